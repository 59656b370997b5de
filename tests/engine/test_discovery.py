"""``pointat ls``: a patch's monitor advertised by zeroconf on loopback is found, with its ports, and its
OSCQuery tree read over HTTP (real sockets, real multicast on the loopback device)."""

from __future__ import annotations

import os
import socket

import pytest

from pointat.checking import check
from pointat.cli import main
from pointat.discovery import Service, browse, fetch_tree, tree_lines
from pointat.loader import build
from pointat.monitor.observe import Observer
from pointat.monitor.webserver import MonitorServer
from pointat.patchfile import parse_patch
from pointat.registry import Registry
from pointat.testing import wait_until

REG = Registry().load_builtins()


@pytest.fixture
def advertised():
    """A patch's monitor on a free loopback port, advertised as a running patch's is; its name is this
    test process's own, so that patches other people run on the machine are told apart."""
    name = f"lstest{os.getpid()}"
    rt = build(check(parse_patch("node tick metro 100\nnode fuse tqt rate=100\n", "<ls>"), REG))
    observer = Observer(rt, patch=name).attach()
    server = MonitorServer(rt, observer, "127.0.0.1", 0, name=f"pointat {name}")
    server.start()
    try:
        if not wait_until(lambda: server._zeroconf is not None, timeout=20):
            pytest.skip("zeroconf cannot advertise on loopback here (no multicast on the loopback device)")
        yield name, server
    finally:
        server.close()
        rt.shutdown()


def _find(name: str) -> Service | None:
    for _ in range(3):  # (a browse is bounded; an answer may miss the first)
        found = [s for s in browse(1.5, local=True) if s.patch == name]
        if found:
            return found[0]
    return None


def test_a_running_patch_is_found_with_its_ports_and_tree(advertised):
    name, server = advertised
    service = _find(name)
    assert service is not None
    assert service.host == "127.0.0.1"
    assert service.port == server.port and service.osc_port == server.osc_port
    assert service.url("/monitor") == f"http://127.0.0.1:{server.port}/monitor"
    lines = tree_lines(fetch_tree(service))
    assert "/pointat/tick/interval f = 100  (rw)" in lines
    assert "/pointat/fuse/reset N  (w)" in lines


def test_pointat_ls_prints_it(advertised, capsys):
    name, server = advertised
    assert _find(name) is not None  # (answering now)
    assert main(["ls", "--local", "--tree", "--for", "2"]) == 0
    out = capsys.readouterr().out.splitlines()
    mine = [i for i, line in enumerate(out) if line.startswith(name + " ")]
    assert mine, out
    line = out[mine[0]]
    assert f"OSCQuery {server.port}/tcp" in line and f"OSC {server.osc_port}/udp" in line
    assert "    /pointat/tick/interval f = 100  (rw)" in out[mine[0] + 1 :]


def test_a_tree_that_cannot_be_read_says_why():
    with socket.socket() as s:  # a port nobody listens on
        s.bind(("127.0.0.1", 0))
        port = s.getsockname()[1]
    with pytest.raises(OSError, match=f"http://127.0.0.1:{port}/: .*refused"):
        fetch_tree(Service("x", ["127.0.0.1"], port), timeout=2)


# -- a remote's OSCQuery tree is outside bytes: any JSON at all is printed or refused, never a crash
from hypothesis import given, settings  # noqa: E402
from hypothesis import strategies as st  # noqa: E402

_JSON = st.recursive(
    st.none() | st.booleans() | st.integers() | st.floats() | st.text(max_size=8),
    lambda inner: (
        st.lists(inner, max_size=4)
        | st.dictionaries(
            st.sampled_from(["CONTENTS", "FULL_PATH", "TYPE", "VALUE", "ACCESS", "x"]) | st.text(max_size=4),
            inner,
            max_size=5,
        )
    ),
    max_leaves=30,
)


@settings(max_examples=300, deadline=None)
@given(_JSON)
def test_any_json_tree_gives_lines_of_text(tree):
    lines = tree_lines(tree) if isinstance(tree, dict) else []
    assert all(isinstance(line, str) for line in lines)


def test_a_tree_nested_deeper_than_the_stack_gives_lines():
    tree: dict = {"FULL_PATH": "/deep", "TYPE": "f"}
    for k in range(100_000):
        tree = {"CONTENTS": {str(k): tree}}
    assert tree_lines(tree) == ["/deep f"]


@settings(max_examples=300, deadline=None)
@given(st.text(max_size=80))
def test_any_advertised_name_gives_a_patch_name_within_it(name):
    from pointat.discovery import patch_name

    got = patch_name(name)
    assert isinstance(got, str) and got in name
