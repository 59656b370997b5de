"""The command line as a user meets it: every shipped patch checks and runs; errors never show a traceback."""

import logging
import os
import re
import shutil
import socket
import subprocess
import sys
import threading
import time
from pathlib import Path

import pytest

from pointat.checking import check
from pointat.cli import main
from pointat.expansion import read_spec
from pointat.loader import parse_overrides
from pointat.maths.calibration import Calibration
from pointat.node import Param, ParamError
from pointat.registry import default_registry
from pointat.testing import beside, free_udp_port, sink_port, wait_until

ROOT = Path(__file__).resolve().parent.parent
PATCHES = sorted((ROOT / "patches").glob("*.pat")) + sorted((ROOT / "examples").glob("**/*.pat"))


GLOVE = ROOT / "patches" / "glove_tqt.pat"


def pointat(*args, timeout=60, cwd=ROOT):
    return subprocess.run(
        [sys.executable, "-m", "pointat.cli", *map(str, args)],
        capture_output=True,
        text=True,
        timeout=timeout,
        cwd=cwd,
    )


@pytest.mark.parametrize("path", PATCHES, ids=lambda p: p.name)
def test_every_shipped_patch_checks(path, capsys):
    assert main(["check", str(path)]) == 0
    assert "ok (" in capsys.readouterr().out


@pytest.fixture(scope="module")
def copy_of_repo(tmp_path_factory):
    """patches/ and examples/ copied out, so what the patches write lands outside the repository."""
    import shutil

    root = tmp_path_factory.mktemp("repo")
    for folder in ("patches", "examples"):
        shutil.copytree(ROOT / folder, root / folder)
    (root / "pointat").mkdir()
    (root / "pointat" / "data").symlink_to(ROOT / "pointat" / "data")
    return root


@pytest.mark.parametrize("path", PATCHES, ids=lambda p: p.name)
def test_a_shipped_patch_run_by_a_test_takes_no_port_of_a_show(path):
    """beside(): every port a shipped patch listens on is a free one (0) and every port it sends to is the
    tests' own sink, so the suite runs beside a performer's patch (9001 held, a renderer on 9000)."""
    checked = check(read_spec(path), default_registry.load_builtins(), parse_overrides(_sets(beside(path))))
    for name, r in checked.nodes.items():
        if r.cls.type_name == "osc_in":
            assert r.values["port"] == 0, name
        if "port" in r.values and r.cls.type_name in ("osc_out", "osc_send", "osc_body"):
            assert r.values["port"] == sink_port(), name
            assert all(int(str(to).rpartition(":")[2]) == sink_port() for to in r.values["to"]), name


def _sets(args: list[str]) -> list[str]:
    return [a for a in args if a != "--set"]


RUN_BRIEFLY = [p for p in PATCHES if "evaluate" not in p.name]


@pytest.fixture(scope="module")
def shipped_runs(copy_of_repo, tmp_path_factory):
    """Every shipped patch run for 0.75 s (3 s each in tests/test_wheel.py, the slow tier), four at a time (each is mostly a Python start-up and a wait):
    {path: the finished process}."""
    from concurrent.futures import ThreadPoolExecutor

    here = tmp_path_factory.mktemp("cwd")  # what a patch writes where it is run from lands here

    def run(path):
        copy = copy_of_repo / path.relative_to(ROOT)
        return pointat("run", copy, "--for", "0.75", *beside(copy), timeout=600, cwd=here)

    with ThreadPoolExecutor(max_workers=4) as pool:
        return dict(zip(RUN_BRIEFLY, pool.map(run, RUN_BRIEFLY), strict=True))


@pytest.mark.parametrize("path", RUN_BRIEFLY, ids=lambda p: p.name)
def test_every_shipped_patch_runs_briefly(path, shipped_runs):
    out = shipped_runs[path]
    assert out.returncode == 0, out.stderr
    assert "Traceback" not in out.stderr
    assert "ERROR" not in out.stderr, out.stderr


