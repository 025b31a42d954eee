"""Embree and the independent trimesh ray tracer agree frame by frame on a real model.

Where surfaces of two elements coincide, either may own a pixel (METRICS.md §2), so a
pixel agrees when both engines name the same element or hit within 1 mm of each other.
"""

from __future__ import annotations

import numpy as np
import pytest

from sightplan.camera.models import EquirectangularCamera, PinholeCamera
from sightplan.engines import make_engine
from sightplan.evaluate import EvaluationSettings, evaluate, pixel_counts
from sightplan.geometry.poses import R_from_gimbal
from sightplan.metrics import MetricParams
from sightplan.model.load import load_model
from sightplan.observations.features import FeatureSet, sample_features
from sightplan.plan.ring import ring_plan
from sightplan.plan.types import Plan

COINCIDENT_M = 0.001


@pytest.fixture(scope="module")
def duplex():
    """The Duplex without its most detailed elements (stairs, railings, furniture), so the
    pure-numpy tracer stays fast; walls, slabs, roof, doors and windows remain."""
    scene, _ = load_model("sample")
    per_element = np.bincount(scene.face_element, minlength=scene.n_elements)
    return scene.with_present(per_element <= 200)


@pytest.fixture(scope="module")
def engines(duplex):
    with make_engine("embree", duplex) as a, make_engine("trimesh", duplex) as b:
        yield a, b


@pytest.fixture(scope="module")
def small_plan(duplex) -> Plan:
    return ring_plan(duplex, PinholeCamera(48, 36, 45, 45, 24, 18, "tiny"), n_frames=3, distance_m=4)


def agreement(a, b, *args) -> tuple[float, float, np.ndarray, np.ndarray]:
    ids_a, t_a = a.element_map(*args)
    ids_b, t_b = b.element_map(*args)
    with np.errstate(invalid="ignore"):  # inf − inf where both miss: those pixels agree by id (−1)
        same = (ids_a == ids_b) | (np.abs(t_a - t_b) < COINCIDENT_M)
    return same.mean(), (ids_a >= 0).mean(), t_a, t_b


@pytest.mark.bench  # pixel by pixel (10 s); test_metrics_agree_between_engines stays in make test
def test_pinhole_element_maps_agree_on_the_duplex(engines, small_plan):
    a, b = engines
    for i in range(len(small_plan)):
        share, hit, t_a, t_b = agreement(a, b, small_plan.camera_of(i), small_plan.R_world_camera[i], small_plan.C_world[i])
        assert hit > 0.2  # the frame really looks at the building
        assert share >= 0.995
        both = np.isfinite(t_a) & np.isfinite(t_b)
        assert np.mean(np.abs(t_a[both] - t_b[both]) < 1e-4) >= 0.995


def test_equirectangular_element_maps_agree_inside_the_house(engines, duplex):
    a, b = engines
    lo, hi = duplex.bounds()
    share, hit, _, _ = agreement(a, b, EquirectangularCamera(64, 32, "pano"), R_from_gimbal(30, 0)[0], (lo + hi) / 2)
    assert hit > 0.9  # inside the house almost every ray hits something
    assert share >= 0.995


@pytest.mark.bench  # make bench; the OpenGL engine's 72-frame metrics against Embree stay in make test
def test_metrics_agree_between_engines(duplex, small_plan):
    fs = sample_features(duplex, 0.2, seed=3)
    every = slice(None, None, 8)  # a fixed eighth of the features keeps the numpy tracer quick
    features = FeatureSet(fs.points[every], fs.normals[every], fs.kind[every], fs.element[every], fs.params)
    params = MetricParams(omega=12, min_track=2, min_features=5)  # 48×36 px, 3 frames: Ω and Y scaled down
    ev = {name: evaluate(duplex, small_plan, EvaluationSettings(engine=name, metric=params), features=features,
                         cache_dir=False)
          for name in ("embree", "trimesh")}
    pa, pb = (pixel_counts(e.observations) for e in ev.values())
    assert pa.sum() > 0.2 * small_plan.camera_of(0).width * small_plan.camera_of(0).height * len(small_plan)
    assert np.abs(pa - pb).sum() <= 0.005 * pa.sum()
    a, b = ev["embree"].metrics.plan, ev["trimesh"].metrics.plan
    assert a.n_visible > 10 and a.T > 0
    for k in ("VC", "VC_bar", "VR", "R", "O", "T"):
        assert getattr(b, k) == pytest.approx(getattr(a, k), rel=0.005), k


def test_storey_cutaways_show_each_storey_from_above():
    from sightplan.engines.views import storey_views

    scene, _ = load_model("sample")
    views = storey_views(scene, "embree")
    assert [name for name, _ in views] == ["T/FDN", "Level 1", "Level 2", "Roof"]  # lowest floor first
    for name, view in views:
        shown = np.unique(view.element[view.element >= 0])
        assert (scene.elements.storey[shown] == name).any(), name
        assert view.R_world_camera[2, 2] < -0.8  # looking down
    level1 = dict(views)["Level 1"]
    upper = scene.elements.storey[np.unique(level1.element[level1.element >= 0])]
    assert "Level 2" not in set(upper) and "Roof" not in set(upper)  # what is above the cut is gone
