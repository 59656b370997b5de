"""Where numba keeps the machine code of pointat's compiled maths: the user's cache folder.

numba's ``cache=True`` writes beside the source file when it may (``__pycache__/*.nbi``, ``*.nbc``): in an
installed pointat that is inside site-packages, where nothing of a run belongs (it is lost, or stale,
at the next upgrade, and a shared installation is not the user's to write).  Compiled under
:func:`user_cache`, the code goes to ``$XDG_CACHE_HOME/pointat/numba`` (``~/.cache/...``) instead, which
numba keys by the source file's full path, so an installed copy and a checkout never share an entry.
"""

from __future__ import annotations

import contextlib
import os
from collections.abc import Iterator
from pathlib import Path
from typing import Any

__all__ = ["cache_root", "user_cache"]


def cache_root() -> Path:
    """pointat's cache folder: ``$XDG_CACHE_HOME/pointat``, else ``~/.cache/pointat``."""
    return Path(os.environ.get("XDG_CACHE_HOME") or Path.home() / ".cache") / "pointat"


@contextlib.contextmanager
def user_cache(numba: Any) -> Iterator[None]:
    """Functions given ``numba.njit(cache=True)`` inside this block cache into :func:`cache_root`
    (numba reads its cache folder as a function's cache is set up: when it is decorated)."""
    saved = numba.config.CACHE_DIR
    numba.config.CACHE_DIR = str(cache_root() / "numba")
    try:
        yield
    finally:
        numba.config.CACHE_DIR = saved
