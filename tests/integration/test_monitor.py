"""The monitor page in a real browser: Debian's Chromium, driven through its ChromeDriver (selenium), on a
patch run as a performer runs it (``pointat run glove_tqt --monitor 0``), the simulated glove moving.

What a performer would look at is checked on screenshots of the page's canvases: the pointer (its colour)
is drawn, and it moves.  The page's readout changes with the glove, the sensor stream says 100 Hz while
the page is open, and the browser's own WebSocket gets OSCQuery's LISTEN stream (an OSC message per
change of ``/pointat/out/aed``).  At a phone's and a tablet's width the page fits (no sideways scrolling,
views a useful size), and a real dropout (the simulated glove told to go silent) greys the pointer and
the big readout, says "NO DATA for N s" big, and the filter says it has no input; screenshots of both
states are kept in the test's folder.
"""

from __future__ import annotations

import io
import json
import re
import shutil
import socket
import struct
import subprocess
import sys
import time
import urllib.request
from pathlib import Path

import numpy as np
import pytest

from tests.monitor_client import CHROMIUM_FLAGS

ROOT = Path(__file__).resolve().parents[2]
POINTER = np.array([0x4F, 0xC3, 0xF7])  # the first pointer's colour (monitor.js COLOURS[0])


def _free_udp() -> socket.socket:
    s = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
    s.bind(("127.0.0.1", 0))
    return s