def run_until(*args: str, lines: int, prefix: str = "azimuth elevation distance:", ceiling: float = 120.0):
    """``pointat run ARGS`` until it has printed ``lines`` lines starting with ``prefix`` (however long a
    loaded machine takes, up to ``ceiling`` seconds), then stopped with Ctrl-C: (exit status, those
    lines, standard error)."""
    import signal
    import threading

    proc = subprocess.Popen(
        [sys.executable, "-m", "pointat.cli", "run", *args],
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        text=True,
        cwd=ROOT,
    )
    timer = threading.Timer(ceiling, proc.kill)
    timer.start()
    got = []
    try:
        for line in proc.stdout:
            if line.startswith(prefix):
                got.append(line.rstrip("\n"))
                if len(got) == lines:
                    proc.send_signal(signal.SIGINT)
                    break
        _, err = proc.communicate(timeout=ceiling)
    finally:
        timer.cancel()
        proc.kill()
    return proc.returncode, got, err


def test_main_job_prints_directions():
    code, lines, err = run_until("patches/glove_tqt.pat", *beside(GLOVE), lines=3)
    assert code == 0, err
    assert len(lines) == 3, err
    az = float(lines[-1].split(":")[1].split()[0])
    assert -180 <= az < 180


@pytest.mark.slow
def test_a_terminal_that_stops_reading_does_not_stop_the_patch(tmp_path):
    """A terminal paused with Ctrl-S (or a pipe nobody reads) fills, and a write to it blocks: the OSC must
    flow on all the same, and the console hears afterwards how many lines it missed."""
    import socket

    rx = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
    rx.bind(("127.0.0.1", 0))
    rx.settimeout(0.2)
    (tmp_path / "chatty.pat").write_text(
        f"node m metro 1\nnode p print {'x' * 200}\nnode o osc_out port={rx.getsockname()[1]} address=/t\n"
        "node one msg 1\nnode go loadbang\ngo -> m\nm -> p\nm -> one -> o\n"
    )
    proc = subprocess.Popen(
        [sys.executable, "-m", "pointat.cli", "run", str(tmp_path / "chatty.pat"), "--for", "4"],
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        cwd=ROOT,
    )
    try:  # 200 KB of console lines a second, and nobody reads them (the pipe holds 64 KB)
        got, end = [], time.monotonic() + 6  # the run: 4 s; then it waits for its reader to be back
        while time.monotonic() < end:
            try:
                rx.recv(64)
                got.append(time.monotonic())
            except TimeoutError:
                pass
        out, err = proc.communicate(timeout=30)  # the reader is back
    finally:
        proc.kill()
        rx.close()
    assert proc.returncode == 0, err
    assert len(got) > 3000 and got[-1] - got[0] > 3.0  # 1000 a second for 4 s, to the end
    assert b"lines not shown: the terminal did not take them" in out


def test_a_pipe_closed_by_its_reader_ends_the_run_quietly():  # pointat run ... | head -2
    proc = subprocess.Popen(
        [sys.executable, "-m", "pointat.cli", "run", "patches/glove_tqt.pat", "--for", "60", *beside(GLOVE)],
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        cwd=ROOT,
    )
    try:
        first = [proc.stdout.readline() for _ in range(2)]
        proc.stdout.close()
        assert proc.wait(timeout=30) == 0
    finally:
        proc.kill()
    assert all(first) and b"Traceback" not in proc.stderr.read()
    proc.stderr.close()


