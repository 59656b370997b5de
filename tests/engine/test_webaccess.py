"""Who may use the monitor's port (pointat.monitor.webaccess), as plain functions: Host, Origin, peers, token."""

from __future__ import annotations

import pytest

from pointat.monitor.webaccess import Access, LogLimit


def test_on_loopback_only_this_machines_names_on_the_port_served_are_hosts():
    a = Access("127.0.0.1", 9002)
    for host in ("127.0.0.1:9002", "localhost:9002", "LOCALHOST:9002", "[::1]:9002"):
        assert a.refusal("127.0.0.1", host, None, "/") is None, host
    for host in (None, "", "evil.example:9002", "127.0.0.1:9003", "127.0.0.1", "127.0.0.1.evil:9002",
                 "127.0.0.1:9002@evil", "localhost:abc", "[::1", "127.0.0.2:9002"):  # fmt: skip
        assert a.refusal("127.0.0.1", host, None, "/") is not None, host
    assert a.token is None and a.url() == "http://127.0.0.1:9002/monitor"


def test_an_origin_must_be_the_pages_own():
    a = Access("127.0.0.1", 9002)
    host = "127.0.0.1:9002"
    for origin in ("http://127.0.0.1:9002", "http://localhost:9002", "http://[::1]:9002"):
        assert a.refusal("127.0.0.1", host, origin, "/") is None, origin
    for origin in ("http://evil.example", "null", "", "https://127.0.0.1:9002", "http://127.0.0.1:9003",
                   "http://127.0.0.1", "file://", "http://user@127.0.0.1:9002", "http://127.0.0.1:9002/x"):  # fmt: skip
        why = a.refusal("127.0.0.1", host, origin, "/")
        assert why is not None and "Origin" in why, origin


def test_a_peer_from_another_machine_is_refused_on_loopback_and_outside_the_allow_list():
    assert Access("127.0.0.1", 9002).refusal("192.168.1.9", "127.0.0.1:9002", None, "/") is not None
    a = Access("192.168.1.5", 9002, allow=["192.168.1.0/24"], token="t0k")
    assert a.peer_allowed("192.168.1.9") and a.peer_allowed("127.0.0.1") and a.peer_allowed("::1")
    assert not a.peer_allowed("10.0.0.1") and not a.peer_allowed("not an address")
    why = a.refusal("10.0.0.1", "192.168.1.5:9002", None, "/")
    assert why is not None and "--monitor-allow" in why


def test_serving_wider_needs_an_allow_list_and_a_bad_one_is_named():
    with pytest.raises(ValueError, match="allow-list"):
        Access("0.0.0.0", 9002)
    with pytest.raises(ValueError, match="'nonsense'"):
        Access("0.0.0.0", 9002, allow=["nonsense"])


def test_a_browser_from_another_machine_needs_the_token_an_oscquery_tool_does_not():
    a = Access("192.168.1.5", 9002, allow=["192.168.1.0/24"], token="s3cret")
    peer, host, origin = "192.168.1.9", "192.168.1.5:9002", "http://192.168.1.5:9002"
    assert a.url() == "http://192.168.1.5:9002/monitor?token=s3cret"
    assert a.refusal(peer, host, None, "/monitor") is not None  # the page without the token
    assert a.refusal(peer, host, None, "/monitor?token=wrong") is not None
    assert a.refusal(peer, host, None, "/monitor?token=s3cret") is None
    assert a.set_cookie("token=s3cret") == "pointat_token_9002=s3cret; Path=/; HttpOnly; SameSite=Strict"
    assert a.set_cookie("token=wrong") is None and a.set_cookie("") is None
    # the page's own requests carry the cookie; the socket without it is refused
    assert a.refusal(peer, host, origin, "/", "pointat_token_9002=s3cret") is None
    assert a.refusal(peer, host, origin, "/", "pointat_token_9002=nope") is not None
    assert a.refusal(peer, host, origin, "/", 'bad"cookie') is not None
    assert a.refusal(peer, host, origin, "/") is not None
    # an OSCQuery tool (no Origin) on an allowed machine reads the tree
    assert a.refusal(peer, host, None, "/?HOST_INFO") is None
    # this machine's own browser needs no token
    assert a.refusal("127.0.0.1", "localhost:9002", "http://localhost:9002", "/monitor") is None


def test_bound_to_every_interface_the_machines_names_are_hosts():
    import socket

    a = Access("0.0.0.0", 9002, allow=["192.168.0.0/16"])
    assert a.token and len(a.token) >= 16
    assert {"127.0.0.1", "localhost", socket.gethostname().lower()} <= a.names
    assert a.refusal("127.0.0.1", f"{socket.gethostname()}:9002", None, "/") is None
    assert a.refusal("127.0.0.1", "evil.example:9002", None, "/") is not None


def test_the_log_limit_tells_a_flood_in_a_few_lines_and_counts_the_rest():
    lines: list[str] = []
    now = [0.0]
    limit = LogLimit(lambda msg, *a: lines.append(msg % a), burst=3, period=10.0, clock=lambda: now[0])
    for i in range(1000):
        limit("gone %d", i)
    assert lines == ["gone 0", "gone 1", "gone 2"] and limit.held == 997 and limit.count == 1000
    now[0] = 10.0
    limit("gone %d", 1000)
    assert lines[-1] == "gone 1000 (and 997 more like it before, not logged one by one)"
