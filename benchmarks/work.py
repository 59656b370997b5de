"""Run samples through one osc_in path, for ``valgrind --tool=callgrind`` to count the instructions.

    python -m benchmarks.work PATH TRIAL SAMPLES

PATH is ``python-osc``, ``relay``, ``torre``, ``tqt`` or ``none`` (the driver alone); TRIAL a BROAD
recording (``*.csv.gz``).  :func:`benchmarks.latency.instructions_per_sample` runs it.
"""

from __future__ import annotations

import sys

from .latency import OSC_PATHS, run_osc_path


def main(argv: list[str] | None = None) -> int:
    args = sys.argv[1:] if argv is None else argv
    if len(args) != 3 or args[0] not in (*OSC_PATHS, "none") or not args[2].isdigit():
        print(__doc__.strip().splitlines()[2].strip(), file=sys.stderr)
        return 2
    run_osc_path(args[0], args[1], int(args[2]))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
