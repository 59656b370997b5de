"""What a receiver and a performer are told while a patch runs: heartbeats and states over OSC (a glove
that drops out and comes back, a filter's flags), the console's banner, status lines and summary, and
presets saved and recalled by OSC.  Each runs ``pointat run`` as a performer would, on free ports."""

from __future__ import annotations

import json
import re
import socket
import subprocess
import sys
import time

import pytest
from pythonosc.osc_message import OscMessage
from pythonosc.udp_client import SimpleUDPClient

from pointat.checking import check
from pointat.expansion import read_spec
from pointat.loader import build, parse_overrides
from pointat.presets import Presets, presets_path
from pointat.registry import Registry
from pointat.testing import free_udp_port


def _udp() -> socket.socket:
    s = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
    s.bind(("127.0.0.1", 0))
    s.settimeout(0.1)
    return s


def _run(patch: str, *args: str, cwd=None) -> subprocess.Popen:
    cmd = [sys.executable, "-m", "pointat.cli", "run", patch, *args]
    return subprocess.Popen(cmd, cwd=cwd, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)


@pytest.mark.slow
def test_the_receiver_is_told_when_the_glove_drops_out_and_comes_back(tmp_path):
    rx = _udp()
    ctl = free_udp_port()
    proc = _run(
        "glove_tqt",
        "--for",
        "10",
        "--set",
        f"out.port={rx.getsockname()[1]}",
        "--set",
        f"ctl.port={ctl}",
        cwd=tmp_path,
    )
    statuses: list[tuple[float, str, float]] = []
    directions = []
    t0 = time.monotonic()
    t_drop = None
    try:
        while proc.poll() is None:
            # the glove out of range for 2 s, once the patch has sent a second of directions (however long
            # this machine took to start it)
            if t_drop is None and len(directions) >= 100:
                SimpleUDPClient("127.0.0.1", ctl).send_message("/pointat/glove/dropout", 2.0)
                t_drop = time.monotonic() - t0
            try:
                msg = OscMessage(rx.recv(1024))
            except TimeoutError:
                continue
            now = time.monotonic() - t0
            if msg.address == "/pointat/1/status":
                statuses.append((now, *msg.params))
            elif msg.address == "/pointat/1/aed":
                directions.append(now)
        out, err = proc.communicate(timeout=30)
    finally:
        rx.close()
        if proc.poll() is None:
            proc.kill()
    assert proc.returncode == 0, err
    assert t_drop is not None, f"only {len(directions)} directions came"
    states = [s for _, s, _ in statuses]
    # heartbeats while all is well, then the dropout, then "ok" again when the glove is back.  The bounds
    # are one-sided: a busy machine only makes these spells longer.
    assert "ok" in states and "dropout" in states, statuses
    first_drop = next(t for t, s, _ in statuses if s == "dropout")
    assert first_drop > t_drop
    last_before = max(t for t in directions if t < first_drop)
    assert first_drop - last_before > 0.4, (last_before, first_drop)  # not before the dropout time (0.5 s)
    back = [t for t, s, _ in statuses if s == "ok" and t > first_drop]
    assert back, statuses
    assert back[0] - first_drop > 1.5, (first_drop, back[0])  # the glove was away for 2 s
    # the heartbeat carries the rate of directions sent over the last second: never above the glove's 100 Hz
    rates = [r for t, s, r in statuses if s == "ok" and t > back[0] + 1.1]
    assert rates and all(0 < r <= 110 for r in rates), statuses
    # the console said it too, and the summary counts the dropout; the live control was acknowledged
    assert "base.m1:" in out and "1 dropouts" in out, out
    assert "live control: /pointat/glove/dropout 2\n" in out, out


