r""":func:`pointat.compiled.kernel.chain_frames` compiled by numba, its machine code cached between runs.

numba compiles the chain with every function it calls (the filter's step, the scalar maths, the roll
gesture, osc_out's fields) in about five seconds, by :func:`pointat.jit.compile_module`.  That is paid
once per version of those sources: the code is cached in the user's cache folder, a folder per version
of them (:func:`pointat.jit.cache_dir`; numba's own cache looks at the file of the function it compiles
only, not at the files of what it calls).

``pointat run`` never waits for a compile it has not asked for: when the cache is not ready it runs node
by node and starts :func:`warm` in a process of its own (``python -m pointat.compiled.build``), so that
the next run starts fused; loading the cached code costs about a third of a second.
"""

from __future__ import annotations

import logging
import os
import subprocess
import sys
import time
import types
from collections.abc import Callable
from pathlib import Path
from typing import Any

from pointat import jit

__all__ = ["cache_dir", "chain_frames", "ready", "scan_plain", "warm", "warm_in_background"]

log = logging.getLogger("pointat.compiled")


def _modules() -> tuple[types.ModuleType, list[types.ModuleType]]:
    """The kernel, and the modules whose functions it calls."""
    from pointat.compiled import kernel
    from pointat.maths import fusion, scalar
    from pointat.maths.tqt import step
    from pointat.osc_bridge import profiles

    return kernel, [step, scalar, fusion, profiles]


def cache_dir() -> Path:
    """Where the compiled chain is cached: a folder per version of its sources, numba and Python."""
    kernel, calls = _modules()
    return jit.cache_dir(kernel, calls=calls)


def ready() -> bool:
    """Whether the cache holds the compiled chain (a run then loads it instead of compiling)."""
    return (cache_dir() / "ready").exists()


_compiled: types.SimpleNamespace | None = None


def _kernel() -> types.SimpleNamespace:
    """The kernel's functions compiled: loaded from the cache, or compiled (seconds) and cached."""
    global _compiled
    if _compiled is not None:
        return _compiled
    kernel, calls = _modules()
    done = jit.compile_module(kernel, calls=calls)
    _exercise(done.chain_frames, done.scan_plain)
    hits = sum(sum(f.stats.cache_hits.values()) for f in (done.chain_frames, done.scan_plain))
    where = cache_dir()
    log.info("the compiled glove chain %s %s", "loaded from" if hits == 2 else "compiled into", where)
    (where / "ready").touch()
    _compiled = done
    return done


def chain_frames() -> Callable[..., Any]:
    """The compiled :func:`~pointat.compiled.kernel.chain_frames` (with :func:`scan_plain`)."""
    return _kernel().chain_frames  # type: ignore[no-any-return]


def scan_plain() -> Callable[..., Any]:
    """The compiled :func:`~pointat.compiled.kernel.scan_plain` (compiled with :func:`chain_frames`)."""
    return _kernel().scan_plain  # type: ignore[no-any-return]


def _exercise(fn: Callable[..., Any], scan: Callable[..., Any]) -> None:
    """Call them once on zeros: numba compiles (or loads) for the types the runner passes."""
    import numpy as np

    from pointat.compiled import kernel as k
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
    """Compile the chain into the cache (what ``python -m pointat.compiled.build`` does)."""
    try:
        _kernel()
    finally:
        (cache_dir() / "compiling").unlink(missing_ok=True)
    return cache_dir()


def warm_in_background() -> subprocess.Popen[bytes] | None:
    """Start :func:`warm` in a process of its own, at low priority; ``None`` when a compile is under way
    already."""
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
        [sys.executable, "-m", "pointat.compiled.build", str(cache_dir())],
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
    """``python -m pointat.compiled.build [CACHE]``: compile into the cache; with ``CACHE`` (the folder
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
