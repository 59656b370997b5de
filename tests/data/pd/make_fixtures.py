r"""Regenerate the Pd fixtures of ``tests/test_pdfile.py`` with a real Pure Data (see README.md).

Each fixture is built inside Pd by messages to a new canvas (``pd menunew``, ``obj``, ``msg``, ``text``,
``connect``, ``menusave``) given with ``-send``, so every file here is written by Pd itself.  Fixtures that
print are then run by Pd for about a second and what Pd printed is stored next to them as ``NAME.out``.
``wrapped.pd`` is hand-written in the style of older Pd versions (records broken over lines); Pd opens it
and saves it again as ``wrapped.resaved.pd``.  ``exported.pd`` is ``exported.pat`` exported by
:func:`pointat.pdfile.write_pd`, then opened (with the stubs of :func:`~pointat.pdfile.write_stubs`) and
saved by Pd.

Run from anywhere:  python tests/data/pd/make_fixtures.py   (needs ``pd`` on the PATH; takes a few seconds)
"""

from __future__ import annotations

import logging
import re
import shutil
import subprocess
import tempfile
from pathlib import Path

log = logging.getLogger("make_fixtures")

HERE = Path(__file__).resolve().parent
PD = ["pd", "-nogui", "-noaudio", "-noprefs", "-stderr"]

