"""Scene cache: a second load is a hit with identical arrays; corrupt entries are rebuilt."""

from __future__ import annotations

import json
import time

import numpy as np
import pytest
import trimesh

from sightplan.model import load_model, sample_model_path
from sightplan.model.cache import content_hash, default_cache_dir, load_scene


def _assert_same(a, b) -> None:
    np.testing.assert_array_equal(a.vertices, b.vertices)
    np.testing.assert_array_equal(a.faces, b.faces)
    np.testing.assert_array_equal(a.face_element, b.face_element)
    for col in ("global_id", "name", "ifc_class", "discipline", "storey", "is_target"):
        np.testing.assert_array_equal(getattr(a.elements, col), getattr(b.elements, col))
    np.testing.assert_array_equal(np.isnat(a.elements.finish), np.isnat(b.elements.finish))
    assert a.content_hash == b.content_hash and a.key == b.key
    assert a.metadata == b.metadata


def test_duplex_cache_hit_is_identical_and_fast(tmp_path):
    t0 = time.perf_counter()
    first, r1 = load_model("sample", cache_dir=tmp_path)
    cold = time.perf_counter() - t0
    t0 = time.perf_counter()
    second, r2 = load_model("sample", cache_dir=tmp_path)
    warm = time.perf_counter() - t0
    assert not r1.from_cache and r2.from_cache
    _assert_same(first, second)
    assert r2.skipped == r1.skipped and r2.excluded == r1.excluded and r2.containers == r1.containers
    assert r2.n_triangles == r1.n_triangles
    assert warm < 0.5 and warm < cold / 4, (cold, warm)
    assert len(list(tmp_path.glob("*.npz"))) == 1
    print(f"duplex cold {cold:.2f} s, cache hit {warm * 1000:.0f} ms")


def test_other_options_other_entry(tmp_path):
    path = tmp_path / "boxes.ply"
    trimesh.creation.box((1, 2, 3)).export(path)
    objects, r1 = load_model(path, cache_dir=tmp_path / "c")
    faces, r2 = load_model(path, cache_dir=tmp_path / "c", elements="faces")
    assert not r2.from_cache and objects.n_elements == 1 and faces.n_elements == 12
    assert len(list((tmp_path / "c").glob("*.npz"))) == 2
    again, r3 = load_model(path, cache_dir=tmp_path / "c", elements="faces")
    assert r3.from_cache and again.n_elements == 12


@pytest.mark.parametrize("damage", ["truncate", "garbage", "json", "missing_json"])
def test_corrupt_entry_is_rebuilt(tmp_path, damage):
    path = tmp_path / "box.obj"
    trimesh.creation.box((1, 2, 3)).export(path)
    cache = tmp_path / "cache"
    good, _ = load_model(path, cache_dir=cache)
    [npz] = cache.glob("*.npz")
    js = npz.with_suffix(".json")
    if damage == "truncate":
        npz.write_bytes(npz.read_bytes()[:100])
    elif damage == "garbage":
        npz.write_bytes(b"not a zip at all")
    elif damage == "json":
        js.write_text("{")
    else:
        js.unlink()
    assert load_scene(good.content_hash, cache) is None
    rebuilt, report = load_model(path, cache_dir=cache)
    assert not report.from_cache
    _assert_same(good, rebuilt)
    again, report = load_model(path, cache_dir=cache)  # the entry was rewritten
    assert report.from_cache
    _assert_same(good, again)


def test_key_is_file_bytes_plus_options(tmp_path):
    a = tmp_path / "a.ifc"
    a.write_bytes(sample_model_path().read_bytes())
    opts = {"loader": "ifc", "occluders": ["IfcSite"]}
    assert content_hash(a, opts) == content_hash(sample_model_path(), opts)
    assert content_hash(a, opts) != content_hash(a, {**opts, "occluders": []})
    a.write_bytes(a.read_bytes() + b"\n")
    assert content_hash(a, opts) != content_hash(sample_model_path(), opts)
    json.dumps(opts)


def test_default_cache_dir(monkeypatch, tmp_path):
    """One layout whatever the environment says: scenes, features and frames each in a folder under the root."""
    from sightplan.observations.cache import default_cache_dir as frames_dir

    monkeypatch.setenv("SIGHTPLAN_CACHE", str(tmp_path / "c"))
    assert default_cache_dir() == tmp_path / "c" / "scenes" and frames_dir() == tmp_path / "c" / "frames"
    monkeypatch.delenv("SIGHTPLAN_CACHE")
    assert default_cache_dir().parts[-3:] == (".cache", "sightplan", "scenes")


def test_cache_hit_reports_the_path_it_was_asked_for(tmp_path):
    import shutil

    from sightplan.model.load import load_model, sample_model_path

    copy = tmp_path / "my-house.ifc"
    shutil.copy(sample_model_path(), copy)
    load_model("sample", cache_dir=tmp_path / "c")
    scene, report = load_model(copy, cache_dir=tmp_path / "c")
    assert report.from_cache
    assert scene.source == str(copy) and report.source == str(copy)