def test_rt_runs_at_real_time_priority_or_says_why_not(tmp_path):
    """``--rt`` asks for SCHED_FIFO as Pd's -rt does; granted (root) or not, the patch runs."""
    probe = tmp_path / "probe.py"  # a plugin node that reports the scheduler thread's policy
    probe.write_text(
        "import os\nfrom pointat import Node, Outlet, register\n"
        "@register('policy_probe')\nclass Probe(Node):\n"
        "    outlets = (Outlet('out', 'symbol'),)\n"
        "    def loadbang(self):\n"
        "        policy = os.sched_getscheduler(0) if hasattr(os, 'sched_getscheduler') else -1\n"
        "        self.out(0, 'fifo' if policy == getattr(os, 'SCHED_FIFO', -2) else 'normal')\n"
    )
    patch = tmp_path / "rt.pat"
    patch.write_text("node p policy_probe\nnode show print policy\np -> show\n")
    out = pointat("run", "--rt", "--plugins", tmp_path, patch, "--for", "0.5")
    assert out.returncode == 0, out.stderr
    granted = "--rt: real-time priority" not in out.stderr
    assert ("policy: fifo" if granted else "policy: normal") in out.stdout, (
        out.stdout,
        out.stderr,
    )
    if not granted:
        assert "running at normal priority" in out.stderr
    plain = pointat("run", "--plugins", tmp_path, patch, "--for", "0.5")
    assert "policy: normal" in plain.stdout, plain.stdout


def test_spin_runs_a_patch_and_is_refused_with_rt_or_out_of_range(capsys):
    code, _lines, err = run_until("-v", "--spin", "2", "patches/glove_tqt.pat", *beside(GLOVE), lines=1)
    assert code == 0, err
    assert "polling for input for 2 ms after each input" in err
    assert main(["run", "--rt", "--spin", "2", "patches/glove_tqt.pat", "--for", "1", *beside(GLOVE)]) == 2
    assert "--spin with --rt" in capsys.readouterr().err
    for bad in ("-1", "x", "nan", "2000"):
        with pytest.raises(SystemExit) as exc:
            main(["run", "--spin", bad, "patches/glove_tqt.pat", "--for", "1", *beside(GLOVE)])
        assert exc.value.code == 2 and "argument --spin" in capsys.readouterr().err, bad


def test_rt_keeps_the_cpus_out_of_deep_idle_while_it_runs_or_says_why_not(tmp_path):
    """``--rt`` holds a PM QoS request of 0 µs (/dev/cpu_dma_latency) while the patch runs, and lets go
    when it ends; where it may not, it says why and the patch runs all the same."""
    import struct

    from pointat.runtime import CPU_DMA_LATENCY

    def current() -> int | None:  # the system's wake-up latency target now, when we may read it
        try:
            with open(CPU_DMA_LATENCY, "rb") as f:
                return struct.unpack("=i", f.read(4))[0]
        except OSError:
            return None

    probe = tmp_path / "qos.py"
    probe.write_text(
        "import struct\nfrom pointat import Node, Outlet, register\n"
        "@register('qos_probe')\nclass Probe(Node):\n"
        "    outlets = (Outlet('out', 'int'),)\n"
        "    def loadbang(self):\n"
        "        try:\n"
        f"            with open({CPU_DMA_LATENCY!r}, 'rb') as f:\n"
        "                self.out(0, struct.unpack('=i', f.read(4))[0])\n"
        "        except OSError:\n"
        "            self.out(0, -1)\n"
    )
    patch = tmp_path / "qos.pat"
    patch.write_text("node p qos_probe\nnode show print qos\np -> show\n")
    before = current()
    out = pointat("run", "--rt", "--plugins", tmp_path, patch, "--for", "0.5")
    assert out.returncode == 0, out.stderr
    if "the CPUs may sleep deeply" in out.stderr:
        assert "not permitted" in out.stderr or "not available" in out.stderr, out.stderr
    else:
        assert "qos: 0" in out.stdout.splitlines(), (out.stdout, out.stderr)
        assert current() == before != 0  # let go when the patch ended


def test_a_bad_patch_gives_located_errors_and_no_traceback(tmp_path):
    bad = tmp_path / "bad.pat"
    bad.write_text(
        "node a metr 100\nnode b print\nnode c tqt k=fast\na -> b.3\nnode g gyro_integrator renormalize=0\nnode v vbap layout=[0, 0]\n"
    )
    out = pointat("check", bad)
    assert out.returncode == 2
    assert "Traceback" not in out.stderr
    assert f"{bad}:1: error: node 'a': unknown node type 'metr' (did you mean 'metro'?)" in out.stderr
    assert f"{bad}:3: error: node 'c' (tqt): parameter 'k' expects a number; got 'fast'" in out.stderr
    # refused by check, not only when run builds the node
    assert f"{bad}:6: error: node 'v' (vbap): loudspeakers 1 and 2 point the same way" in out.stderr
    assert (
        f"{bad}:5: error: node 'g' (gyro_integrator): parameter 'renormalize' expects a whole number >= 1"
        in (out.stderr)
    )
    out = pointat("run", bad)
    assert out.returncode == 2 and "Traceback" not in out.stderr