#: Each fixture: name -> the messages that build it (``C`` stands for the canvas' receiver name).
FIXTURES: dict[str, list[str]] = {
    # loadbang -> metro 100 -> print tick, stopped by delay 350; a trigger, message boxes with ',' ';' $1,
    # route, send / receive, pack, unpack, change (fed
    # numbers: Pd's change takes floats only).
    "vanilla": [
        "C obj 20 20 loadbang",  # 0
        "C obj 20 60 metro 100",  # 1
        "C obj 20 100 print tick",  # 2
        "C obj 120 60 delay 350",  # 3
        "C msg 120 100 stop",  # 4
        "C obj 240 60 t b b",  # 5
        r"C msg 300 100 1 2 \, 3 4 \; bus 5 6",  # 6
        "C obj 300 140 route 1 3",  # 7
        "C obj 300 180 print one",  # 8
        "C obj 380 180 print three",  # 9
        "C obj 500 100 r bus",  # 10
        "C obj 500 140 print bus",  # 11
        "C msg 240 100 8",  # 12
        r"C msg 240 140 \$1 \$1",  # 13
        "C obj 240 180 s loop",  # 14
        "C obj 600 100 receive loop",  # 15
        "C obj 600 140 unpack f f",  # 16
        "C obj 600 180 pack 0 0",  # 17
        "C obj 600 220 print packed",  # 18
        r"C msg 700 20 3 \, 3 \, 4",  # 19
        "C obj 700 60 change",  # 20
        "C obj 700 100 print changed",  # 21
        "C connect 0 0 1 0",
        "C connect 1 0 2 0",
        "C connect 0 0 3 0",
        "C connect 3 0 4 0",
        "C connect 4 0 1 0",
        "C connect 0 0 5 0",
        "C connect 5 1 6 0",
        "C connect 6 0 7 0",
        "C connect 7 0 8 0",
        "C connect 7 1 9 0",
        "C connect 10 0 11 0",
        "C connect 5 0 12 0",
        "C connect 12 0 13 0",
        "C connect 13 0 14 0",
        "C connect 15 0 16 0",
        "C connect 16 1 17 1",
        "C connect 16 0 17 0",
        "C connect 17 0 18 0",
        "C connect 0 0 19 0",
        "C connect 19 0 20 0",
        "C connect 20 0 21 0",
    ],
    # Boxes pointat does not implement: a signal object, GUI objects, an atom box and an array, between good
    # ones.
    "unknown": [
        "C obj 20 20 loadbang",  # 0
        "C obj 20 60 osc~ 440",  # 1
        "C obj 120 20 bng 19 250 50 0 empty empty empty 0 -10 0 12 #fcfcfc #000000 #000000",  # 2
        "C floatatom 120 60 5 0 0 0 - - - 0",  # 3
        "C text 220 20 just a comment",  # 4
        "C obj 220 60 tgl 19 0 empty empty empty 17 7 0 10 #fcfcfc #000000 #000000 0 1",  # 5
        "C arraydialog table 8 3 1",  # 6: an array (a graph-on-parent subpatch)
        "C obj 20 100 print ok",  # 7
        "C connect 0 0 2 0",
        "C connect 2 0 7 0",
        "C connect 3 0 7 0",
        "C connect 5 0 7 0",
    ],
    # Comments count in box indices; '@name NODE' names the next box (pointat's convention).
    "comments": [
        "C obj 20 20 loadbang",  # 0
        r"C text 120 20 a comment\, with a comma",  # 1
        "C text 20 45 @name greet",  # 2
        "C msg 20 60 hello 1",  # 3
        "C text 120 60 another comment",  # 4
        "C obj 20 100 print said",  # 5
        "C connect 0 0 3 0",
        "C connect 3 0 5 0",
    ],
    # Escapes: ',' ';' '$1' and spaces inside symbols, a leading '+', key=value atoms of a pointat node.
    "escapes": [
        r"C msg 20 20 1 \, 2 \; foo \$1 bar\ baz +5 -3 1e+10 0.5 \$1-x",  # 0
        r"C obj 20 60 tqt k=0.123456789012 mode=robust rho=0.5",  # 1
        r"C obj 20 100 print two\ words",  # 2
        r"C obj 20 140 print a=b",  # 3
    ],
    # A subpatch whose two inlets were created right one first (box order != x order), and a nested
    # pass-through subpatch (inlet wired straight to outlet).
    "subpatch": [
        "C obj 20 20 loadbang",  # 0
        "C obj 20 50 t b b",  # 1
        "C msg 20 80 7",  # 2
        "C msg 100 80 5",  # 3
        "C obj 20 130 pd inner",  # 4
        "C obj 20 170 pd through",  # 5
        "C obj 20 210 print sub",  # 6
        "pd-inner obj 200 20 inlet",  # inner 0: right inlet
        "pd-inner obj 20 20 inlet",  # inner 1: left inlet
        "pd-inner obj 20 80 pack 0 0",  # inner 2
        "pd-inner obj 20 140 outlet",  # inner 3
        "pd-inner connect 1 0 2 0",
        "pd-inner connect 0 0 2 1",
        "pd-inner connect 2 0 3 0",
        "pd-through obj 20 20 inlet",
        "pd-through obj 20 80 outlet",
        "pd-through connect 0 0 1 0",
        "C connect 0 0 1 0",
        "C connect 1 1 3 0",
        "C connect 1 0 2 0",
        "C connect 3 0 4 1",
        "C connect 2 0 4 0",
        "C connect 4 0 5 0",
        "C connect 5 0 6 0",
    ],
    # Fan-out order is connect order, not box order: 'second' is box 2 but connected after 'first' (box 3);
    # one outlet into both inlets of a pack (the right one first) is the loader's warning case.
    "fanout": [
        "C obj 20 20 loadbang",  # 0
        "C msg 20 50 5",  # 1
        "C obj 20 100 print second",  # 2
        "C obj 120 100 print first",  # 3
        "C obj 220 100 pack 0 0",  # 4
        "C obj 220 140 print packed",  # 5
        "C connect 0 0 1 0",
        "C connect 1 0 3 0",
        "C connect 1 0 2 0",
        "C connect 1 0 4 1",
        "C connect 1 0 4 0",
        "C connect 4 0 5 0",
    ],
}

#: Fixtures that Pd runs for about a second, recording what it prints.
RUN = ("vanilla", "subpatch", "fanout", "comments", "wrapped")

