r""":func:`pointat.fusion.kernel.chain_frames` compiled by numba, its machine code cached between runs.

numba compiles the chain with every function it calls (the filter's step, the scalar maths, the roll
gesture, osc_out's fields) in about five seconds.  That is paid once per version of those sources: the
code is cached in ``$XDG_CACHE_HOME/pointat/numba-KEY`` (``~/.cache/...``), ``KEY`` a hash of the sources
compiled, where they are, and numba's and Python's versions, so that a change to any of them compiles anew (numba's own
cache looks at the file of the function it compiles only, not at the files of what it calls).

``pointat run`` never waits for a compile it has not asked for: when the cache is not ready it runs node
by node and starts :func:`warm` in a process of its own (``python -m pointat.fusion.compiled``), so that
the next run starts fused; loading the cached code costs about a third of a second.
"""

from __future__ import annotations

import hashlib
import inspect
import logging
import os
import subprocess
import sys
import time
import types
from collections.abc import Callable
from pathlib import Path
from typing import Any

__all__ = ["available", "cache_dir", "chain_frames", "ready", "scan_plain", "warm", "warm_in_background"]

log = logging.getLogger("pointat.fusion")

try:  # an optional dependency: without it every chain runs node by node
    import numba
except ImportError:  # pragma: no cover - depends on the environment
    numba = None


def available() -> bool:
    """Whether numba is installed."""
    return numba is not None


def _modules() -> list[types.ModuleType]:
    from pointat.fusion import kernel
    from pointat.maths import fusion, scalar
    from pointat.maths.tqt import step
    from pointat.osc_bridge import profiles

    return [step, scalar, fusion, profiles, kernel]


def cache_dir() -> Path:
    """Where the compiled chain is cached: a folder per version of its sources, numba and Python."""
    h = hashlib.sha256()
    for module in _modules():  # (numba's cache keys a function by its file too: a copy elsewhere is new)
        h.update(f"{module.__file__}\n{inspect.getsource(module)}".encode())
    h.update(f"{getattr(numba, '__version__', '')} {sys.version}".encode())
    root = Path(os.environ.get("XDG_CACHE_HOME") or Path.home() / ".cache") / "pointat"
    return root / f"numba-{h.hexdigest()[:16]}"


def ready() -> bool:
    """Whether the cache holds the compiled chain (a run then loads it instead of compiling)."""
    return numba is not None and (cache_dir() / "ready").exists()


_compiled: Callable[..., Any] | None = None


def chain_frames() -> Callable[..., Any]:
    """The compiled :func:`~pointat.fusion.kernel.chain_frames`: loaded from the cache, or compiled
    (seconds) and cached.  numba functions call only numba functions: every function of the modules
    it calls is compiled into one namespace of its own (the modules keep their Python functions)."""
    global _compiled
    if _compiled is not None:
        return _compiled
    if numba is None:
        raise RuntimeError('numba is not installed: pip install "pointat[fast]"')
    where = cache_dir()
    where.mkdir(parents=True, exist_ok=True)
    modules = _modules()
    space: dict[str, Any] = {}
    for module in modules:
        space.update(vars(module))
    saved = numba.config.CACHE_DIR
    numba.config.CACHE_DIR = str(where)  # read when a function's cache is set up, just below
    try:
        jit = numba.njit(cache=True, nogil=True)
        for module in modules:
            for name, value in vars(module).items():
                if isinstance(value, types.FunctionType) and value.__module__ == module.__name__:
                    space[name] = jit(types.FunctionType(value.__code__, space, name, value.__defaults__))
    finally:
        numba.config.CACHE_DIR = saved
    fn = space["chain_frames"]
    _exercise(fn, space["scan_plain"])
    hits = sum(sum(space[f].stats.cache_hits.values()) for f in ("chain_frames", "scan_plain"))
    log.info("the compiled glove chain %s %s", "loaded from" if hits == 2 else "compiled into", where)
    (where / "ready").touch()
    _compiled = fn
    global _scan
    _scan = space["scan_plain"]
    return fn


_scan: Callable[..., Any] | None = None