def test_missing_patch_file_is_a_clear_error(tmp_path):
    out = pointat("run", tmp_path / "nope.pat")
    assert out.returncode == 2 and "cannot read patch" in out.stderr and "Traceback" not in out.stderr


def test_text_that_is_not_utf8_or_starts_with_a_bom_and_targets_that_cannot_be_written(tmp_path, capsys):
    latin = tmp_path / "latin.pat"
    latin.write_bytes(b'node a loadbang\nnode p print prefix="caf\xe9"\na -> p\n')
    assert main(["check", str(latin)]) == 2
    assert f"{latin}:2: error: not UTF-8 text: byte 0xe9 cannot be read" in capsys.readouterr().err
    bom = tmp_path / "bom.pat"
    bom.write_bytes(b"\xef\xbb\xbfnode a loadbang\n")  # as some Windows editors save
    assert main(["check", str(bom)]) == 0
    assert main(["convert", str(bom), str(tmp_path / "bom.pd"), "--no-stubs"]) == 0
    pd = tmp_path / "bom.pd"
    pd.write_bytes(b"\xef\xbb\xbf" + pd.read_bytes())
    assert main(["check", str(pd)]) == 0
    capsys.readouterr()
    for command in (
        ["convert", str(bom), str(tmp_path / "no" / "x.pd")],
        ["graph", str(bom), "-o", "/no/x.dot"],
    ):
        assert main(command) == 2
        err = capsys.readouterr().err
        assert "error: cannot write " in err and "No such file or directory" in err


def test_nodes_and_help_cover_every_node_type(capsys):
    assert main(["nodes"]) == 0
    listing = capsys.readouterr().out
    for cls in default_registry:
        assert cls.type_name in listing
        text = cls.help_text()
        assert "inlets:" in text and "outlets:" in text and "parameters" in text
        assert cls.__doc__, f"{cls.type_name} has no help text"
    assert main(["help", "tqt"]) == 0
    assert "Gauss-Newton" in capsys.readouterr().out
    assert main(["help", "tqtt"]) == 2
    assert "did you mean 'tqt'" in capsys.readouterr().err


def test_help_examples_are_valid_patches():
    from pointat.loader import check
    from pointat.patchfile import parse_patch

    for cls in default_registry:
        if cls.example:
            check(parse_patch(cls.example, f"<example of {cls.type_name}>"), default_registry)


def test_graph_writes_dot(tmp_path):
    out = pointat("graph", "patches/pointing_at.pat", "-o", tmp_path / "g.dot")
    assert out.returncode == 0
    dot = (tmp_path / "g.dot").read_text()
    assert dot.startswith('digraph "pointing_at"') and '"glove" -> "base"' in dot


def test_graph_draws_braces_bars_and_quotes_as_text_on_two_lines(tmp_path, capsys, require_tool):
    require_tool(shutil.which("dot") is not None, "Graphviz's dot is not installed")
    odd = tmp_path / "odd.pat"
    odd.write_text(
        'node out osc_out profile=generic address=/glove/{n}/x\nnode p print prefix="a|b <c> \\\\ \\"q\\""\n'
    )
    assert main(["graph", str(odd), "-o", str(tmp_path / "odd.dot")]) == 0, capsys.readouterr().err
    texts = re.findall(r"<text[^>]*>([^<]*)</text>", (tmp_path / "odd.svg").read_text())
    assert "out" in texts and "[osc_out profile=generic address=/glove/{n}/x]" in texts  # two lines, not \n
    assert any(t.startswith("[print prefix=") and "a|b &lt;c&gt;" in t for t in texts)


