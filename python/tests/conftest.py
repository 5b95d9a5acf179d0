"""Fixtures and markers of the roks_tools tests.

* `roks`: the roks binary (`roks_tools.runner.roks_binary`): `$ROKS_BIN`
  (tests/mitsuba_chain.rs sets it to the binary cargo built), else `roks`
  on PATH, else the repository's target/release/roks. A missing binary
  fails the tests that need it (build it first).
* `mi`: the mitsuba module with the variant `setup_mitsuba("auto")` picks.
* Tests marked `mitsuba` are skipped when mitsuba cannot be imported,
  unless `ROKS_REQUIRE_MITSUBA=1`, where that is a failure.
"""

from __future__ import annotations

import importlib.util
import os

import pytest

from roks_tools.errors import BinaryNotFound
from roks_tools.runner import roks_binary


def _have_mitsuba() -> bool:
    return all(importlib.util.find_spec(m) is not None for m in ("mitsuba", "drjit"))


def pytest_runtest_setup(item):
    if item.get_closest_marker("mitsuba") and not _have_mitsuba():
        if os.environ.get("ROKS_REQUIRE_MITSUBA") == "1":
            pytest.fail("ROKS_REQUIRE_MITSUBA=1 but mitsuba cannot be imported (scripts/setup_venv.sh)")
        pytest.skip("mitsuba cannot be imported (scripts/setup_venv.sh)")


@pytest.fixture(scope="session")
def roks() -> str:
    try:
        return str(roks_binary())
    except BinaryNotFound as e:
        pytest.fail(str(e))


@pytest.fixture(scope="session")
def mi():
    from roks_tools.mitsuba.setup import setup_mitsuba
    return setup_mitsuba("auto")