def test_the_console_opens_with_a_banner_and_ends_with_a_summary(tmp_path):
    port = free_udp_port()
    proc = _run(
        "glove_tqt",
        "--for",
        "3",
        "--status",
        "1",
        "--set",
        f"out.port={port}",
        "--set",
        "ctl.port=0",
        cwd=tmp_path,
    )
    out, err = proc.communicate(timeout=30)
    assert proc.returncode == 0, err
    lines = out.splitlines()
    assert lines[0].startswith("pointat ") and "glove_tqt: The Pointing-at glove" in lines[0]
    assert any("simulate 'glove': the simulated glove, 100 Hz" in line for line in lines)
    assert any(f"osc_out 'out': OSC to 127.0.0.1:{port}, profile pointat" in line for line in lines)
    assert "  Ctrl-C stops." in lines
    # values for a person: no Pd type words, a direction to 0.1 deg
    assert not [line for line in lines if " list " in line or " symbol " in line or ": vector" in line], out
    assert "gyro nulls (hold the glove still): ready " in out
    shown = [line for line in lines if line.startswith("azimuth elevation distance: ")]
    assert shown and all(len(v.split(".")[1]) == 1 for line in shown for v in line.split(": ")[1].split()), (
        shown
    )
    # a status line a second (a pipe: written as lines), then the summary; "ok" only with a rate, and no
    # direction shown before one was sent (the gyro nulls are measured first)
    summary = lines[lines.index(next(line for line in lines if line.startswith("ran "))) :]
    status = lines[: len(lines) - len(summary)]
    assert sum(line.startswith("out: ") for line in status) >= 2, out
    assert any(line.startswith("out: az ") for line in status), out
    assert any(line.startswith("base.m1: ok, 10") for line in status), out
    assert not any(line.startswith("base.m1: ok, 0 Hz") for line in status), out
    assert not any(line.startswith("out: az") and "(0 sent)" in line for line in status), out
    assert any(
        line.startswith("base.m1: ") and "samples" in line and "no dropout" in line for line in summary
    )
    # nobody listens at the port: datagrams beside datagrams, and why they were refused
    (told,) = [line for line in summary if line.startswith("out: ")]
    assert re.fullmatch(
        rf"out: \d+ updates to 127\.0\.0\.1:{port} \((\d+) datagrams sent, (\d+) refused: the receiver "
        r"was not listening\)",
        told,
    ), told


def test_presets_are_saved_and_recalled_by_osc_beside_the_patch(tmp_path):
    patch = tmp_path / "show.pat"
    patch.write_text(
        "# Two live settings and nothing else.\n"
        "node ctl  osc_in port=0\n"
        "node tick metro 50\n"
        "node lim  speedlim 100\n"
        "node on   loadbang\n"
        "on -> tick -> lim\n"
    )
    # in-process: the runtime's own values are there to look at
    rt = build(check(read_spec(str(patch)), Registry().load_builtins(), parse_overrides([])))
    path = presets_path(patch)
    assert path == tmp_path / "show.presets.json"
    rt.presets = Presets(rt, path)
    said: list[str] = []
    rt.console = said.append
    th = rt.run_in_thread(10)
    try:
        deadline = time.monotonic() + 5
        while rt.nodes["ctl"].address[1] == 0 and time.monotonic() < deadline:  # bound as it starts
            time.sleep(0.01)
        osc = SimpleUDPClient("127.0.0.1", rt.nodes["ctl"].address[1])

        def settle(check):
            deadline = time.monotonic() + 5
            while not check() and time.monotonic() < deadline:
                time.sleep(0.01)
            assert check()

        osc.send_message("/pointat/tick/interval", 20.0)
        osc.send_message("/pointat/lim/interval", 250.0)
        settle(lambda: rt.nodes["lim"].p.interval == 250.0)
        osc.send_message("/pointat/preset/save", "stage")
        settle(lambda: path.exists())
        saved = json.loads(path.read_text())
        assert saved["presets"]["stage"]["tick"]["interval"] == 20.0
        assert saved["presets"]["stage"]["lim"]["interval"] == 250.0
        osc.send_message("/pointat/tick/interval", 80.0)
        osc.send_message("/pointat/lim/interval", 10.0)
        settle(lambda: rt.nodes["lim"].p.interval == 10.0)
        osc.send_message("/pointat/preset/recall", "stage")
        settle(lambda: rt.nodes["lim"].p.interval == 250.0 and rt.nodes["tick"].p.interval == 20.0)
        osc.send_message("/pointat/preset/recall", "nope")  # refused, told, nothing changed
        time.sleep(0.2)
        assert rt.nodes["lim"].p.interval == 250.0
    finally:
        rt.stop()
        th.join(5)
    assert "preset 'stage' saved (2 settings)" in said, said
    assert any(line.startswith("preset 'stage' recalled (2 settings)") for line in said), said
    # a second run finds them, and a file that cannot be read is never written over
    again = Presets(rt, path)
    assert again.names() == ["stage"]
    path.write_text("{not json")
    broken = Presets(rt, path)
    assert not broken.writable
    broken.save("other")
    assert path.read_text() == "{not json"