def test_set_overrides_and_reports_unknown_nodes():
    out = pointat("check", "patches/glove_tqt.pat", "--set", "fuse.k=0.5", "--set", "nope.k=1")
    assert out.returncode == 2 and "--set nope.k: no node named 'nope'" in out.stderr


def test_convert_refuses_a_pd_file_named_like_a_node_type(tmp_path):
    # Pd finds abstractions beside the patch first: [calibrate] inside calibrate.pd would be the patch itself
    out = pointat("convert", "patches/calibrate_glove.pat", tmp_path / "calibrate.pd")
    assert out.returncode == 2 and "calibrate.pd is named like its own [calibrate] box" in out.stderr
    assert not (tmp_path / "calibrate.pd").exists()


def test_convert_round_trip_to_pd_and_back_elsewhere_keeps_the_graph(tmp_path):
    from pointat.loader import check, read_spec

    pd_file, back = tmp_path / "pd" / "glove.pd", tmp_path / "native" / "glove.pat"
    pd_file.parent.mkdir()
    back.parent.mkdir()
    assert pointat("convert", "patches/evaluate_tqt.pat", pd_file).returncode == 0
    assert (pd_file.parent / "pointat-stubs" / "tqt.pd").exists()
    glove = tmp_path / "pd" / "glove_tqt.pd"  # the header says which abstraction it flattened
    assert pointat("convert", "patches/glove_tqt.pat", glove).returncode == 0
    assert read_spec(glove).doc.endswith(
        "Abstractions flattened, each into nodes named INSTANCE/NODE: tqt (lib/tqt_fusion.pat)."
    )
    assert pointat("convert", pd_file, back).returncode == 0
    shipped = read_spec(ROOT / "patches" / "evaluate_tqt.pat")
    shipped.out = str(pd_file.parent)  # (what it writes: the first copy, the .pd, writes beside itself)
    a = check(shipped, default_registry.load_builtins())
    b = check(read_spec(back), default_registry)
    assert os.path.normpath(b.nodes["sink"].values["file"]) == str(pd_file.parent / "evaluate_tqt.csv")

    def graph(checked):  # path parameters compared as the files they name
        return {
            n: (r.cls, {k: os.path.normpath(v) if k == "file" else v for k, v in r.values.items()})
            for n, r in checked.nodes.items()
        }

    assert graph(a) == graph(b)
    assert sorted(a.wires) == sorted(b.wires)
    # a converted Pd patch with subpatches (nodes named sub/x) is a valid native patch
    out = tmp_path / "sub.pat"
    assert pointat("convert", ROOT / "tests" / "data" / "pd" / "subpatch.pd", out).returncode == 0
    assert pointat("check", out).returncode == 0


def test_convert_elsewhere_keeps_abstractions_and_their_files_in_reach(tmp_path, capsys):
    from pointat.loader import check, read_spec

    (tmp_path / "lib").mkdir()
    (tmp_path / "lib" / "rec.pat").write_text("inlet in -> r\nnode r record file=take.csv\n")
    (tmp_path / "top.pat").write_text("node lb loadbang\nnode a lib/rec.pat\nlb -> a\n")
    for target in (tmp_path / "pd" / "top.pd", tmp_path / "native" / "top.pat"):
        target.parent.mkdir()
        assert main(["convert", str(tmp_path / "top.pat"), str(target), "--no-stubs"]) == 0, (
            capsys.readouterr()
        )
        [r] = [r for n, r in check(read_spec(target), default_registry).nodes.items() if n.endswith("r")]
        assert Path(r.values["file"]).resolve() == tmp_path / "lib" / "take.csv"  # where the .pat records


