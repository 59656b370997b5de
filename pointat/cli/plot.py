"""``pointat plot``: a recorded take drawn as PNG and HTML (:mod:`pointat.plotting`)."""

from __future__ import annotations

import argparse
from typing import Any

from ..registry import Registry


def add_plot(sub: Any) -> None:
    """``pointat plot``: a recorded take drawn."""
    p = sub.add_parser(
        "plot",
        help="draw a recorded take as PNG and HTML: where the hand points, the sensor norms, the filter's "
        "flags and, where the take has truth, the error against it (needs matplotlib)",
    )
    p.add_argument(
        "take",
        metavar="TAKE",
        help="a take: record's CSV (record_glove.pat's ADC counts, or gyro/accel/mag columns) or a BROAD "
        "trial (.csv.gz)",
    )
    p.add_argument(
        "-o",
        "--output",
        metavar="OUT",
        help="write OUT.png and OUT.html (default: the take's path without its extension)",
    )
    p.add_argument(
        "--truth",
        action=argparse.BooleanOptionalAction,
        default=True,
        help="draw the orientation error against the take's truth, when it has one (BROAD's optical "
        "quaternions; default: --truth)",
    )


def cmd_plot(args: argparse.Namespace, registry: Registry) -> int:
    from ..plotting import plot_take

    for path in plot_take(args.take, args.output, truth=args.truth):
        print(path)
    return 0
