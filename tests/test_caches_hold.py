"""Caches that hold: a cached load keeps its tie pairs, a fully cached plan builds no engine, ``--no-cache`` reads and
writes nothing, and every cache lives in its own folder under one root."""

from __future__ import annotations

import sys

import numpy as np
import pytest
import trimesh

from sightplan.camera.models import PinholeCamera
from sightplan.evaluate import EvaluationSettings, evaluate
from sightplan.model.load import load_model
from sightplan.plan.ring import ring_plan
from test_cli import run_cli

CAMERA = PinholeCamera(64, 48, 60.0, 60.0, 32.0, 24.0, "small")


def two_boxes(path):
    """A 4 m block with a 1 m box standing flush on its top: two objects, a few tied faces."""
    scene = trimesh.Scene()
    block = trimesh.creation.box((4.0, 4.0, 2.0))
    block.apply_translation((0, 0, 1.0))
    small = trimesh.creation.box((1.0, 1.0, 1.0))
    small.apply_translation((0, 0, 2.5))
    scene.add_geometry(block, geom_name="block")
    scene.add_geometry(small, geom_name="small")
    scene.export(path)
    return path


def test_a_cached_load_carries_its_tie_pairs(duplex):
    scene, report = load_model("sample")  # the session's cache holds it since the duplex fixture
    assert report.from_cache and scene.has_tie_pairs()
    assert np.array_equal(scene.tie_pairs(), duplex.tie_pairs()) and len(scene.tie_pairs()) > 0


def test_a_cached_load_reports_its_own_peak_memory(tmp_path, monkeypatch):
    path = two_boxes(tmp_path / "boxes.glb")
    _, cold = load_model(path, cache_dir=tmp_path / "c")
    monkeypatch.setattr("sightplan.model.load.peak_rss_mb", lambda: 12345.0)
    _, hit = load_model(path, cache_dir=tmp_path / "c")
    assert cold.peak_rss_mb > 0 and hit.from_cache and hit.peak_rss_mb == 12345.0


def test_bounds_are_computed_once(duplex):
    from dataclasses import replace

    scene = replace(duplex)
    first = scene.bounds()
    used = scene.vertices[np.unique(scene.faces)]
    assert np.array_equal(first, np.stack([used.min(0), used.max(0)]))
    first[:] = 0  # a copy: the scene's own stays as it was
    assert "_bounds" in scene.__dict__ and np.array_equal(scene.bounds(), np.stack([used.min(0), used.max(0)]))


def test_a_fully_cached_plan_builds_no_engine(tmp_path, monkeypatch):
    scene, _ = load_model(two_boxes(tmp_path / "boxes.glb"), cache=False)
    plan = ring_plan(scene, CAMERA, n_frames=4, distance_m=5.0)
    settings = EvaluationSettings(engine="embree", feature_density=5.0)
    built = []
    ev_module = sys.modules["sightplan.evaluate"]  # the module (the package exports a function of that name)
    real = ev_module.make_engine
    monkeypatch.setattr(ev_module, "make_engine", lambda *a, **k: built.append(1) or real(*a, **k))
    first = evaluate(scene, plan, settings, cache_dir=tmp_path / "frames")
    assert first.timings["frames_cast"] == 4 and len(built) == 1

    def refuse(*args, **kwargs):
        raise AssertionError("an engine was built for a fully cached plan")

    monkeypatch.setattr(ev_module, "make_engine", refuse)
    stages = []
    again = evaluate(scene, plan, settings, cache_dir=tmp_path / "frames", stages=lambda *s: stages.append(s))
    assert again.timings["frames_cast"] == 0 and again.cache_hits == 4
    assert again.metrics.plan.to_dict() == first.metrics.plan.to_dict() and again.engine == "embree"
    assert ("frames", 4, 4) in stages and not any(s[0] == "engine" for s in stages)
    moved = plan.subset(np.arange(3))  # a plan of cached frames only, in another order: still no engine
    assert evaluate(scene, moved, settings, cache_dir=tmp_path / "frames").timings["frames_cast"] == 0