@pytest.fixture
def running_patch(tmp_path):
    """``pointat run glove_tqt --monitor 0`` (a receiver of our own on a free port); its monitor's URL."""
    rx = _free_udp()
    rx.settimeout(0.05)
    cmd = [sys.executable, "-m", "pointat.cli", "run", "glove_tqt", "--monitor", "0", "--for", "120"]
    cmd += ["--set", f"out.port={rx.getsockname()[1]}", "--set", "ctl.port=0"]
    proc = subprocess.Popen(cmd, cwd=tmp_path, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    url = None
    deadline = time.monotonic() + 20
    lines = []
    while time.monotonic() < deadline and url is None:
        line = proc.stdout.readline()
        if not line:
            break
        lines.append(line)
        m = re.search(r"monitor  (http://127\.0\.0\.1:\d+/monitor\S*).*OSC control on (\d+)/udp", line)
        if m:
            url, control = m.group(1), int(m.group(2))
    try:
        assert url is not None, ("no monitor line in the banner", lines, proc.poll())
        yield url, rx, control, proc
    finally:
        proc.terminate()
        proc.communicate(timeout=10)
        rx.close()


@pytest.fixture
def browser(require_tool, tmp_path_factory):
    require_tool(shutil.which("chromium") is not None, "Chromium is not installed (Debian: chromium)")
    require_tool(shutil.which("chromedriver") is not None, "ChromeDriver is not installed (chromium-driver)")
    try:
        from selenium import webdriver
        from selenium.webdriver.chrome.service import Service
    except ImportError:
        require_tool(False, "selenium is not installed (pip install selenium)")
    options = webdriver.ChromeOptions()
    options.binary_location = shutil.which("chromium")
    for flag in CHROMIUM_FLAGS:
        options.add_argument(flag)
    options.add_argument(f"--user-data-dir={tmp_path_factory.mktemp('chromium')}")
    driver = webdriver.Chrome(service=Service(shutil.which("chromedriver")), options=options)
    driver.set_page_load_timeout(20)
    driver.set_script_timeout(10)
    try:
        yield driver
    finally:
        driver.quit()


def _pixels(png: bytes) -> np.ndarray:
    import matplotlib.image

    return (matplotlib.image.imread(io.BytesIO(png), format="png")[..., :3] * 255).round().astype(int)


def _pointer_pixels(img: np.ndarray) -> np.ndarray:
    return np.argwhere(np.abs(img - POINTER).sum(axis=-1) < 30)


def _wait(driver, script: str, until, seconds: float = 10.0):
    deadline = time.monotonic() + seconds
    while True:
        value = driver.execute_script(script)
        if until(value) or time.monotonic() > deadline:
            return value
        time.sleep(0.1)


def test_the_monitor_shows_the_glove_moving_over_the_loudspeakers(running_patch, browser, tmp_path):
    url, _rx, _control, _proc = running_patch
    browser.get(url)
    frames = _wait(browser, "return window.pointatMonitor.frames", lambda n: n >= 25)
    assert frames >= 25, "the page got no readings over its WebSocket"
    assert browser.execute_script("return window.pointatMonitor.connected") is True
    # grey while the gyro nulls are measured (no direction yet), then in the pointer's colour
    live = _wait(browser, "return document.body.dataset.state", lambda v: v == "ok", 60.0)
    assert live == "ok", live
    # the glove's script sweeps the room: the readout and the drawing change as it moves
    first = browser.execute_script("return document.querySelector('.aed').textContent")
    above = browser.find_element("id", "above")
    shot1 = above.screenshot_as_png
    _wait(browser, "return document.querySelector('.aed').textContent", lambda t: t != first, 10.0)
    time.sleep(1.0)
    second = browser.execute_script("return document.querySelector('.aed').textContent")
    shot2 = above.screenshot_as_png
    assert re.fullmatch(r"az +-?\d+\.\d°  el +-?\d+\.\d°  dist \d+", first), first
    assert second != first, "the readout did not move with the glove"
    img1, img2 = _pixels(shot1), _pixels(shot2)
    p1, p2 = _pointer_pixels(img1), _pointer_pixels(img2)
    assert len(p1) > 100 and len(p2) > 100, "no pointer drawn from above"
    # its tip (the pointer pixel farthest from the centre) moved
    centre = np.array(img1.shape[:2]) / 2

    def tip(p):
        return p[np.argmax(((p - centre) ** 2).sum(axis=1))]

    assert np.linalg.norm(tip(p1) - tip(p2)) > 5, (tip(p1), tip(p2))
    # the rest of the page: eight loudspeakers' gains, the stream at its rate while the page is open
    state = json.loads(urllib.request.urlopen(url + "/state", timeout=5).read())
    assert state["layout"]["azimuths"] == [0, 45, 90, 135, 180, -135, -90, -45]
    gains = state["pointers"][0]["gains"]
    assert len(gains) == 8 and abs(sum(g * g for g in gains) - 1.0) < 1e-2
    (stream,) = state["streams"]
    assert stream["state"] == "ok" and 90 <= stream["rate"] <= 110, stream
    rows = browser.execute_script("return document.querySelectorAll('#sensors tbody tr').length")
    assert rows == 1
    history = browser.execute_script("return window.pointatMonitor.history.out.map(h => h[1])")
    assert max(history) - min(history) > 10, "the azimuth plot shows no motion"
    page = tmp_path / "monitor.png"
    page.write_bytes(browser.get_screenshot_as_png())
    assert _pixels(page.read_bytes()).std() > 10  # not a blank page
    # on a phone and a tablet held upright it fits (the dropout at these widths: the slow tier's test)
    for device in sorted(WIDTHS):
        _as_device(browser, device)
        _wait(browser, "return window.innerWidth", lambda w, d=device: w == WIDTHS[d][0], 10.0)
        _assert_fits(browser, device)
        (tmp_path / f"monitor-{device}.png").write_bytes(browser.get_screenshot_as_png())


def test_the_browsers_websocket_gets_oscquery_listen_messages(running_patch, browser):
    url, _rx, _control, _proc = running_patch
    browser.get(url)
    got = browser.execute_async_script(
        """
        const done = arguments[arguments.length - 1];
        const ws = new WebSocket(`ws://${location.host}/`);
        ws.binaryType = "arraybuffer";
        const seen = [];
        ws.onopen = () => ws.send(JSON.stringify({COMMAND: "LISTEN", DATA: "/pointat/out/aed"}));
        ws.onmessage = (ev) => {
          const bytes = new Uint8Array(ev.data);
          const address = new TextDecoder().decode(bytes.slice(0, bytes.indexOf(0)));
          const view = new DataView(ev.data);
          seen.push([address, view.getFloat32(bytes.length - 12)]);
          if (seen.length === 5) { ws.send(JSON.stringify({COMMAND: "IGNORE", DATA: "/pointat/out/aed"})); ws.close(); done(seen); }
        };
        setTimeout(() => done(seen), 8000);
        """
    )
    assert len(got) == 5, got
    assert {a for a, _ in got} == {"/pointat/out/aed"}
    azimuths = [az for _, az in got]
    assert len(set(azimuths)) > 1, azimuths  # only changes are sent, and the glove moves


#: A phone held upright, and a tablet held upright (CSS pixels).
WIDTHS = {"phone": (390, 844), "tablet": (820, 1180)}

LAYOUT = """
const fits = (e) => e.scrollWidth <= e.clientWidth + 1;
const box = (id) => document.getElementById(id).getBoundingClientRect();
return {
  inner: window.innerWidth,
  page: document.documentElement.scrollWidth,
  above: box("above").width, side: box("side").width, gains: box("gains").width,
  tables: [...document.querySelectorAll("table")].map((t) => [fits(t.parentElement), t.getBoundingClientRect().right]),
  right: Math.max(...[...document.querySelectorAll("main *")].map((e) => e.getBoundingClientRect().right)),
};
"""

LOOK = """
const p = document.querySelector(".pointer"), a = document.getElementById("alert");
const cell = document.querySelector("#filters tbody td:nth-child(2)");
if (!p) return { state: "not drawn yet" };
return {
  state: document.body.dataset.state,
  stale: p.classList.contains("stale"),
  opacity: parseFloat(getComputedStyle(p.querySelector(".aed")).opacity),
  colour: getComputedStyle(p.querySelector(".aed")).color,
  alert: a.hidden ? "" : a.textContent,
  alertSize: a.hidden ? 0 : parseFloat(getComputedStyle(a).fontSize),
  filter: cell ? cell.textContent : "",
};
"""


def _as_device(browser, device: str) -> None:
    width, height = WIDTHS[device]
    browser.execute_cdp_cmd(
        "Emulation.setDeviceMetricsOverride",
        {"width": width, "height": height, "deviceScaleFactor": 1, "mobile": True},
    )


def _assert_fits(browser, device: str) -> dict:
    """The page at a device's width: nothing wider than the screen, the views as wide as they can be."""
    width = WIDTHS[device][0]
    layout = browser.execute_script(LAYOUT)
    assert layout["inner"] == width, layout
    assert layout["page"] <= width, ("the page scrolls sideways", layout)
    assert layout["right"] <= width + 0.5, ("something sticks out to the right", layout)
    assert all(fits and right <= width for fits, right in layout["tables"]), ("a table overflows", layout)
    # the views fill the width they have: one column on a phone, the two side by side on a tablet
    least = {"phone": width - 2 * 10 - 2, "tablet": (width - 2 * 18 - 16) / 2 - 2}[device]
    assert layout["above"] >= least and layout["side"] >= least, layout
    return layout


@pytest.mark.slow  # (a real 10 s dropout at each width)
@pytest.mark.parametrize("device", sorted(WIDTHS))
def test_a_dropout_is_shown_big_and_grey_at_a_phones_and_a_tablets_width(
    running_patch, browser, tmp_path, device
):
    url, _rx, control, proc = running_patch
    width, height = WIDTHS[device]
    _as_device(browser, device)
    browser.get(url)
    # the glove's nulls measured, directions flowing: the page says all is well
    look = _wait(browser, LOOK, lambda v: v["state"] == "ok" and not v["stale"], 60.0)
    assert look["state"] == "ok" and not look["stale"] and look["opacity"] > 0.9, look
    assert look["alert"] == "" and look["filter"] == "ok", look

    layout = _assert_fits(browser, device)
    (tmp_path / f"monitor-{device}.png").write_bytes(browser.get_screenshot_as_png())

    # a real dropout: the simulated glove goes silent (no frames into the base station's pty) for 10 s
    with socket.socket(socket.AF_INET, socket.SOCK_DGRAM) as s:
        s.sendto(_osc("/pointat/glove/dropout", 10.0), ("127.0.0.1", control))
    look = _wait(browser, LOOK, lambda v: v["state"] == "dropout" and _seconds(v["alert"]) >= 1.0, 30.0)
    assert look["state"] == "dropout", look
    assert re.match(r"NO DATA for \d+\.\d s", look["alert"]), look
    assert look["alertSize"] >= 24, look  # big: read from across a stage
    assert look["stale"] and look["opacity"] < 0.5, look  # the big readout greyed
    assert look["colour"] == "rgb(107, 112, 120)", look  # the stale grey, not the pointer's blue
    assert look["filter"].startswith("no input"), look  # the filter does not say ok
    shot = browser.get_screenshot_as_png()
    (tmp_path / f"monitor-{device}-dropout.png").write_bytes(shot)
    browser.execute_script("document.getElementById('sensors').scrollIntoView()")  # the tables, too
    (tmp_path / f"monitor-{device}-dropout-tables.png").write_bytes(browser.get_screenshot_as_png())
    above = _pixels(browser.find_element("id", "above").screenshot_as_png)
    assert len(_pointer_pixels(above)) == 0, "the pointer is still drawn in its bright colour"
    assert layout["page"] <= width and browser.execute_script(LAYOUT)["page"] <= width

    # the glove back: all is well again
    look = _wait(browser, LOOK, lambda v: v["state"] == "ok" and not v["stale"], 60.0)
    assert look["state"] == "ok" and not look["stale"] and look["filter"] == "ok", look

    # the patch gone (stopped, crashed): the page does not go on showing its last direction as live
    proc.terminate()
    proc.wait(timeout=30)
    look = _wait(browser, LOOK, lambda v: v["state"] == "offline", 30.0)
    assert look["state"] == "offline" and look["alert"].startswith("PATCH NOT REACHABLE"), look
    assert look["stale"] and look["opacity"] < 0.5, look
    browser.execute_script("window.scrollTo(0, 0)")
    (tmp_path / f"monitor-{device}-offline.png").write_bytes(browser.get_screenshot_as_png())


def _seconds(alert: str) -> float:
    m = re.match(r"NO DATA for (\d+\.\d) s", alert)
    return float(m.group(1)) if m else 0.0


def _osc(address: str, value: float) -> bytes:
    """One OSC message with a float argument (the bytes ``pointat send`` would send)."""

    def pad(b: bytes) -> bytes:
        return b + b"\0" * (4 - len(b) % 4)

    return pad(address.encode()) + pad(b",f") + struct.pack(">f", value)


def test_another_machines_monitor_opens_from_a_host_and_port(running_patch, browser):
    """The header's field: host:port (as pointat ls prints it) opens that monitor in a tab of its own; a
    text that is no host:port is refused on the page and opens nothing.  (Here the other machine is this
    one: the same page from its own address.)"""
    url, _rx, _control, _proc = running_patch
    browser.get(url)
    host = url.split("/")[2]
    field = browser.find_element("id", "elsewhere-host")
    field.send_keys("no port here")
    browser.find_element("css selector", "#elsewhere button").click()
    assert "expected host:port" in browser.find_element("id", "elsewhere-why").text
    assert len(browser.window_handles) == 1
    field.clear()
    field.send_keys(host)
    browser.find_element("css selector", "#elsewhere button").click()
    deadline = time.monotonic() + 10
    while len(browser.window_handles) < 2 and time.monotonic() < deadline:
        time.sleep(0.1)
    assert len(browser.window_handles) == 2
    browser.switch_to.window(browser.window_handles[1])
    assert (
        _wait(browser, "return location.href", lambda h: h.endswith("/monitor")) == f"http://{host}/monitor"
    )
    assert _wait(browser, "return window.pointatMonitor.frames", lambda n: n >= 5) >= 5