def test_a_node_that_cannot_start_is_an_error_exit_not_a_traceback(tmp_path):
    """What check cannot know, as it opens nothing: a port another program holds."""
    bad = tmp_path / "p.pat"
    with socket.socket(socket.AF_INET, socket.SOCK_DGRAM) as held:
        held.bind(("127.0.0.1", 0))
        bad.write_text(f"node ctl osc_in port={held.getsockname()[1]}\nnode p print\nctl -> p\n")
        assert pointat("check", bad).returncode == 0
        out = pointat("run", bad)
    assert out.returncode == 2 and "Traceback" not in out.stderr
    assert f"{bad}:1: error: node 'ctl' (osc_in): cannot start" in out.stderr


def test_check_reads_the_files_the_nodes_will_read(tmp_path, capsys):
    # what `run` would find only as the patch starts, `check` finds before the show: a calibration spoiled
    # by a hand edit, a recording that is not one, a loudspeaker layout that does not parse
    (tmp_path / "cal.json").write_text('{"gyro_null": [1, 2,\n')
    (tmp_path / "take.csv").write_text("a,b\n1,2\n")
    (tmp_path / "room.json").write_text('{"loudspeakers": "all of them"}')
    patch = tmp_path / "p.pat"
    patch.write_text(
        "node nulls offset calibration=cal.json\n"
        "node src replay file=take.csv\n"
        "node spk vbap file=room.json\n"
        "node show print\n"
        "src.gyro -> show\n"
        "spk.speaker -> show\n"
    )
    assert main(["check", str(patch)]) == 2
    err = capsys.readouterr().err
    assert f"{patch}:1: error: node 'nulls' (offset): calibration file " in err
    assert "not valid JSON" in err
    assert f"{patch}:2: error: node 'src' (replay): " in err and "expected a header line" in err
    assert f"{patch}:3: error: node 'spk' (vbap): " in err
    assert "3 errors" in err
    # mended, the same patch checks but for a file not there, which stops the start (as run would stop)
    cal = Calibration()
    cal.acc_null[:] = (2040.0, 2051.0, 2046.0)
    cal.save(tmp_path / "cal.json")
    (tmp_path / "take.csv").write_text("t,gyr_x,gyr_y,gyr_z\n0.0,0,0,0\n0.01,0,0,0\n")
    (tmp_path / "room.json").unlink()
    assert main(["check", str(patch)]) == 2
    err = capsys.readouterr().err
    said = f"{patch}:3: error: node 'spk' (vbap): parameter 'file': no file "
    assert said in err and "(it cannot start without it)" in err and "1 error" in err
    assert main(["run", str(patch), "--for", "0"]) == 2
    assert said in capsys.readouterr().err


@pytest.mark.parametrize("value", ["nan", "-1", "inf", "soon"])
def test_for_takes_a_finite_number_of_seconds(value, capsys):
    with pytest.raises(SystemExit) as exc:
        main(["run", "patches/glove_tqt.pat", "--for", value])
    assert exc.value.code == 2
    err = capsys.readouterr().err
    assert "argument --for: expected a" in err and repr(value) in err


def test_send_delivers_one_osc_message_with_typed_arguments():
    import socket

    from pythonosc.osc_message import OscMessage

    with socket.socket(socket.AF_INET, socket.SOCK_DGRAM) as rx:
        rx.bind(("127.0.0.1", 0))
        rx.settimeout(10)
        port = rx.getsockname()[1]
        out = pointat("send", str(port), "/pointat/tqt/fuse/k_heading", "3", "0.05", "word", "3000000000")
        assert out.returncode == 0, out.stderr
        msg = OscMessage(rx.recv(1024))
    assert msg.address == "/pointat/tqt/fuse/k_heading"
    assert msg.params[0] == 3 and msg.params[2] == "word" and msg.params[3] == 3e9
    assert msg.params[1] == pytest.approx(0.05)  # float32
    assert [t for t in msg.dgram.split(b",", 1)[1][:4].decode()] == ["i", "f", "s", "f"]
    bad = pointat("send", "99999", "/x")
    assert bad.returncode == 2 and "expected a port 1..65535 or host:port" in bad.stderr


