"""The compiled glove chain (pointat.compiled) against the nodes: the same datagrams, to the bit.

Recorded takes go through one patch twice, node by node and compiled, as frames of a base station with
three motes: the simulated glove's take (rolls into distance mode and back) and the vendored BROAD trial
(a real IMU, its gyro scaled up so that it clips: the saturation flags come and go).  On the way, live
control reaches the chains (a reference capture, a filter gain, new gyro nulls, a new source number):
each hands its chain back to the nodes and the chain is taken up again.  Every datagram at a real UDP
socket, every value a listener outside the chain hears and every flag must be equal.  The last test runs
``pointat run`` itself on a pseudo-terminal, as a performer would, both ways.
"""

from __future__ import annotations

import gzip
import os
import shutil
import socket
import subprocess
import sys
import threading
import time
from pathlib import Path

import numpy as np
import pytest

from pointat.compiled import build
from pointat.control import control
from pointat.devices.mote_frame import Frame, MoteSpec, encode_frame
from pointat.maths.evaluation import load_broad
from pointat.testing import beside, patch, wait_until

DATA = Path(__file__).resolve().parents[2] / "pointat" / "data"
GLOVE_PATCH = Path(__file__).resolve().parents[2] / "patches" / "glove_tqt.pat"

GLOVE = """
node nulls{i} offset samples=50
node units{i} scaling
node tqt{i}   tqt rate=100 mode=robust
node ref{i}   reference mode=heading
node dir{i}   azi_ele
node roll{i}  roll_distance
node out{i}   osc_out host=127.0.0.1 port={port} source={i} {out}
base.m{i} -> nulls{i} -> units{i}
units{i}.mag -> tqt{i}.mag
units{i}.accel -> tqt{i}.accel
units{i}.range -> tqt{i}.range
units{i}.gyro -> tqt{i}.gyro
tqt{i}.flags -> flags{i}
tqt{i}.flags -> out{i}.flags
tqt{i}.quat -> ref{i}
press -> ref{i}.capture
ref{i} -> dir{i}
ref{i} -> roll{i}
dir{i}.elevation -> out{i}.elevation
roll{i}.distance -> out{i}.distance
roll{i}.azimuth -> out{i}.azimuth
node flags{i} collect
"""

OUTS = (
    "profile=pointat",
    "profile=adm",
    "profile=generic address=/g/{n} fields=[n, spread, az, el, dist_m, dist01, az_right] radius=3",
)


def _patch_text(port: int) -> str:
    text = "node base mote ids=[1, 2, 3] rate=100\nnode press msg bang\nnode show collect\nnode tag collect\n"
    text += "".join(GLOVE.format(i=i + 1, port=port, out=o) for i, o in enumerate(OUTS))
    # listeners outside the chains: glove 1's azimuth, glove 2's frames
    return text + "node modes collect\nroll1.azimuth -> show\nroll1.mode -> modes\nbase.m2 -> tag\n"


def _takes(n: int) -> np.ndarray:
    """(n, 3, 9) counts: the simulated take, BROAD with its gyro clipping, BROAD turned about."""
    with gzip.open(DATA / "glove_take.csv.gz", "rt") as fh:
        sim = np.loadtxt(fh, delimiter=",", comments="#", skiprows=3)[:, 1:]
    b = load_broad(DATA / "01_undisturbed_slow_rotation_A.csv.gz")
    spec = MoteSpec()
    step = 3  # 286 Hz -> about 100 Hz
    si = np.hstack([np.degrees(b["gyr"]), b["acc"], b["mag"] / 100.0])[::step]
    fast = np.argmax(np.abs(si[:, :3]).max(axis=1))
    si = np.vstack([si[:200], si[fast - 1200 :]])  # at rest (the nulls), then up to its fastest turn
    clipped = si * np.array([4.0] * 3 + [1.0] * 6)  # four times the turn rate: the gyro clips
    turned = si[::-1].copy()
    rows = []
    for k in range(n):
        rows.append(
            [
                sim[k % len(sim)],
                spec.to_counts(clipped[k % len(clipped)]),
                spec.to_counts(turned[k % len(turned)]),
            ]
        )
    return np.asarray(rows, dtype=np.int64)


