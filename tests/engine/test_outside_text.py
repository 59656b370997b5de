"""Text from outside that the monitor and presets read, as property tests: a presets file a person edited
(any bytes, any JSON), and any request line a client sends to the monitor's HTTP server."""

from __future__ import annotations

import json
import socket
import time

import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from pointat.checking import check
from pointat.loader import build
from pointat.monitor.observe import Observer
from pointat.monitor.webserver import READS_METHODS, MonitorServer
from pointat.patchfile import parse_patch
from pointat.presets import Presets
from pointat.registry import Registry

SETTINGS = settings(
    derandomize=True,
    database=None,
    deadline=None,
    max_examples=150,
    suppress_health_check=[HealthCheck.function_scoped_fixture],
)
REG = Registry().load_builtins()


def _runtime():
    spec = parse_patch("node lim speedlim 100\nnode m metro 50\nnode on loadbang\non -> m -> lim", "x.pat")
    return build(check(spec, REG))


@pytest.fixture(scope="module")
def server_port():
    rt = _runtime()
    obs = Observer(rt).attach()
    server = MonitorServer(rt, obs, "127.0.0.1", 0, advertise=False)
    server.start()
    yield server.port
    server.close()


json_values = st.recursive(
    st.none() | st.booleans() | st.floats(allow_nan=False) | st.integers() | st.text(max_size=10),
    lambda inner: st.lists(inner, max_size=4) | st.dictionaries(st.text(max_size=8), inner, max_size=4),
    max_leaves=20,
)


@SETTINGS
@given(st.binary(max_size=300) | json_values.map(lambda v: json.dumps(v).encode()))
def test_any_presets_file_loads_or_is_refused_and_kept(tmp_path_factory, data):
    path = tmp_path_factory.mktemp("p") / "x.presets.json"
    path.write_bytes(data)
    rt = _runtime()
    said: list[str] = []
    rt.console = said.append
    presets = Presets(rt, path)  # never raises
    if not presets.writable:  # refused: the file stays as it was, even after a save
        presets.save("new")
        assert path.read_bytes() == data
        return
    for name in presets.names():  # every preset it took can be recalled without an exception
        presets.recall(name)
    presets.save("new")
    assert "new" in json.loads(path.read_text())["presets"]


def test_a_presets_entry_of_the_wrong_type_is_skipped_not_taken(tmp_path):
    path = tmp_path / "x.presets.json"
    path.write_text(
        json.dumps({"presets": {"a": {"lim": {"interval": "fast", "nope": 1}, "ghost": {"x": 1}}}})
    )
    rt = _runtime()
    rt.console = lambda line: None
    rt.start()
    try:
        Presets(rt, path).recall("a")
        rt.drain()
        assert rt.nodes["lim"].p.interval == 100.0  # "fast" refused by the parameter's own check
    finally:
        rt.shutdown()


@settings(derandomize=True, database=None, deadline=None, max_examples=200)
@given(
    st.text(
        alphabet=st.characters(min_codepoint=33, max_codepoint=0x2FF, blacklist_characters="\x7f"),
        max_size=60,
    ),
    st.sampled_from(["GET", "HEAD", "POST", "PUT", "OPTIONS", "GARBAGE"]),
)
def test_any_request_line_gets_an_answer_and_the_server_lives_on(server_port, path, verb):
    port = server_port
    with socket.create_connection(("127.0.0.1", port), timeout=5) as s:
        s.sendall(
            f"{verb} /{path} HTTP/1.1\r\nHost: 127.0.0.1:{port}\r\nConnection: close\r\n\r\n".encode(
                "utf-8", "replace"
            )
        )
        reply = b""
        deadline = time.monotonic() + 5
        while time.monotonic() < deadline:
            chunk = s.recv(65536)
            if not chunk:
                break
            reply += chunk
    # a request the server's parser (the websockets library's) does not take (not ASCII) is closed
    # unanswered; any other is answered (405 for a method other than GET and HEAD)
    if path.isascii() and (verb == "GET" or READS_METHODS):
        status = int(reply.split(b" ", 2)[1])
        assert status in ((200, 204, 404) if verb in ("GET", "HEAD") else (405,)), reply[:200]
    elif reply:
        assert int(reply.split(b" ", 2)[1]) in (200, 204, 400, 404, 405, 414), reply[:200]
    with socket.create_connection(("127.0.0.1", port), timeout=5) as s:  # and it serves on
        s.sendall(f"GET /?HOST_INFO HTTP/1.1\r\nHost: 127.0.0.1:{port}\r\n\r\n".encode())
        assert s.recv(65536).startswith(b"HTTP/1.1 200 ")
