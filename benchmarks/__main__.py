"""``python -m benchmarks [--quick] [--data DIR] [--out benchmarks/REPORT.md]``: measure, then write the report.

Latency first (the most sensitive to other work), then throughput; the memory soak runs in the
background while the accuracy benchmark computes (neither measures time at a fine grain).
"""

from __future__ import annotations

import argparse
import datetime
import logging
import os
import platform
import shlex
import subprocess
import sys
import time
from importlib.metadata import PackageNotFoundError, version
from pathlib import Path

import numpy as np

REPO = Path(__file__).resolve().parents[1]
DEFAULT_DATA = REPO.parent / "shared" / "data" / "broad"
QUICK_TRIALS = ("01_", "15_", "32_")
PARTS = ("latency", "throughput", "accuracy", "memory", "monitor", "gestures", "reload")
#: Where the report goes without --out: a quick or partial run never replaces the full run's report.
FULL_REPORT = REPO / "benchmarks" / "REPORT.md"
PARTIAL_REPORT = REPO / "benchmarks" / "results" / "REPORT.md"


def _parser() -> argparse.ArgumentParser:
    ap = argparse.ArgumentParser(
        prog="python -m benchmarks",
        description="pointat's benchmarks: latency and jitter (against a python-osc relay and Pure Data), "
        "throughput and cost per update (against ahrs, imufusion, vqf), accuracy on the BROAD recordings, "
        "and memory; writes a Markdown report with SVG figures.",
        epilog="quick: about 10 minutes; full: about 40 minutes (2 cores).  Peers: pip install -e '.[bench]'; "
        "Pure Data: apt-get install puredata-core.",
    )
    ap.add_argument(
        "--quick", action="store_true", help="short measurements and 3 BROAD trials (a few minutes)"
    )
    ap.add_argument(
        "--data",
        type=Path,
        default=None,
        help=f"folder of BROAD trials (*.csv.gz); default {os.path.relpath(DEFAULT_DATA, REPO)} relative to the "
        "repository if it exists, else the trial shipped in pointat/data",
    )
    ap.add_argument(
        "--out",
        type=Path,
        default=None,
        help="the report to write (figures go beside it); default benchmarks/REPORT.md for a full run, "
        "benchmarks/results/REPORT.md for --quick or --only (the full report, which the README quotes, stays)",
    )
    ap.add_argument(
        "--only", choices=PARTS, action="append", help="run only this part (repeatable); default: all seven"
    )
    ap.add_argument(
        "--uwave", type=Path, default=None, help="uWave's unpacked folders, for the gestures part"
    )
    ap.add_argument("-v", "--verbose", action="store_true", help="log more")
    return ap


def report_path(out: Path | None, quick: bool, only: list[str] | None) -> Path:
    """``--out``, or where the report goes without it: a quick or partial run never replaces the full one."""
    if out is not None:
        return out
    return PARTIAL_REPORT if quick or only else FULL_REPORT


def _version(dist: str) -> str:
    try:
        return version(dist)
    except PackageNotFoundError:
        return "not installed"


def _git(*args: str) -> str:
    try:
        return subprocess.run(
            ["git", *args], cwd=REPO, capture_output=True, text=True, timeout=10
        ).stdout.strip()
    except (OSError, subprocess.TimeoutExpired):
        return ""