EVENTS = {  # frame -> live control, as a performer sends it over OSC
    700: ("/pointat/press/bang", []),
    1100: ("/pointat/tqt2/k_heading", [0.2]),
    1500: ("/pointat/nulls3/recalibrate", []),
    1900: ("/pointat/out1/source", [7]),
    2300: ("/pointat/roll1/enter", [60.0]),
}


def _run(mode: str, counts: np.ndarray, batch: int = 3) -> tuple[list[bytes], dict, object]:
    rx = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
    rx.setsockopt(socket.SOL_SOCKET, socket.SO_RCVBUF, 1 << 23)
    rx.bind(("127.0.0.1", 0))
    rx.setblocking(False)
    rt = patch(_patch_text(rx.getsockname()[1]))
    rt.compiled = mode
    rt.start()
    mote = rt.nodes["base"]
    got: list[bytes] = []

    def drain() -> None:
        while True:
            try:
                got.append(rx.recv(512))
            except BlockingIOError:
                return

    t0 = 1000.0
    for k in range(0, len(counts), batch):  # a read brings a few frames of every mote
        for j in range(k, min(k + batch, len(counts))):
            if j in EVENTS:
                address, args = EVENTS[j]
                assert control(rt, address, args, t0 + j / 100.0) is None
            for m in range(3):
                frame = Frame(m + 1, j & 0xFFFF, tuple(int(c) for c in counts[j, m]))
                mote._frame(frame, 0.0, t0 + j / 100.0)
        if mote._fused is not None:
            mote._fused.flush()
        drain()
    chains = rt.compiled_chains
    fused_frames = sum(g.fused_frames for g in chains.groups) if chains else 0
    rt.shutdown()
    drain()
    rx.close()
    heard = {
        name: [(m.kind, m.value, m.time) for m in rt.nodes[name].messages]
        for name in ("show", "tag", "modes", "flags1", "flags2", "flags3")
    }
    tqt = {
        i: (np.array(rt.nodes[f"tqt{i}"].filter._s).tolist(), rt.nodes[f"out{i}"].updates) for i in (1, 2, 3)
    }
    return got, {"heard": heard, "state": tqt}, fused_frames


@pytest.fixture(scope="module")
def both_ways():
    build.chain_frames()  # (compiled once for the module: seconds when the cache is cold)
    counts = _takes(3950)
    return _run("off", counts), _run("on", counts), counts


def test_the_compiled_chain_sends_the_nodes_datagrams_to_the_bit(both_ways):
    (plain, _, none), (fused, _, frames), counts = both_ways
    assert none == 0
    # most frames went through the compiled chain; the others (nulls being averaged, a capture pending)
    # node by node
    assert frames > 0.9 * counts.shape[0] * 3, frames
    assert len(plain) > 0.9 * counts.shape[0] * 3
    # each glove's datagrams in its order (between gloves, the ones still node by node in a read go out
    # after the compiled ones)
    streams = {}
    for name, got in (("plain", plain), ("fused", fused)):
        for d in got:
            streams.setdefault(name, {}).setdefault(d.split(b"\0", 1)[0].split(b"/")[-2:][0], []).append(d)
    assert set(streams["plain"]) == {b"1", b"7", b"2", b"g"}, set(streams["plain"])
    for glove, want in streams["plain"].items():
        have = streams["fused"][glove]
        first = next((k for k, (a, b) in enumerate(zip(want, have, strict=False)) if a != b), None)
        assert first is None and len(have) == len(want), (glove, first, len(want), len(have))