def test_send_to_a_port_nobody_listens_on_says_so_and_fails():
    port = free_udp_port()  # nothing listens there once it is closed
    out = pointat("send", str(port), "/pointat/press/bang")
    assert out.returncode == 1
    assert (
        f"nothing listens on UDP 127.0.0.1:{port}: is the patch running, with osc_in port={port}?"
        in out.stderr
    )


def test_what_building_a_node_refuses_check_refuses_first():
    # a number a node's constructor would refuse (renormalize=0, seed=-1) must not pass `check` and fail
    # only as the show starts: every numeric parameter of every node type, at 0, -1 and 1e9
    failures = []
    logging.disable(logging.CRITICAL)
    try:
        for name in sorted(default_registry.load_builtins().names()):
            cls = default_registry.get(name)
            if cls.type_name != name or name == "record":  # record opens its file as it is built
                continue
            for p in cls.params:
                if p.type not in ("int", "float"):
                    continue
                for v in (0, -1, 10**9):
                    try:
                        values = cls.resolve_params((), {p.name: v})
                        cls.validate(values)
                        cls.layout(values)
                    except (ParamError, ValueError):
                        continue  # refused by check: fine
                    try:
                        cls(name, values).close()
                    except Exception as exc:
                        failures.append(f"{name}.{p.name}={v}: {exc}")
    finally:
        logging.disable(logging.NOTSET)
    assert failures == []


def test_a_pd_file_is_read_as_pd_whatever_its_name_says_and_an_empty_patch_is_told(tmp_path, capsys):
    pd_text = (
        "#N canvas 0 0 450 300 12;\n#X obj 10 10 loadbang;\n#X obj 10 40 print hi;\n#X connect 0 0 1 0;\n"
    )
    for name in ("OK.PD", "ok.pat"):  # from a system that ignores case; a download saved under another name
        (tmp_path / name).write_text(pd_text)
        assert main(["check", str(tmp_path / name)]) == 0
        assert capsys.readouterr().out == f"{tmp_path / name}: ok (2 nodes, 1 wire)\n"
    (tmp_path / "notes.pat").write_text("# only a comment\n")
    assert main(["check", str(tmp_path / "notes.pat")]) == 0
    captured = capsys.readouterr()
    assert "ok (0 nodes, 0 wires, 1 warning)" in captured.out
    assert f"{tmp_path / 'notes.pat'}: warning: the patch has no nodes: it does nothing" in captured.err
    (tmp_path / "g.pat").write_text("node a loadbang\n")
    assert main(["convert", str(tmp_path / "g.pat"), str(tmp_path / "G.PD"), "--no-stubs"]) == 0
    assert (tmp_path / "G.PD").read_text().startswith("#N canvas")  # Pd's text, not the native one


def test_files_a_node_would_write_where_it_cannot_are_refused_by_check(tmp_path, capsys):
    (tmp_path / "afile").write_text("")
    patch = tmp_path / "out.pat"
    patch.write_text(
        "node l loadbang\n"
        "node r record file=nodir/x.csv\n"
        "node m midi_out file=afile/x.mid\n"
        "node c calibrate file=nodir/calibration.json\n"
        "node f record file=.\n"
        "l -> r\n"
    )
    assert main(["check", str(patch)]) == 2
    err = capsys.readouterr().err
    nodir = tmp_path / "nodir"
    assert (
        f"{patch}:2: error: node 'r' (record): parameter 'file': cannot write '{nodir}/x.csv': the folder '{nodir}' does not exist"
        in err
    )
    assert f"{patch}:3: error: node 'm' (midi_out): parameter 'file': cannot write" in err
    assert f"the folder '{tmp_path / 'afile'}' is a file, not a folder" in err
    assert f"{patch}:4: error: node 'c' (calibrate): parameter 'file': cannot write" in err
    assert (
        f"{patch}:5: error: node 'f' (record): parameter 'file': '{tmp_path}' is a folder: name a file in it"
        in err
    )


