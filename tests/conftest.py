"""Shared fixtures: the real data folder (skipped cleanly when absent) and isolated caches."""

from __future__ import annotations

from pathlib import Path

import pytest

SHARED_DATA = Path(__file__).resolve().parents[1].parent / "shared" / "data"


@pytest.fixture(autouse=True, scope="session")
def _isolated_cache(tmp_path_factory):
    """Caches go to a temporary folder, never to the user's ~/.cache."""
    mp = pytest.MonkeyPatch()
    mp.setenv("SIGHTPLAN_CACHE", str(tmp_path_factory.mktemp("sightplan-cache")))
    yield
    mp.undo()


@pytest.fixture(scope="session")
def shared_data() -> Path:
    if not SHARED_DATA.is_dir():
        pytest.skip("../shared/data is not present")
    return SHARED_DATA


def shared_file(*parts: str) -> Path:
    path = SHARED_DATA.joinpath(*parts)
    if not path.exists():
        pytest.skip(f"{path} is not present")
    return path


@pytest.fixture(scope="session")
def duplex():
    """The bundled Duplex as a Scene, loaded once for every test that reads it (scenes are not changed in place)."""
    from sightplan.model.load import load_model

    scene, _ = load_model("sample")
    return scene
