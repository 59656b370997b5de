r"""numba for pointat: a module's functions compiled, with those of the modules they call, cached once.

numba compiles only what it is given, and a compiled function calls only compiled ones.  To run a
module's maths compiled (the filter's step for a bank, the DTW loops, the glove chain's kernel),
:func:`compile_module` compiles every function the module defines, and every function of the modules
named in ``calls``, each into a copy of *its own* module's namespace in which the functions of those
modules are their compiled forms.  The modules keep their Python functions, which the plain forms run
and the tests compare with.  No namespace is merged into another: two modules may each define an
``accmag_matrix``, and each module's functions call their own.

One cache policy for all of it.  numba's ``cache=True`` writes beside the source file when it may
(``__pycache__``): inside an installed package, where nothing of a run belongs.  Here the machine code
goes to the user's cache folder instead, ``$XDG_CACHE_HOME/pointat/numba-KEY`` (``~/.cache/...``),
``KEY`` a hash of the sources compiled together, where they are, and numba's and Python's versions:
numba's own check looks at the file of the function it loads, not at the files of the functions it
calls, so a change to any of them must mean another folder (an installed copy and a checkout never
share one either).  Every version leaves a folder behind, so the folders of versions no run has used for
:data:`KEEP_DAYS` days are removed as another is opened (:func:`prune`; a folder's ``used`` file says
when it was last opened).

Compiling is lazy, as numba's is: a function is compiled (or loaded from the cache) at its first call.
``options`` are numba's own for every function of the set (``{"_nrt": False}``: no reference counting,
for code that allocates nothing; they are part of the cache folder's key too).

>>> import pointat.maths.dtw as dtw
>>> cache_dir(dtw).name.startswith("numba-")
True
"""

from __future__ import annotations

import hashlib
import inspect
import os
import shutil
import sys
import threading
import time
import types
from collections.abc import Mapping, Sequence
from pathlib import Path
from typing import Any

__all__ = ["KEEP_DAYS", "cache_dir", "cache_root", "compile_module", "prune"]

#: A cache folder no run has opened for this many days is removed (:func:`prune`).
KEEP_DAYS = 30


def cache_root() -> Path:
    """pointat's cache folder: ``$XDG_CACHE_HOME/pointat``, else ``~/.cache/pointat``."""
    return Path(os.environ.get("XDG_CACHE_HOME") or Path.home() / ".cache") / "pointat"


def cache_dir(
    module: types.ModuleType,
    *,
    calls: Sequence[types.ModuleType] = (),
    options: Mapping[str, Any] | None = None,
) -> Path:
    """Where :func:`compile_module` caches ``module`` compiled with ``calls`` (and ``options``): a folder
    per version of their sources, numba and Python."""
    import numba

    h = hashlib.sha256()
    for m in (module, *calls):
        h.update(f"{m.__file__}\n{inspect.getsource(m)}".encode())
    h.update(f"{numba.__version__} {sys.version}".encode())
    if options:
        h.update(repr(sorted(options.items())).encode())
    return cache_root() / f"numba-{h.hexdigest()[:16]}"


def prune(root: Path, keep: Path, now: float | None = None) -> list[Path]:
    """Remove the ``numba-*`` folders of ``root`` but ``keep`` that no run has opened for
    :data:`KEEP_DAYS` days (their ``used`` file's time, else the folder's); returns those removed.  A
    folder that cannot be removed is left as it is: the cache is never worth an error."""
    limit = (time.time() if now is None else now) - KEEP_DAYS * 86400.0
    gone = []
    for folder in root.glob("numba-*"):
        if folder == keep or not folder.is_dir():
            continue
        stamp = folder / "used"
        try:
            last = (stamp if stamp.exists() else folder).stat().st_mtime
        except OSError:
            continue
        if last < limit:
            shutil.rmtree(folder, ignore_errors=True)
            if not folder.exists():  # (a link, a folder not ours to remove: left, and not said removed)
                gone.append(folder)
    return gone


_lock = threading.Lock()  # (numba reads its cache folder from its config as a function is decorated)
_compiled: dict[tuple[Any, ...], tuple[tuple[types.ModuleType, ...], types.SimpleNamespace]] = {}


def compile_module(
    module: types.ModuleType,
    *,
    calls: Sequence[types.ModuleType] = (),
    options: Mapping[str, Any] | None = None,
) -> types.SimpleNamespace:
    """``module``'s functions compiled by numba (``nogil`` and ``options``, cached in :func:`cache_dir`),
    as the attributes of a namespace; those of the modules in ``calls`` are compiled for them to call.
    Once a process for the same modules and options: the second call gives the first one's namespace."""
    modules = (module, *calls)
    key = (*(m.__name__ for m in modules), repr(sorted((options or {}).items())))
    with _lock:
        done = _compiled.get(key)
        if done is None or any(m is not n for m, n in zip(done[0], modules, strict=True)):  # (reloaded)
            done = _compiled[key] = (modules, _compile(module, calls, dict(options or {})))
    return done[1]


def _own(module: types.ModuleType) -> dict[str, types.FunctionType]:
    """The functions ``module`` defines (not those it imports)."""
    return {
        name: value
        for name, value in vars(module).items()
        if isinstance(value, types.FunctionType) and value.__module__ == module.__name__
    }


def _compile(
    module: types.ModuleType, calls: Sequence[types.ModuleType], options: dict[str, Any]
) -> types.SimpleNamespace:
    import numba

    modules = [module, *(m for m in calls if m is not module)]
    where = cache_dir(module, calls=calls, options=options)
    where.mkdir(parents=True, exist_ok=True)
    (where / "used").touch()
    prune(where.parent, keep=where)
    spaces = {m.__name__: dict(vars(m)) for m in modules}
    compiled: dict[int, Any] = {}  # id of a Python function -> its compiled form
    jit = numba.njit(cache=True, nogil=True, **options)
    saved = numba.config.CACHE_DIR
    numba.config.CACHE_DIR = str(where)
    try:
        for m in modules:
            space = spaces[m.__name__]
            for name, fn in _own(m).items():
                copy = types.FunctionType(fn.__code__, space, name, fn.__defaults__, fn.__closure__)
                copy.__kwdefaults__ = fn.__kwdefaults__
                compiled[id(fn)] = jit(copy)
    finally:
        numba.config.CACHE_DIR = saved
    for (
        space
    ) in spaces.values():  # every name of a compiled function, its own or imported, to the compiled form
        for name, value in space.items():
            if isinstance(value, types.FunctionType) and id(value) in compiled:
                space[name] = compiled[id(value)]
    return types.SimpleNamespace(**{name: compiled[id(fn)] for name, fn in _own(module).items()})