def test_stubs_that_cannot_be_written_are_an_error_and_convert_then_writes_nothing(tmp_path, capsys):
    (tmp_path / "g.pat").write_text("node a loadbang\n")
    (tmp_path / "taken").write_text("")
    assert main(["stubs", str(tmp_path / "taken")]) == 2
    assert f"error: cannot write the stubs to {tmp_path / 'taken'}: File exists" in capsys.readouterr().err
    (tmp_path / "out").mkdir()
    (tmp_path / "out" / "pointat-stubs").write_text("")  # a file where convert puts its stubs folder
    assert main(["convert", str(tmp_path / "g.pat"), str(tmp_path / "out" / "g.pd")]) == 2
    assert "error: cannot write the stubs to" in capsys.readouterr().err
    assert not (tmp_path / "out" / "g.pd").exists()


def test_a_value_given_on_the_command_line_is_blamed_with_the_line_it_lands_on(tmp_path, capsys):
    assert main(["check", "patches/glove_tqt.pat", "--set", "out.port=70000"]) == 2
    err = capsys.readouterr().err
    assert "(osc_out): " in err and "(given on the command line: --set out.port=70000)" in err


def test_a_list_given_on_the_command_line_is_read_as_pd_reads_a_message(capsys):
    # --set moves.relative="acc q": two atoms, as [acc q] in a patch (it was one word, "acc q", refused)
    assert main(["check", "patches/gestures.pat", "--set", "moves.relative=acc q"]) == 0
    assert main(["check", "patches/gestures.pat", "--set", "moves.relative=acc x"]) == 2
    assert "relative takes acc and q; got acc x" in capsys.readouterr().err
    assert Param("at", "vector", (0.0, 0.0, 0.0), size=3).coerce("1 2 3.5") == (1.0, 2.0, 3.5)
    assert Param("ids", "list", (1,)).coerce("2") == ("2",)  # one word stays one
    assert Param("ids", "list", (1,)).coerce("1 2") == (1, 2)


def test_send_takes_an_ipv6_address_in_brackets():
    with socket.socket(socket.AF_INET6, socket.SOCK_DGRAM) as sock:
        try:
            sock.bind(("::1", 0))
        except OSError as exc:  # a container without IPv6
            pytest.skip(f"no IPv6 loopback here: {exc}")
        sock.settimeout(5)
        port = sock.getsockname()[1]
        assert main(["send", f"[::1]:{port}", "/x", "1"]) == 0
        assert sock.recv(100).startswith(b"/x\x00")


def test_run_watch_reloads_a_saved_patch_and_refuses_a_broken_one(tmp_path):
    """``pointat run --watch`` as a performer runs it: a save runs (the metro kept, the print made anew);
    a broken save is said with its file:line on stderr and the patch goes on."""
    path = tmp_path / "p.pat"
    path.write_text("node m metro 20\nnode show print prefix=before\nm -> show\nnode lb loadbang\nlb -> m\n")
    proc = subprocess.Popen(
        [sys.executable, "-m", "pointat.cli", "run", str(path), "--watch", "--for", "60", "--status", "0"],
        cwd=tmp_path,
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        text=True,
    )
    out: list[str] = []
    err: list[str] = []
    for stream, into in ((proc.stdout, out), (proc.stderr, err)):
        threading.Thread(target=lambda s=stream, i=into: i.extend(s), daemon=True).start()

    def said(lines: list[str], text: str, after: int = 0) -> bool:
        return wait_until(lambda: any(text in line for line in lines[after:]), timeout=30)

    try:
        assert said(out, "before: bang"), out
        path.write_text(path.read_text().replace("prefix=before", "prefix=after"))
        assert said(out, "reloaded p.pat: 2 nodes kept, 1 made anew (show)"), out
        assert said(out, "after: bang"), out
        path.write_text(path.read_text() + "m -> nowhere\n")
        assert said(err, "not reloaded (1 error); the patch running goes on unchanged"), err
        assert any(line.startswith(f"ERROR pointat.reload:   {path}:6: error: ") for line in err), err
        shown = len(out)
        assert said(out, "after: bang", shown), out  # still running
    finally:
        proc.terminate()
        proc.wait(timeout=20)
