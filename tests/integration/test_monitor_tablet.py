"""A stage tablet's view of the monitor, in a real browser (headless Chromium): ``pointat run glove_tqt
--monitor 0 --monitor-host ADDRESS --monitor-allow ADDRESS/32`` on this machine's network address, the
browser connecting from that address (not loopback, so the tablet's rules hold).  The printed URL's
token opens the page, which keeps it as a cookie for its own WebSocket; the page without it is refused.
"""

from __future__ import annotations

import re
import socket
import subprocess
import sys
import time

import pytest

from pointat.monitor.webaccess import _lan_address

from .test_monitor import _wait, browser  # noqa: F401 (the browser fixture)


@pytest.fixture
def tablet_patch(tmp_path):
    lan = _lan_address()
    if lan is None:
        pytest.skip("no network address on this machine")
    rx = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
    rx.bind(("127.0.0.1", 0))
    cmd = [sys.executable, "-m", "pointat.cli", "run", "glove_tqt", "--monitor", "0", "--for", "60"]
    cmd += ["--monitor-host", lan, "--monitor-allow", f"{lan}/32", "--compiled", "off"]
    cmd += ["--set", f"out.port={rx.getsockname()[1]}", "--set", "ctl.port=0"]
    proc = subprocess.Popen(cmd, cwd=tmp_path, stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True)
    url = None
    lines = []
    deadline = time.monotonic() + 30
    while time.monotonic() < deadline and url is None:
        line = proc.stdout.readline()
        if not line:
            break
        lines.append(line)
        m = re.search(r"monitor  (http://\S+/monitor\?token=\S+)", line)
        if m:
            url = m.group(1)
    try:
        assert url is not None, ("no monitor line with a token in the banner", lines)
        yield url
    finally:
        proc.terminate()
        proc.communicate(timeout=20)
        rx.close()


def test_the_printed_url_opens_the_page_and_its_socket_and_no_other_does(tablet_patch, browser):  # noqa: F811
    url = tablet_patch
    bare = url.split("?")[0]
    browser.get(bare)  # without the token: refused
    assert "forbidden" in browser.page_source
    browser.get(url)
    frames = _wait(browser, "return window.pointatMonitor.frames", lambda n: n >= 25, 30.0)
    assert frames >= 25, "the page got no readings over its WebSocket"
    assert browser.execute_script("return window.pointatMonitor.connected") is True
    # the token stays with the page: reloaded without it, it still opens (the cookie)
    browser.get(bare)
    assert "forbidden" not in browser.page_source