def scan_plain() -> Callable[..., Any]:
    """The compiled :func:`~pointat.fusion.kernel.scan_plain` (compiled with :func:`chain_frames`)."""
    chain_frames()
    assert _scan is not None
    return _scan


def _exercise(fn: Callable[..., Any], scan: Callable[..., Any]) -> None:
    """Call them once on zeros: numba compiles (or loads) for the types the runner passes."""
    import numpy as np

    from pointat.fusion import kernel as k
    from pointat.maths.tqt import step

    g, f, n = 1, 1, 64
    fn(
        np.zeros(f, np.int64), np.zeros((f, 9)), np.zeros(f), np.zeros(f),
        np.zeros((g, k.G_SIZE)), np.zeros((g, k.C_SIZE)), np.zeros((g, step.STATE_SIZE)),
        np.zeros((g, step.PARAM_SIZE + 2)), np.zeros((f, k.O_SIZE)), np.zeros(f, np.int64),
        np.zeros(f, np.int64), np.zeros((f, n), np.uint8), np.zeros((g, n), np.uint8),
        np.zeros(g, np.int64), np.full((g, 8), -1, np.int64), np.zeros((g, 8), np.int64),
    )  # fmt: skip
    scan(
        np.zeros(64, np.uint8), 0, 64, np.full(256, -1, np.int64), np.zeros(256, np.uint8),
        np.full(256, -1, np.int64),
        np.zeros((3, 256)), 100.0, np.zeros(f, np.int64), np.zeros((f, 9)), np.zeros(f),
        np.zeros(256, np.int64), 0,
    )  # fmt: skip


#: Seconds a compile in the background is taken to be under way (its lock file's age), so that patches
#: started meanwhile do not start compiles of their own.
COMPILING = 120.0


def warm() -> Path:
    """Compile the chain into the cache (what ``python -m pointat.fusion.compiled`` does)."""
    try:
        chain_frames()
    finally:
        (cache_dir() / "compiling").unlink(missing_ok=True)
    return cache_dir()


def warm_in_background() -> subprocess.Popen[bytes] | None:
    """Start :func:`warm` in a process of its own, at low priority; ``None`` when numba is missing or a
    compile is under way already."""
    if numba is None:
        return None
    lock = cache_dir() / "compiling"
    lock.parent.mkdir(parents=True, exist_ok=True)
    try:
        fd = os.open(lock, os.O_CREAT | os.O_EXCL | os.O_WRONLY)
    except FileExistsError:
        if time.time() - lock.stat().st_mtime < COMPILING:
            return None
        lock.touch()  # one that died long ago: this one takes over
    else:
        os.close(fd)
    return subprocess.Popen(
        [sys.executable, "-m", "pointat.fusion.compiled", str(cache_dir())],
        # from the folder that holds this very package: ``-m`` puts the working folder first on the
        # path, and a run from a checkout's folder would otherwise compile the checkout's pointat (for
        # another cache key) while the installed one waits for its own forever
        cwd=_ROOT,
        stdin=subprocess.DEVNULL,
        stdout=subprocess.DEVNULL,
        stderr=subprocess.DEVNULL,
        start_new_session=True,  # not stopped by the run's Ctrl-C: a half-written cache helps nobody
        preexec_fn=lambda: os.nice(10),  # noqa: PLW1509 - only nice, before exec
    )


#: The folder that holds the ``pointat`` package this module belongs to (site-packages, or a checkout).
_ROOT = Path(__file__).resolve().parents[2]


def main(argv: list[str]) -> int:
    """``python -m pointat.fusion.compiled [CACHE]``: compile into the cache; with ``CACHE`` (the folder
    the run that started it waits on), only when this process computes the same one: a compile of
    another copy of pointat would fill a folder nobody reads."""
    if argv and Path(argv[0]) != cache_dir():
        print(f"error: this pointat ({_ROOT}) caches into {cache_dir()}, not {argv[0]}", file=sys.stderr)
        (Path(argv[0]) / "compiling").unlink(missing_ok=True)
        return 2
    print(warm())
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