@pytest.mark.parametrize("command", ["evaluate", "info"])
def test_no_cache_reads_and_writes_nothing(tmp_path, monkeypatch, command):
    root = tmp_path / "cache"
    root.mkdir()
    monkeypatch.setenv("SIGHTPLAN_CACHE", str(root))
    model = two_boxes(tmp_path / "boxes.glb")
    args = ("--ring-frames", "3", "--scale", "0.05", "--no-picture", "--out", str(tmp_path / "out")) \
        if command == "evaluate" else ()
    res = run_cli(command, str(model), "--no-cache", *args, cwd=tmp_path)
    assert res.returncode == 0, res.stderr
    assert list(root.rglob("*")) == []
    res = run_cli(command, str(model), *args, cwd=tmp_path)  # with the caches: each in its own folder
    assert res.returncode == 0, res.stderr
    expected = {"scenes", "features", "frames"} if command == "evaluate" else {"scenes"}
    assert {p.name for p in root.iterdir()} == expected


def _spy_engines(monkeypatch, built: list) -> None:
    """Count every engine built, by the evaluation or for a picture."""
    from sightplan.engines import registry

    for module in (sys.modules["sightplan.evaluate"], registry):
        real = module.make_engine
        monkeypatch.setattr(module, "make_engine", lambda *a, _real=real, **k: built.append(1) or _real(*a, **k))


def test_a_second_evaluate_draws_its_pictures_without_an_engine(tmp_path, monkeypatch):
    """With the pictures on, a fully cached re-evaluation builds no engine, and writes the same pictures."""
    monkeypatch.setenv("SIGHTPLAN_CACHE", str(tmp_path / "cache"))
    model = two_boxes(tmp_path / "boxes.glb")
    built: list = []
    _spy_engines(monkeypatch, built)
    args = ("evaluate", str(model), "--ring-frames", "3", "--scale", "0.05", "--engine", "embree")
    res = run_cli(*args, "--out", str(tmp_path / "first"), cwd=tmp_path)
    assert res.returncode == 0, res.stderr
    assert len(built) == 2  # the evaluation's engine and the overview's
    res = run_cli(*args, "--out", str(tmp_path / "again"), cwd=tmp_path)
    assert res.returncode == 0, res.stderr
    assert len(built) == 2, "a fully cached evaluate built an engine"
    first, again = (tmp_path / "first" / "overview.png").read_bytes(), (tmp_path / "again" / "overview.png").read_bytes()
    assert len(first) > 1000 and first == again


def test_the_views_of_the_storey_cutaways_are_cached_too(duplex, tmp_path, monkeypatch):
    """The sample's overview and storey cutaways: cast once (an engine each), then read back as cast; a plan that
    frames the overview otherwise casts only a new overview."""
    from sightplan.engines.views import picture_views

    built: list = []
    _spy_engines(monkeypatch, built)
    centres = np.array([[30.0, -20.0, 10.0]])
    view, storeys, hits = picture_views(duplex, centres, "embree", cache_dir=tmp_path)
    assert hits == 0 and len(built) == 1 + len(storeys) and len(storeys) >= 2
    again, storeys_again, hits = picture_views(duplex, centres, "embree", cache_dir=tmp_path)
    assert hits == 2 and len(built) == 1 + len(storeys)
    for a, b in [(view, again), *((s[1], t[1]) for s, t in zip(storeys, storeys_again, strict=True))]:
        assert np.array_equal(a.element, b.element) and np.array_equal(a.shade, b.shade) and a.camera == b.camera
        assert np.array_equal(a.R_world_camera, b.R_world_camera) and np.array_equal(a.C_world, b.C_world)
    assert [s[0] for s in storeys] == [s[0] for s in storeys_again]
    moved = picture_views(duplex, centres + 50.0, "embree", cache_dir=tmp_path)  # another framing: a new overview
    assert moved[2] == 1 and len(built) == 2 + len(storeys) and moved[1][0][0] == storeys[0][0]
    assert not np.array_equal(moved[0].C_world, view.C_world)
