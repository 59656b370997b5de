"""Find the patches running on this machine and the network (``pointat ls``).

A patch run with ``--monitor`` advertises its OSCQuery server by zeroconf as ``_oscjson._tcp`` and its OSC
port as ``_osc._udp`` (:mod:`pointat.monitor.webserver`), under one name: ``pointat PATCH HHMMSS`` (the time it
started, so that two runs of one patch differ).  :func:`browse` listens for both for a few seconds and
pairs them by that name; :func:`fetch_tree` reads a server's address space over HTTP, as any OSCQuery
client does (no ``Origin``, so no token is needed from a machine the server allows).

Other programs that speak OSCQuery (ossia score, Chataigne, TouchDesigner) are listed too, under their
own names.
"""

from __future__ import annotations

import json
import re
import threading
import time
import urllib.error
import urllib.request
from dataclasses import dataclass, field
from typing import Any

__all__ = ["Service", "browse", "fetch_tree", "patch_name", "tree_lines"]

OSCQUERY = "_oscjson._tcp.local."
OSC = "_osc._udp.local."


@dataclass
class Service:
    """One advertised server: its zeroconf name, addresses and ports."""

    name: str
    addresses: list[str] = field(default_factory=list)
    port: int = 0  # OSCQuery's (HTTP and WebSocket)
    osc_port: int | None = None  # OSC over UDP, when it is advertised too
    server: str = ""

    @property
    def host(self) -> str:
        """The address to reach it at: loopback when it is this machine's, else its first."""
        for a in self.addresses:
            if a.startswith("127.") or a == "::1":
                return a
        return self.addresses[0] if self.addresses else self.server.rstrip(".")

    @property
    def patch(self) -> str:
        return patch_name(self.name)

    def url(self, path: str = "/") -> str:
        host = f"[{self.host}]" if ":" in self.host else self.host
        return f"http://{host}:{self.port}{path}"


def patch_name(name: str) -> str:
    """The patch a zeroconf name stands for (``pointat NAME HHMMSS``, maybe with zeroconf's `` (2)``),
    else the name as it is (another program's).

    >>> patch_name("pointat glove_tqt 101502._oscjson._tcp.local.")
    'glove_tqt'
    >>> patch_name("pointat my patch 101502 (2)._oscjson._tcp.local.")
    'my patch'
    >>> patch_name("ossia score._oscjson._tcp.local.")
    'ossia score'
    """
    label = name.split("._", 1)[0]
    match = re.fullmatch(r"pointat (.+) \d{6}( \(\d+\))?", label)
    return match.group(1) if match else label


def browse(seconds: float, *, local: bool = False) -> list[Service]:
    """The OSCQuery servers that answer within ``seconds``, sorted by patch and host.  ``local``: this
    machine's only (loopback), else every interface's.  Raises ``RuntimeError`` without zeroconf."""
    try:
        from zeroconf import InterfaceChoice, ServiceBrowser, Zeroconf
    except ImportError:
        raise RuntimeError("zeroconf is not installed (pip install zeroconf)") from None
    found: dict[tuple[str, str], None] = {}
    lock = threading.Lock()

    class Listener:
        def add_service(self, _zc: Any, kind: str, name: str) -> None:
            with lock:
                found[(kind, name)] = None

        update_service = add_service

        def remove_service(self, _zc: Any, kind: str, name: str) -> None:
            with lock:
                found.pop((kind, name), None)

    zc = Zeroconf(interfaces=["127.0.0.1"] if local else InterfaceChoice.All)
    try:
        browser = ServiceBrowser(zc, [OSCQUERY, OSC], Listener())
        time.sleep(seconds)
        browser.cancel()
        with lock:
            names = list(found)
        services: dict[str, Service] = {}
        osc_ports: dict[str, int] = {}
        for kind, name in names:
            info = zc.get_service_info(kind, name, timeout=1000)
            if info is None:
                continue
            label = name[: -len(kind) - 1] if name.endswith("." + kind) else name
            if kind == OSC:
                osc_ports[label] = info.port
                continue
            services[label] = Service(name, list(info.parsed_addresses()), info.port, None, info.server or "")
        for label, service in services.items():
            service.osc_port = osc_ports.get(label)
        return sorted(services.values(), key=lambda s: (s.patch, s.host, s.port))
    finally:
        zc.close()


def fetch_tree(service: Service, timeout: float = 3.0) -> dict[str, Any]:
    """A server's OSCQuery address space (``GET /``), as JSON; ``OSError`` or ``ValueError`` says why not."""
    request = urllib.request.Request(service.url("/"), headers={"Accept": "application/json"})
    try:
        with urllib.request.urlopen(request, timeout=timeout) as response:
            data = response.read(1 << 22)
    except urllib.error.HTTPError as exc:
        hint = " (this machine is not in its --monitor-allow)" if exc.code == 403 else ""
        raise OSError(f"{service.url('/')}: HTTP {exc.code} {exc.reason}{hint}") from None
    except (TimeoutError, urllib.error.URLError) as exc:
        reason = getattr(exc, "reason", exc)
        raise OSError(f"{service.url('/')}: {reason}") from None
    try:
        tree = json.loads(data)
    except RecursionError:  # (nested deeper than the parser's stack: not a tree anyone serves)
        raise ValueError(f"{service.url('/')}: JSON nested too deep") from None
    if not isinstance(tree, dict):
        raise ValueError(f"{service.url('/')}: not an OSCQuery tree (a JSON {type(tree).__name__})")
    return tree


def tree_lines(tree: dict[str, Any]) -> list[str]:
    """Every leaf of an OSCQuery tree as a line: ``ADDRESS TYPE = VALUE  (r/w)``, in address order.

    >>> tree_lines({"CONTENTS": {"a": {"FULL_PATH": "/a", "TYPE": "f", "VALUE": [0.5], "ACCESS": 3},
    ...                          "b": {"FULL_PATH": "/b", "TYPE": "N", "ACCESS": 2}}})
    ['/a f = 0.5  (rw)', '/b N  (w)']
    """
    lines = []
    todo = [tree]  # (a stack, not recursion: a remote's tree may be nested deeper than Python's stack)
    while todo:
        node = todo.pop()
        contents = node.get("CONTENTS")
        if isinstance(contents, dict) and contents:
            todo += [contents[k] for k in sorted(contents, reverse=True) if isinstance(contents[k], dict)]
            continue
        if "FULL_PATH" not in node or contents is not None:
            continue
        text = f"{node['FULL_PATH']} {node.get('TYPE', '')}".rstrip()
        value = node.get("VALUE")
        if isinstance(value, list) and value:
            text += " = " + " ".join(f"{v:g}" if isinstance(v, float) else str(v) for v in value)
        access = node.get("ACCESS")
        access = {1: "r", 2: "w", 3: "rw"}.get(access, "") if isinstance(access, int) else ""
        lines.append(text + (f"  ({access})" if access else ""))
    return lines