def test_listeners_flags_and_state_are_the_nodes(both_ways):
    (_, plain, _), (_, fused, _), counts = both_ways
    assert fused["heard"] == plain["heard"]
    assert len(plain["heard"]["show"]) > 0.9 * counts.shape[0]
    assert len(plain["heard"]["tag"]) == counts.shape[0]
    said = {value for _kind, value, _t in plain["heard"]["flags2"]}
    assert "gyro_saturated" in said and len(said) > 1, said  # the clipped glove's flags came and went
    modes = [value for _kind, value, _t in plain["heard"]["modes"]]
    assert modes[:2] == ["distance", "azimuth"], modes  # the simulated hand rolled, and back
    assert fused["state"] == plain["state"]


def _frames_bytes(counts: np.ndarray) -> list[bytes]:
    return [
        encode_frame(Frame(1, k & 0xFFFF, tuple(int(c) for c in counts[k, 0]))) for k in range(len(counts))
    ]


def _cli(mode: str, frames: list[bytes], tmp_path: Path) -> list[bytes]:
    """``pointat run patches/glove_tqt.pat`` on a pseudo-terminal, the take written into it in real time."""
    master, slave = os.openpty()
    rx = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
    rx.setsockopt(socket.SOL_SOCKET, socket.SO_RCVBUF, 1 << 22)
    rx.bind(("127.0.0.1", 0))
    rx.settimeout(0.2)
    patch_file = Path(__file__).resolve().parents[2] / "patches" / "glove_tqt.pat"
    cmd = [
        sys.executable, "-m", "pointat.cli", "run", str(patch_file), "--compiled", mode,
        "--set", "glove.output=direct", "--set", f"base.device={os.ttyname(slave)}",
        "--set", f"out.port={rx.getsockname()[1]}", "--set", "ctl.port=0", "--set", "out.status=0",
        "--for", "8",
    ]  # fmt: skip
    proc = subprocess.Popen(cmd, stdout=subprocess.PIPE, stderr=subprocess.STDOUT, cwd=tmp_path)
    got: list[bytes] = []
    lines: list[bytes] = []
    started = threading.Event()

    def receive() -> None:
        while True:
            try:
                got.append(rx.recv(512))
            except TimeoutError:
                if proc.poll() is not None:
                    return

    # the nodes start once the chains are compiled (or loaded: an installed copy of pointat has a cache
    # of its own, so a cold one takes seconds), which the console says; node by node, after the banner
    ready = b"compiled glove chains" if mode == "on" else b"Ctrl-C stops."

    def console() -> None:
        for line in proc.stdout:
            lines.append(line)
            if ready in line:
                started.set()

    threads = [threading.Thread(target=fn, daemon=True) for fn in (receive, console)]
    for th in threads:
        th.start()
    try:
        assert started.wait(60.0), b"".join(lines).decode()[-2000:]
        time.sleep(1.0)  # (the mote opens its device)
        for k in range(0, len(frames), 5):  # 5 frames every 10 ms: 500 Hz
            os.write(master, b"".join(frames[k : k + 5]))
            time.sleep(0.01)
        proc.wait(timeout=30)
    finally:
        proc.kill()
        os.close(master)
        os.close(slave)
    for th in threads:
        th.join(timeout=5)
    rx.close()
    out = b"".join(lines)
    text = out.decode()
    assert ("compiled glove chains (1)" in text) == (mode == "on"), text[-2000:]
    return got


@pytest.mark.slow
def test_pointat_run_on_a_pseudo_terminal_sends_the_same_either_way(tmp_path):
    frames = _frames_bytes(_takes(2000))
    plain = _cli("off", frames, tmp_path)
    fused = _cli("on", frames, tmp_path)
    assert len(plain) > 1500
    assert fused == plain


