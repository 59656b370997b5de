"""Suite-wide fixtures.

``started``: ``started(rt)`` starts a runtime and shuts it down after the test, whatever happens.

``require_tool``: a test that needs a real program (Pd, oscdump...) calls ``require_tool(shutil.which("pd")
is not None, "Pure Data is not installed")``.  It skips where the tool is missing, except where
``POINTAT_REQUIRE_TOOLS=1`` (CI, which installs every tool): there a missing tool is a failure.
"""

import os

import pytest


def _require(available: bool, reason: str) -> None:
    if available:
        return
    if os.environ.get("POINTAT_REQUIRE_TOOLS"):
        pytest.fail(f"{reason} (POINTAT_REQUIRE_TOOLS is set: CI must install it)")
    pytest.skip(reason)


@pytest.fixture
def require_tool():
    return _require


@pytest.fixture
def started():
    runtimes = []

    def start(rt):
        runtimes.append(rt)
        rt.start()
        return rt

    yield start
    for rt in runtimes:
        rt.shutdown()
