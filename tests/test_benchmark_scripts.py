"""The measuring functions of the benchmark scripts run on the Duplex (`make bench` runs them on real sizes).

A benchmark that breaks is found when it is run, often long after the change that broke it; these run its
per-frame measurement on a few small frames, so the suite finds it first.
"""

from __future__ import annotations

import sys
from pathlib import Path

import numpy as np
import pytest

from sightplan.engines import make_engine

BENCHMARKS = Path(__file__).resolve().parents[1] / "benchmarks"


@pytest.fixture(scope="module")
def scripts():
    sys.path.insert(0, str(BENCHMARKS))
    try:
        import features
        import speed
        from run import cell_plan

        yield speed, features, cell_plan
    finally:
        sys.path.remove(str(BENCHMARKS))


def test_speed_times_the_feature_test_inside_observe(duplex, scripts):
    """`speed.frames_case` wraps the engine's feature test to time it: the frames' features are those the engine
    finds without the wrapper, and the test's share of the frame lies between 0 and 1."""
    from sightplan.observations.features import sample_features

    speed, _, cell_plan = scripts
    plan = cell_plan(duplex, "drone", 4)
    with make_engine("embree", duplex, sample_features(duplex, 1.0, seed=1), threads=2) as engine:
        case = speed.frames_case(engine, plan, 0.25)
        assert "visible_features" not in vars(engine)  # the wrapper is gone again
        plain = [engine.observe(plan.camera_of(i), plan.R_world_camera[i], plan.C_world[i], 0.25).features
                 for i in range(len(plan))]
    assert case["frames"] == 4 and 0 < case["feature_share"] < 1 and 0 < case["feature_cpu_share"] < 1
    assert sum(len(f) for f in plain) > 100


def test_features_counts_the_rays_each_proof_leaves(duplex, scripts):
    """`features.frame_counts` on a Duplex frame: the rays left shrink from the candidates to the proofs without
    pixels and to those with them, and the set with the pixels is the reference's. `features.hidden_reasons` sorts
    the same rays: those it counts seen are the reference's set, and no seen feature's own first triangle proves it
    hidden (the proof is sound on Embree's own hits)."""
    from sightplan.observations.features import sample_features

    _, features, cell_plan = scripts
    plan = cell_plan(duplex, "drone", 2)
    with make_engine("embree", duplex, sample_features(duplex, 1.0, seed=1), threads=1) as engine:
        cam, R, C = plan.camera_of(0), plan.R_world_camera[0], plan.C_world[0]
        pixels = features.frame_pixels(engine, cam, R, C)
        row = features.frame_counts(engine, cam, R, C, pixels)
        reasons = features.hidden_reasons(engine, cam, R, C, pixels)
        reference = engine.visible_features_reference(cam, R, C)
        np.testing.assert_array_equal(engine.visible_features(cam, R, C, pixels=pixels), reference)
    assert row["blocks_kept"] > 0 and row["candidates"] >= row["rays_alone"] and row["candidates"] > row["rays"]
    assert reasons["rays"] == row["rays"] and reasons["seen"] == len(reference) > 0 and reasons["hidden"] > 0
    assert reasons["own_hit_seen"] == 0
    assert reasons["own_hit"] > 0  # the oracle proves some hidden features (counted among the hidden by construction)
