"""The background threads of the device layer: started as daemons, stopped with a bounded join."""

from __future__ import annotations

import logging
import threading
from collections.abc import Callable

log = logging.getLogger("pointat.devices")


def start_daemon(target: Callable[[], object], name: str) -> threading.Thread:
    """Start ``target`` on a daemon thread called ``name``."""
    thread = threading.Thread(target=target, name=name, daemon=True)
    thread.start()
    return thread


def join(thread: threading.Thread | None, timeout: float) -> None:
    """Wait up to ``timeout`` s for ``thread`` (not when called from it); log one that does not end."""
    if thread is not None and thread is not threading.current_thread():
        thread.join(timeout)
        if thread.is_alive():
            log.warning("thread %s did not stop within %.1f s", thread.name, timeout)
