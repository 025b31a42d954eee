"""The EGM96 geoid grid for the tests that check ellipsoidal heights: a failure in CI, else a skip."""

from __future__ import annotations

import os

import pytest

from sightplan import geoid


def require_geoid() -> None:
    if geoid.available():
        return
    reason = f"the EGM96 geoid grid is not installed: {geoid.INSTALL_HINT}"
    if os.environ.get("CI"):
        pytest.fail(f"{reason} (CI must check the ellipsoidal heights)")
    pytest.skip(reason)
