"""A third party's node shows as a built-in does (issue 47): the README's "Writing a node" package, installed
as pip installs one (its module and a dist-info with the README's entry point on the path), runs in a patch
beside a built-in output of the same role (``osc_out``), through ``pointat run --monitor 0`` as a performer
runs it.  Both are on the console's banner among the outputs and on its status lines, both are pointers in
the monitor's state (what its WebSocket sends), both have their direction in the OSCQuery tree, served over
HTTP on 127.0.0.1."""

from __future__ import annotations

import json
import os
import re
import socket
import subprocess
import sys
import time
import urllib.request
from pathlib import Path

ROOT = Path(__file__).resolve().parents[2]
README = (ROOT / "README.md").read_text(encoding="utf-8")

PATCH = """\
# The README's node beside osc_out, both fed the same azimuth.
node lb   loadbang
node tick metro 20
node az   msg 100
node near nearest step=30
node out  osc_out port={port}
lb -> tick -> az
az -> near
az -> out.azimuth
"""


def _section(title: str) -> str:
    start = README.index(f"\n## {title}\n")
    end = README.find("\n## ", start + 1)
    return README[start:end]


def _install(site: Path) -> None:
    """The README's module and its entry point, as pip leaves an installed package."""
    section = _section("Writing a node")
    (code,) = re.findall(r"```python\n(.*?)```", section, flags=re.S)
    (toml,) = re.findall(r"```toml\n(.*?)```", section, flags=re.S)
    group, entry = toml.strip().splitlines()
    assert group == '[project.entry-points."pointat.nodes"]'
    name, _, module = (w.strip().strip('"') for w in entry.partition("="))
    package, _, stem = module.partition(".")
    (site / package).mkdir(parents=True)
    (site / package / "__init__.py").write_text("")
    (site / package / f"{stem}.py").write_text(code)
    info = site / f"{package}-0.1.dist-info"
    info.mkdir()
    (info / "METADATA").write_text(f"Metadata-Version: 2.1\nName: {package}\nVersion: 0.1\n")
    (info / "entry_points.txt").write_text(f"[pointat.nodes]\n{name} = {module}\n")


def _get(url: str):
    with urllib.request.urlopen(url, timeout=5) as r:
        return json.loads(r.read())


def test_the_readmes_node_shows_in_the_console_the_monitor_and_oscquery_as_osc_out_does(tmp_path):
    _install(tmp_path / "site")
    rx = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)  # osc_out's receiver
    rx.bind(("127.0.0.1", 0))
    (tmp_path / "show.pat").write_text(PATCH.format(port=rx.getsockname()[1]))
    env = {
        **os.environ,
        "PYTHONPATH": os.pathsep.join([str(tmp_path / "site"), os.environ.get("PYTHONPATH", "")]),
    }
    cmd = [sys.executable, "-m", "pointat.cli", "run", "show.pat", "--monitor", "0", "--status", "0.2"]
    proc = subprocess.Popen(
        [*cmd, "--for", "60"],
        cwd=tmp_path,
        env=env,
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        text=True,
    )
    try:
        lines = []
        url = None
        while url is None:
            line = proc.stdout.readline()
            assert line, ("the run ended before its banner named the monitor", lines, proc.stderr.read())
            lines.append(line.rstrip("\n"))
            m = re.search(r"monitor  (http://127\.0\.0\.1:\d+)/monitor", line)
            url = m.group(1) if m else None
        # the monitor's state: both are pointers, fed and fresh (a generous ceiling: two busy cores)
        deadline = time.monotonic() + 30
        while True:
            state = _get(url + "/monitor/state")
            pointers = {p["name"]: p for p in state["pointers"]}
            if all(pointers.get(n, {}).get("state") == "ok" for n in ("near", "out")):
                break
            assert time.monotonic() < deadline, state["pointers"]
            time.sleep(0.1)
        for name in ("near", "out"):
            assert (pointers[name]["azimuth"], pointers[name]["elevation"]) == (100.0, 0.0), pointers
            assert pointers[name]["about"], pointers
        assert pointers["near"]["about"] == "says the nearest loudspeaker, one every 30°"
        # OSCQuery: each one's direction, read-only, in the same units
        tree = _get(url + "/")
        aed = {n: tree["CONTENTS"]["pointat"]["CONTENTS"][n]["CONTENTS"]["aed"] for n in ("near", "out")}
        for leaf in aed.values():
            assert (leaf["TYPE"], leaf["ACCESS"], leaf["UNIT"]) == (
                "fff",
                1,
                ["angle.degree", "angle.degree", ""],
            )
            assert leaf["VALUE"] == [100.0, 0.0, 0.0]
        assert _get(url + "/pointat/near/aed?VALUE") == {"VALUE": [100.0, 0.0, 0.0]}
        assert _get(url + "/pointat/near/step")["VALUE"] == [30.0]  # a live parameter, as any node's
        # the console's status lines, a few times a second: until both have said where they point
        status = {name: f"{name}: az 100.0°  el  0.0°" for name in ("near", "out")}
        while not all(any(x.startswith(s) for x in lines) for s in status.values()):
            line = proc.stdout.readline()
            if not line:  # (the run's --for ended first: the assertions below say what was missing)
                break
            lines.append(line.rstrip("\n"))
    finally:
        proc.terminate()
        out, err = proc.communicate(timeout=30)
        rx.close()
    lines += out.splitlines()
    # the console: the banner lists both among the outputs, the status lines say where both point
    assert "  out  nearest 'near': says the nearest loudspeaker, one every 30°" in lines, lines
    assert any(
        re.fullmatch(r"  out  osc_out 'out': OSC to 127\.0\.0\.1:\d+, profile \w+", x) for x in lines
    ), lines
    for said in status.values():
        assert any(x.startswith(said) for x in lines), (said, lines)
    assert "near: the loudspeaker at 90°" in lines, lines  # what the node itself says
    assert proc.returncode == 0, err