def machine_info() -> dict[str, str]:
    """CPU, cores, memory, OS, Python and the versions of numpy, the peers and Pd."""
    from .latency import pd_version

    cpu = platform.processor() or platform.machine()
    try:
        for line in Path("/proc/cpuinfo").read_text().splitlines():
            if line.startswith("model name"):
                cpu = line.split(":", 1)[1].strip()
                break
    except OSError:
        pass
    mem = ""
    try:
        kb = int(Path("/proc/meminfo").read_text().split()[1])
        mem = f"{kb / 1024 / 1024:.1f} GiB"
    except (OSError, ValueError, IndexError):
        pass
    commit = _git("rev-parse", "--short", "HEAD")
    # changed code; not an untracked report written inside the tree
    dirty = bool(_git("status", "--porcelain", "--untracked-files=no"))
    info = {
        "CPU": f"{cpu}, {os.cpu_count()} logical cores" + (" (virtual machine)" if _virtual() else ""),
        "memory": mem or "?",
        "OS": f"{platform.system()} {platform.release()}",
        "Python": f"{platform.python_implementation()} {platform.python_version()}",
        "numpy": np.__version__,
        "pointat": f"{_version('pointat')} (git {commit or '?'}{', uncommitted changes' if dirty else ''})",
        "python-osc": _version("python-osc"),
        "pyserial": _version("pyserial"),
        "ahrs": _version("ahrs"),
        "imufusion": _version("imufusion"),
        "vqf": _version("vqf"),
        "numba": _version("numba"),
        "Pure Data": pd_version() or "not installed",
    }
    return info


def _virtual() -> bool:
    try:
        return "hypervisor" in Path("/proc/cpuinfo").read_text()
    except OSError:
        return False


def _load() -> str:
    try:
        return " ".join(f"{x:.2f}" for x in os.getloadavg())
    except OSError:
        return "?"


def resolve_data(arg: Path | None, quick: bool) -> tuple[list[Path], str]:
    """The trial files to use and a sentence for the report saying which and why."""
    from pointat.maths.evaluation import BROAD_SAMPLE

    from .accuracy import trial_files

    folder = arg if arg is not None else (DEFAULT_DATA if DEFAULT_DATA.is_dir() else None)
    files = trial_files(folder) if folder is not None and folder.exists() else []
    if not files:
        why = (
            f"`{arg}` holds no BROAD trials"
            if arg is not None
            else f"`{os.path.relpath(DEFAULT_DATA, REPO)}` is not there"
        )
        return [BROAD_SAMPLE], (
            f"Data: {why}, so only the trial shipped with pointat (`pointat/data/{BROAD_SAMPLE.name}`) was used; "
            "the published peer means are over 10 trials and are not comparable with a one-trial mean. "
            "Pass `--data` with the BROAD CSV export for the full comparison."
        )
    where = os.path.relpath(folder, REPO) if folder is not None else "?"
    if quick:
        chosen = [f for f in files if f.name.startswith(QUICK_TRIALS)] or files[:3]
        return chosen, (
            f"Data: `{where}` ({len(files)} trials); this quick run uses {len(chosen)} of them "
            f"({', '.join(f.name.split('_')[0] for f in chosen)}: slow rotation, fast translation, attached magnet). "
            "The goals are defined on the mean over all 10: run without `--quick` for them."
        )
    return files, f"Data: `{where}`, all {len(files)} trials."