def _pty_run(mode: str, counts: np.ndarray) -> tuple[list[bytes], int]:
    """The three-mote patch running (real time, its own thread), its base station a pseudo-terminal the
    frames are written into a few ticks at a time: the reader's parser hands the plain ones to the chains."""
    master, slave = os.openpty()
    rx = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
    rx.setsockopt(socket.SOL_SOCKET, socket.SO_RCVBUF, 1 << 23)
    rx.bind(("127.0.0.1", 0))
    rx.settimeout(0.5)
    text = _patch_text(rx.getsockname()[1])
    rt = patch(
        text.replace("node base mote ids", f"node base mote device={os.ttyname(slave)} ids"), realtime=True
    )
    rt.compiled = mode
    thread = rt.run_in_thread()
    got: list[bytes] = []
    try:
        assert wait_until(lambda: rt.nodes["base"]._fd is not None, 10.0)
        for k in range(0, len(counts), 4):
            ticks = range(k, min(k + 4, len(counts)))
            os.write(master, b"".join(
                encode_frame(Frame(m + 1, j & 0xFFFF, tuple(int(c) for c in counts[j, m])))
                for j in ticks for m in range(3)
            ))  # fmt: skip
            time.sleep(0.004)
        while True:
            try:
                got.append(rx.recv(512))
            except TimeoutError:
                break
        group = rt.compiled_chains.groups[0] if rt.compiled_chains else None
        plain = int(group.plain_taken) if group else 0
    finally:
        rt.stop()
        thread.join(5.0)
        os.close(master)
        os.close(slave)
        rx.close()
    return got, plain


@pytest.mark.slow  # (real time through a pty, twice; tests/devices/test_mote_plain.py holds the claim in process)
def test_frames_straight_from_the_reader_give_the_same_datagrams(both_ways):
    counts = both_ways[2][:1500]
    plain, none = _pty_run("off", counts)
    fused, taken = _pty_run("on", counts)
    # gloves 1 and 3 (glove 2's frames have a listener of their own, "tag": they go one at a time)
    assert none == 0 and taken > 0.6 * 3 * len(counts), taken
    assert len(plain) > 0.9 * 3 * len(counts)
    # (the heartbeats carry the rate over the last second: real time, not the take's)
    for address in {d.split(b"\0", 1)[0] for d in plain} - {b"/pointat/1/status", b"/pointat/3/status"}:
        mine = [d for d in fused if d.startswith(address + b"\0")]
        theirs = [d for d in plain if d.startswith(address + b"\0")]
        assert mine == theirs, address


def _programs_cache_dir(env: dict[str, str], cwd: Path) -> Path:
    """The compiled chain's cache folder as the pointat the program runs has it: an installed wheel's in CI,
    not this checkout's (the folder's key holds where the sources are, so the two never share one)."""
    code = "from pointat.compiled import build; print(build.cache_dir())"
    out = subprocess.run(
        [sys.executable, "-c", code],
        capture_output=True,
        text=True,
        env=env,
        cwd=cwd,
        timeout=120,
        check=True,
    )
    return Path(out.stdout.strip())


@pytest.mark.slow
def test_the_first_run_compiles_in_the_background_and_the_next_starts_compiled(tmp_path, monkeypatch):
    """A performer's first ``pointat run`` after installing: node by node at once (no waiting for a
    compile), the compile in a process of its own; the next run starts with the chain compiled, loaded
    from the cache (what start-up then costs is in the benchmarks)."""
    env = {**os.environ, "XDG_CACHE_HOME": str(tmp_path / "cache")}
    monkeypatch.setenv("XDG_CACHE_HOME", env["XDG_CACHE_HOME"])
    chain = _programs_cache_dir(env, tmp_path)  # (the chain's: the tqt filter's step has a folder of its own)
    cmd = [sys.executable, "-m", "pointat.cli", "run", "glove_tqt", *beside(GLOVE_PATCH), "--for", "1"]
    first = subprocess.run(cmd, capture_output=True, text=True, env=env, cwd=tmp_path, timeout=60)
    assert first.returncode == 0, first.stderr
    assert "compiling the glove chain for the next runs" in first.stdout
    assert "compiled glove chains" not in first.stdout
    assert chain.parent == tmp_path / "cache" / "pointat" and (chain / "compiling").exists()
    ready = [chain]
    assert wait_until(lambda: (ready[0] / "ready").exists(), 120.0, poll=0.2)
    assert wait_until(lambda: not (ready[0] / "compiling").exists(), 10.0)
    second = subprocess.run([*cmd, "-v"], capture_output=True, text=True, env=env, cwd=tmp_path, timeout=60)
    assert second.returncode == 0, second.stderr
    assert "compiled glove chains (1): base.m1 -> out" in second.stdout
    assert "compiling" not in second.stdout
    assert f"the compiled glove chain loaded from {ready[0]}" in second.stdout + second.stderr


