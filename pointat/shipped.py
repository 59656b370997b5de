"""What pointat ships beside its code: the patches, the examples and the sample data.

An installed wheel holds them inside the package (``pointat/patches``, ``pointat/examples``,
``pointat/data``: pyproject's ``package-dir`` maps the repository's top-level folders there); a source
checkout keeps ``patches/`` and ``examples/`` at the top of the repository, beside ``pointat/``.  The same
names find them either way:

* ``pointat run glove_tqt`` (a name that is no file here) runs ``patches/glove_tqt.pat``, from any folder;
* a path parameter written ``pointat:data/glove_take.csv.gz`` is the file of that name in the package,
  so a shipped patch names its sample take the same way installed or not;
* a shipped patch is read-only: a file it writes (a take, a calibration, a BVH or MIDI file, its
  gesture examples, its presets) goes to the current folder, or the one ``pointat run --out DIR``
  names (:func:`place`), never beside the patch inside the package.
"""

from __future__ import annotations

import os
from pathlib import Path

__all__ = [
    "PREFIX",
    "copy_patch",
    "find_patch",
    "folder",
    "is_shipped",
    "names_in",
    "patch_names",
    "place",
    "resolve",
    "seeds",
]

#: The package's own folder.
PACKAGE = Path(__file__).resolve().parent
#: A path parameter that starts with this names a file in :data:`PACKAGE`.
PREFIX = "pointat:"
#: The folders of shipped patches, searched in this order.
PATCH_FOLDERS = ("patches", "examples")


def folder(name: str) -> Path:
    """``patches``, ``examples`` or ``data``: inside the package when installed, else the checkout's.

    >>> folder("data").name, (folder("patches") / "glove_tqt.pat").is_file()
    ('data', True)
    """
    inside = PACKAGE / name
    return inside if inside.is_dir() else PACKAGE.parent / name


def resolve(value: str) -> str:
    """``pointat:REST`` -> the path of REST in the package; anything else unchanged.

    >>> Path(resolve("pointat:data/glove_take.csv.gz")).is_file(), resolve("take.csv")
    (True, 'take.csv')
    """
    if not value.startswith(PREFIX):
        return value
    rest = value[len(PREFIX) :].lstrip("/")
    top, _, below = rest.partition("/")
    return str(folder(top) / below) if top in (*PATCH_FOLDERS, "data") and below else str(PACKAGE / rest)


def is_shipped(path: str | os.PathLike[str]) -> bool:
    """Whether ``path`` is a file of the shipped patches or examples (their ``lib/`` too), however it
    was named: by name, or by its path inside the package or the checkout.

    >>> is_shipped(find_patch("glove_tqt")), is_shipped(folder("patches") / "lib" / "tqt_fusion.pat")
    (True, True)
    >>> is_shipped("my.pat")
    False
    """
    where = Path(os.path.realpath(path))
    return any(where.is_relative_to(os.path.realpath(folder(top))) for top in PATCH_FOLDERS)


def place(value: str, base: Path, out: Path, *, reads: bool, writes: bool) -> str:
    """Where a shipped patch's relative file parameter ``value`` (written in a file of folder ``base``)
    is: a file it writes is in ``out`` (the current folder, or ``--out``); one it only reads is the
    user's copy in ``out`` when there is one, else the shipped one beside the patch (read-only), else
    the user's (where the error then says to put it).  A file both read and written (the gestures'
    examples) is the user's: :func:`seeds` copies the shipped one there first.

    >>> out = Path("/show")
    >>> place("take.csv", folder("patches"), out, reads=False, writes=True)
    '/show/take.csv'
    >>> place("lib/tqt_fusion.pat", folder("patches"), out, reads=True, writes=False) == str(
    ...     folder("patches") / "lib/tqt_fusion.pat")
    True
    """
    mine, theirs = out / value, base / value
    if not writes and not mine.exists() and theirs.exists():
        return str(theirs)
    return str(mine)


def seeds(patch: str | os.PathLike[str]) -> list[Path]:
    """The files a shipped patch keeps beside itself under its own name, read and written as it runs
    (``gestures.json`` beside ``gestures.pat``: the examples it loads, and saves when taught more):
    what a run copies into its output folder when they are not there yet, to be the user's own."""
    found = Path(patch)
    if not is_shipped(found):
        return []
    return sorted(p for p in found.parent.glob(found.stem + ".*") if p != found and p.suffix == ".json")


def find_patch(name: str) -> Path | None:
    """A shipped patch by name (``glove_tqt``, ``glove_tqt.pat``, ``pd/glove_to_pd_vbap``), or None.

    >>> find_patch("glove_tqt").name, find_patch("no_such_patch")
    ('glove_tqt.pat', None)
    """
    if not name or "\0" in name or Path(name).is_absolute() or ".." in Path(name).parts:
        return None
    for top in PATCH_FOLDERS:
        for candidate in (name, name + ".pat", name + ".pd"):
            path = folder(top) / candidate
            if path.is_file():
                return path
    return None


def patch_names() -> list[str]:
    """Every shipped patch's name, as ``pointat run NAME`` takes it (patches first, then examples).

    >>> names = patch_names()
    >>> "glove_tqt" in names, "pd/glove_to_pd_vbap" in names, any(n.startswith("lib/") for n in names)
    (True, True, False)
    """
    names = []
    for top in PATCH_FOLDERS:
        names += names_in(folder(top))
    return names


def names_in(base: Path) -> list[str]:
    """The patches under folder ``base`` by name (``pd/glove_to_pd_vbap``), sorted, without its
    ``lib/`` of abstractions: only the parts below ``base`` count (an installed package's own path
    has a ``lib`` in it, ``.venv/lib/python3.11/site-packages``)."""
    found = (p.relative_to(base) for p in base.rglob("*.pat"))
    return sorted(p.with_suffix("").as_posix() for p in found if p.parts[0] != "lib")


def copy_patch(name: str, target: Path) -> list[Path]:
    """Copy shipped patch ``name`` into folder ``target`` to be one's own, with what lies beside it under
    its name (``gestures.json``: the examples it loads) and the abstractions of ``lib/`` it uses; a file
    already there is never replaced.  Returns the files written; ``ValueError`` says what stood in the way.
    """
    found = find_patch(name)
    if found is None:
        raise ValueError(f"no shipped patch {name!r} (pointat patches lists them)")
    if target.exists() and not target.is_dir():
        raise ValueError(f"{target}: not a folder")
    text = found.read_text(encoding="utf-8")
    wanted = [found, *seeds(found)]
    wanted += sorted(p for p in (found.parent / "lib").glob("*.pat") if f"lib/{p.name}" in text)
    plan = [(p, target / p.relative_to(found.parent)) for p in wanted]
    there = [str(dest) for _, dest in plan if dest.exists()]
    if there:
        raise ValueError(
            f"{', '.join(there)} already there: nothing copied (move it away, or copy elsewhere)"
        )
    for src, dest in plan:  # (the folder made too, as cp -r or mkdir -p would)
        dest.parent.mkdir(parents=True, exist_ok=True)
        dest.write_bytes(src.read_bytes())
    return [dest for _, dest in plan]