def main(argv: list[str] | None = None) -> int:
    args = _parser().parse_args(argv)
    logging.basicConfig(
        level=logging.INFO if args.verbose else logging.WARNING, format="%(levelname)s %(name)s: %(message)s"
    )
    parts = set(args.only or PARTS)
    from pointat.maths.evaluation import load_broad

    from . import accuracy, latency, memory, report, throughput

    t_start = time.monotonic()
    command = "python -m benchmarks" + (
        ""
        if argv is None and len(sys.argv) <= 1
        else " " + shlex.join(sys.argv[1:] if argv is None else argv)
    )

    def progress(text: str) -> None:
        print(f"[{time.monotonic() - t_start:6.1f} s] {text}", file=sys.stderr, flush=True)

    files, data_note = resolve_data(args.data, args.quick)
    first = files[0]
    sample = load_broad(first)
    info = machine_info()
    run = report.Run(
        command=command,
        quick=args.quick,
        machine=info,
        data_note=data_note,
        started=datetime.datetime.now().astimezone().strftime("%Y-%m-%d %H:%M %Z"),
    )
    load_before = _load()
    progress(f"machine: {info['CPU']}; load average {load_before}")

    if "latency" in parts:

        def phases(rate: float) -> latency.Phases:
            if args.quick:
                return latency.Phases(measure=3.0 if rate < 500 else 2.0)
            return latency.Phases(measure=30.0 if rate < 500 else 20.0)

        rounds = 2 if args.quick else 3
        run.latency = latency.run_all((100.0, 1000.0), phases, sample, progress, rounds)
        run.costs = latency.costs(1000.0, 3.0 if args.quick else 8.0, rounds, progress)
        progress("latency: the engine's thread -> scheduler hand-off alone, 1 kHz")
        run.handoff = latency.handoff(1000.0, 3.0 if args.quick else 10.0)
        for rate in (100.0, 1000.0):
            progress(f"latency: the scheduler's timers against a sleeping Python loop, {rate:g} Hz")
            run.timers[rate] = latency.timers(rate, 6.0 if args.quick else 20.0)
        progress("latency: Python calls per sample on the osc_in path")
        run.calls = latency.python_calls(sample)
        progress("latency: instructions per sample on the osc_in path (valgrind)")
        try:
            counted = latency.instructions_per_sample(first)
        except (RuntimeError, OSError, subprocess.SubprocessError) as exc:  # the rest of the run goes on
            progress(f"latency: instructions not counted: {exc}")
            counted = None
        else:
            if counted is None:
                progress("latency: instructions not counted: valgrind is not installed")
        for c in run.calls:
            c.instructions = None if counted is None else counted.get(c.path)
    if "throughput" in parts:
        run.throughput = throughput.run_all(sample, first, args.quick, progress)
    if "monitor" in parts:  # (before the memory soak: its rounds are timed)
        from . import monitor

        run.monitor = monitor.report(args.quick, progress).split("\n", 2)[2]
    if "gestures" in parts:  # (timed too: before the soak)
        from . import gestures

        run.gestures, run.gesture_goals = gestures.report(args.quick, progress, args.uwave)
    if "reload" in parts:  # (timed too: before the soak)
        from . import reload

        run.reload = reload.report(args.quick, progress).split("\n", 2)[2]
    soak = None
    if "memory" in parts:
        seconds = 30.0 if args.quick else 600.0
        progress(f"memory: soak for {seconds:.0f} s in the background")
        soak = memory.Soak(seconds)
        soak.start()
    try:
        if "accuracy" in parts:
            run.accuracy = accuracy.run_all(files, progress)
    finally:
        if soak is not None:
            progress("memory: waiting for the soak to end")
            run.memory = soak.finish()
    run.seconds = time.monotonic() - t_start
    run.machine["load average"] = f"{load_before} at the start, {_load()} at the end (1, 5, 15 min)"
    if args.quick:
        run.notes.append(
            "Quick run: latency windows of 2-3 s (a p99 of ~2,000 samples at 1 kHz, ~300 at 100 Hz), "
            "30 s memory soak, 3 BROAD trials.  The full run measures 20-30 s per latency row, 10 minutes of "
            "soak and all trials."
        )
    run.notes.append(
        "Sample tags: the mote path replaces each frame's gyro x count by 1548 + (k mod 1000) (a ±50 °/s "
        "sawtooth) and adds an `unpack`→`map` tap per mote that puts it in `osc_out`'s spread field; the "
        "osc_in path sends `[/tag k, /sensors ...]` bundles and adds `route`→`map`.  These taps (a few µs) "
        "are in the measured latency; they are not in the throughput figures."
    )
    out = report_path(args.out, args.quick, args.only)
    out.parent.mkdir(parents=True, exist_ok=True)
    report.write_figures(run, out.parent / "figures")
    out.write_text(report.render(run), encoding="utf-8")
    progress(f"wrote {out} and {out.parent / 'figures'} in {run.seconds / 60:.1f} min")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