@pytest.mark.slow
def test_a_run_from_a_checkouts_folder_compiles_for_the_pointat_it_runs(tmp_path, monkeypatch):
    """``pointat run`` (the installed program) started from a folder that holds another pointat, as a
    repository checkout does: the compile in the background is of the pointat that runs, into the cache
    folder it reads, so that the next run from that folder starts compiled.  (``python -m`` puts the
    working folder first on the path: the compile used to import the checkout's pointat, fill a cache
    nobody read, and every run from the repository said it was compiling.)"""
    program = Path(sys.executable).with_name("pointat")
    if not program.exists():
        pytest.skip(f"no pointat program beside {sys.executable}")
    checkout = tmp_path / "checkout"
    root = Path(__file__).resolve().parents[2]
    skip = shutil.ignore_patterns("__pycache__", "data", "monitor")
    for folder in ("pointat", "nodes", "osc_bridge"):
        shutil.copytree(root / folder, checkout / folder, ignore=skip)
    with open(checkout / "pointat" / "compiled" / "kernel.py", "a") as fh:
        fh.write("# another version of the kernel: another cache key\n")
    env = {**os.environ, "XDG_CACHE_HOME": str(tmp_path / "cache")}
    cmd = [str(program), "run", "glove_tqt", *beside(GLOVE_PATCH), "--for", "1"]
    first = subprocess.run(cmd, capture_output=True, text=True, env=env, cwd=checkout, timeout=60)
    assert first.returncode == 0, first.stderr
    assert "compiling the glove chain for the next runs" in first.stdout
    monkeypatch.setenv("XDG_CACHE_HOME", env["XDG_CACHE_HOME"])
    mine = _programs_cache_dir(env, tmp_path)  # (the program's pointat's; the tqt filter's folder is another)
    assert wait_until(lambda: (mine / "ready").exists(), 120.0, poll=0.2), sorted(mine.parent.iterdir())
    assert wait_until(lambda: not (mine / "compiling").exists(), 10.0)
    chains = [p for p in mine.parent.iterdir() if list(p.glob("*/kernel.*")) or list(p.glob("compiling"))]
    assert chains == [mine]  # (no compile of the checkout's)
    second = subprocess.run([*cmd, "-v"], capture_output=True, text=True, env=env, cwd=checkout, timeout=60)
    assert second.returncode == 0, second.stderr
    assert "compiled glove chains (1): base.m1 -> out" in second.stdout
    assert "compiling" not in second.stdout


def test_the_compile_refuses_to_fill_a_cache_of_another_pointat(tmp_path):
    env = {**os.environ, "XDG_CACHE_HOME": str(tmp_path / "cache")}
    other = tmp_path / "numba-0123456789abcdef"
    other.mkdir()
    (other / "compiling").touch()
    cmd = [sys.executable, "-m", "pointat.compiled.build", str(other)]
    out = subprocess.run(cmd, capture_output=True, text=True, env=env, timeout=60)
    assert out.returncode == 2
    assert f"caches into {tmp_path / 'cache' / 'pointat'}" in out.stderr and str(other) in out.stderr
    assert not (other / "compiling").exists()  # (the run that waits on it may start one again)
    assert not (tmp_path / "cache" / "pointat").exists()
