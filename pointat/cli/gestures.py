"""``pointat gestures``: ``evaluate`` (recognition trained on one folder of labelled recordings, tested
on another) and ``export`` (a model file's examples as such a folder)."""

from __future__ import annotations

import argparse
import json
import sys
from typing import Any

from ..registry import Registry


def add_gestures(sub: Any) -> None:
    """``pointat gestures evaluate`` and ``export``."""
    p = sub.add_parser(
        "gestures",
        help="evaluate gesture recognition on folders of labelled recordings (evaluate), or turn a gesture "
        "node's saved examples into such a folder (export)",
    )
    gsub = p.add_subparsers(dest="gestures_command", metavar="ACTION")
    _add_gestures_evaluate(gsub)
    _add_gestures_export(gsub)


def _add_gestures_evaluate(gsub: Any) -> None:
    """``pointat gestures evaluate``: train on one folder, test on another."""
    g = gsub.add_parser(
        "evaluate",
        help="train on one folder, test on another: accuracy, recall, confusion, decision latency",
        description="Train the gesture node's recognizer on --train and test it on --test, each laid out as "
        "DIR/<label>/<example>.csv (columns t and any of acc_x..z, gyr_x..z, mag_x..z, qw..qz). Each test "
        "recording is fed frame by frame, bracketed as one movement, as the gesture node runs it (with --stream:"
        " whole, cut as the node cuts it live). A take of ordinary motion in the training null/ folder, longer"
        " than a movement, is taught as the movements 'record null' would keep of it.",
    )
    g.add_argument("--train", required=True, metavar="DIR", help="labelled recordings to learn from")
    g.add_argument("--test", required=True, metavar="DIR", help="labelled recordings to test on")
    g.add_argument(
        "--channels",
        nargs="+",
        choices=("acc", "gyr", "mag", "q"),
        help="channel groups to use (default: every group all the recordings have)",
    )
    g.add_argument("--json", action="store_true", help="print the evaluation as JSON (with every decision)")
    g.add_argument("--no-early", action="store_true", help="decide only when each movement has ended")
    g.add_argument(
        "--set",
        action="append",
        default=[],
        metavar="NAME=VALUE",
        dest="sets",
        help="a gesture node parameter, as in a patch (reject=2, early=false, warp=each, relative=[acc q])",
    )
    g.add_argument(
        "--baseline",
        action="store_true",
        help="score plain 1-NN DTW on the same split beside it (raw channels warped together, no rejection)",
    )
    g.add_argument(
        "--stream",
        action="store_true",
        help="feed each test recording whole, as the node runs live (cut from rest to rest, or cut=spot): the"
        " gestures told in each, and false triggers a minute in null/ (recordings of ordinary motion)",
    )


def _add_gestures_export(gsub: Any) -> None:
    """``pointat gestures export``: a model file's examples as a folder of recordings."""
    g = gsub.add_parser(
        "export",
        help="a model file's examples (what a gesture node saved) as DIR/<label>/<n>.csv, for evaluate",
    )
    g.add_argument("model", help="a model file: what gesture, posture or follow saved (gestures.json)")
    g.add_argument("folder", help="where the recordings go (DIR/<label>/<n>.csv); files there stay")


def cmd_gestures(args: argparse.Namespace, registry: Registry) -> int:
    from .. import gesture_eval
    from ..gesture_files import read_folder

    if args.gestures_command == "export":
        from ..gesture_files import export_model

        try:
            written = export_model(args.model, args.folder)
        except (ValueError, OSError) as exc:
            print(f"error: {exc}", file=sys.stderr)
            return 2
        print(f"{len(written)} recordings into {args.folder}")
        return 0
    if args.gestures_command != "evaluate":
        print(
            "usage: pointat gestures evaluate --train DIR --test DIR [--baseline | --stream] [--set NAME=VALUE]"
            " [--json]"
            "  |  pointat gestures export MODEL DIR",
            file=sys.stderr,
        )
        return 2
    if args.stream and args.baseline:
        print(
            "error: --baseline scores each test recording as one movement; not with --stream", file=sys.stderr
        )
        return 2
    try:
        model_options, recognizer_options = gesture_eval.options(
            [*args.sets, *(["early=false"] if args.no_early else [])]
        )
        train, test = read_folder(args.train), read_folder(args.test)
        if args.stream:
            st = gesture_eval.stream(train, test, args.channels, model_options, recognizer_options)
            print(
                json.dumps(st.as_dict(), indent=2, allow_nan=True)
                if args.json
                else gesture_eval.format_stream(st)
            )
            return 0
        ev = gesture_eval.evaluate(train, test, args.channels, model_options, recognizer_options)
        plain = gesture_eval.baseline(train, test, ev.channels) if args.baseline else None
    except ValueError as exc:
        print(f"error: {exc}", file=sys.stderr)
        return 2
    if args.json:
        print(gesture_eval.to_json(ev, plain))
    else:
        print(gesture_eval.format_report(ev))
        if plain is not None:
            print(f"baseline, plain 1-NN DTW on the same split: accuracy {100 * plain.accuracy:.1f} %")
    return 0