WRAPPED = r"""#N canvas 0 50 450 300 12;
#X obj 20 20
 loadbang;
#X msg 20 60 a long message box that an old Pd would break over lines \,
 second message \; bus
 3;
#N canvas 0 50 450 250 (subpatch) 0;
#X array table 8 float 3;
#A 0 0 1 2 3 4 5 6
 7;
#X coords 0 7 8 0 200 140 1 0 0;
#X restore 200 20 graph;
#X obj 20 120 print
 wrapped;
#X obj 120 120 r bus;
#X obj 120 160 print bus;
#X connect 0 0 1
 0;
#X connect 1 0 3 0;
#X connect 4 0 5 0;
"""

DRIVER = r"""#N canvas 0 50 450 300 12;
#X obj 10 10 loadbang;
#X obj 10 40 delay 1000;
#X msg 10 70 \; pd quit;
#X connect 0 0 1 0;
#X connect 1 0 2 0;
"""


def _pd(*args: str, timeout: float = 10.0) -> str:
    done = subprocess.run([*PD, *args], capture_output=True, text=True, timeout=timeout, check=False)
    return done.stderr


def build(name: str, messages: list[str], out: Path) -> Path:
    canvas = f"pd-{name}.pd"
    sends = [f"pd menunew {name}.pd {out}"]
    sends += [canvas + m[1:] if m.startswith("C ") else m for m in messages]
    sends += [f"{canvas} menusave", "pd quit"]
    _pd("-send", "; ".join(sends))
    path = out / f"{name}.pd"
    if not path.exists():
        raise RuntimeError(f"Pd did not save {path}")
    return path


def record(path: Path, tmp: Path) -> list[str]:
    """Run ``path`` in Pd for a second; the lines its print objects wrote."""
    driver = tmp / "driver.pd"
    driver.write_text(DRIVER)
    err = _pd("-open", str(path), "-open", str(driver))
    prefixes = set(re.findall(r"print\s+(\S+?);", path.read_text()))
    return [ln for ln in err.splitlines() if ln.split(":", 1)[0] in prefixes]


def export(tmp: Path) -> None:
    """exported.pat -> write_pd -> Pd opens and saves it (finding the stubs) -> exported.pd."""
    from pointat.patchfile import read_patch
    from pointat.pdfile import STUB_FOLDER, write_pd, write_stubs

    (tmp / "exported.pd").write_text(write_pd(read_patch(HERE / "exported.pat")))
    write_stubs(tmp / STUB_FOLDER)
    err = _pd("-open", str(tmp / "exported.pd"), "-send", "pd-exported.pd menusave; pd quit")
    if "couldn't create" in err or "connection failed" in err:
        raise RuntimeError(f"Pd could not load the exported patch:\n{err}")
    shutil.copy(tmp / "exported.pd", HERE / "exported.pd")


def main() -> None:
    if shutil.which("pd") is None:
        raise SystemExit("pd is not installed")
    with tempfile.TemporaryDirectory() as tmpname:
        tmp = Path(tmpname)
        for name, messages in FIXTURES.items():
            shutil.copy(build(name, messages, tmp), HERE / f"{name}.pd")
        (HERE / "wrapped.pd").write_text(WRAPPED)
        shutil.copy(HERE / "wrapped.pd", tmp / "wrapped.pd")
        _pd("-open", str(tmp / "wrapped.pd"), "-send", "pd-wrapped.pd menusave; pd quit")
        shutil.copy(tmp / "wrapped.pd", HERE / "wrapped.resaved.pd")
        export(tmp)
        for name in RUN:
            lines = record(HERE / f"{name}.pd", tmp)
            (HERE / f"{name}.out").write_text("".join(ln + "\n" for ln in lines))
            log.info("%s: %d printed lines", name, len(lines))


if __name__ == "__main__":
    logging.basicConfig(level=logging.INFO)
    main()
