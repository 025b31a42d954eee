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
