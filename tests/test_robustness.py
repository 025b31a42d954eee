"""Metrics under pose error (``sightplan.robustness``): draws of perturbed plans against closed-form geometry.

The scenes are walls facing a camera that looks north at known distances, so what a frame sees after a shift is
known exactly: a wall parallel to the image plane moves in the image by f·δ/D pixels. Expected numbers come from
the normal and binomial laws (scipy), never from sightplan's own helpers, with tolerances of at least four
standard deviations of the Monte-Carlo estimate at the number of draws used.
"""

from __future__ import annotations

import json
import math

import numpy as np
import pytest
from scipy.stats import binom, norm

from sightplan.camera.models import PinholeCamera
from sightplan.engines.registry import available_engines
from sightplan.errors import PlanError, SightplanError
from sightplan.evaluate import EvaluationSettings
from sightplan.metrics import MetricParams
from sightplan.model.scene import ElementTable, Scene
from sightplan.observations.table import FrameObservation, Observations
from sightplan.plan.perturb import PoseError, perturbed_poses
from sightplan.plan.types import Plan
from sightplan.robustness import draw_picks, evaluate_under_error

pytestmark = pytest.mark.skipif("embree" not in available_engines(), reason="the draws are cast with embree")

# Looking north (+Y), image right = +X, image down = −Z (columns: the camera's axes in world coordinates).
R_NORTH = np.array([[1.0, 0.0, 0.0], [0.0, 0.0, 1.0], [0.0, -1.0, 0.0]])
# 200 × 100 px, f = 100 px: at 10 m a pixel is 0.1 m, the image spans x ∈ [−10, 10], z ∈ [−5, 5] about the camera.
CAM = PinholeCamera(200, 100, 100.0, 100.0, 100.0, 50.0, name="test")
SETTINGS = EvaluationSettings(engine="embree")


def wall_scene(walls: list[tuple[float, float, float, float, float]]) -> Scene:
    """Walls (y, x0, x1, z0, z1) in planes y = const, element i for the i-th, two triangles each."""
    vs, fs = [], []
    for i, (y, x0, x1, z0, z1) in enumerate(walls):
        vs.append([[x0, y, z0], [x1, y, z0], [x1, y, z1], [x0, y, z1]])
        fs.append(np.array([[0, 1, 2], [0, 2, 3]]) + 4 * i)
    elements = ElementTable.build([f"W{i}" for i in range(len(walls))])
    return Scene.from_arrays(np.array(vs, float).reshape(-1, 3), np.concatenate(fs), np.repeat(np.arange(len(walls)), 2),
                             elements)


def frames_at(C) -> Plan:
    C = np.asarray(C, float).reshape(-1, 3)
    return Plan.build(CAM, np.repeat(R_NORTH[None], len(C), axis=0), C)


# ------------------------------------------------------------------------------------------- the error's meaning
def test_pose_error_parses_presets_numbers_and_heading():
    assert PoseError.parse("gnss") == PoseError(1.5, 0.5, 0.0)
    assert PoseError.parse("RTK") == PoseError(0.1, 0.1, 0.0)
    assert PoseError.parse("gnss,3") == PoseError(1.5, 0.5, 3.0)
    assert PoseError.parse("2,1") == PoseError(2.0, 1.0, 0.0)
    assert PoseError.parse(" 2 , 1 , 5 ") == PoseError(2.0, 1.0, 5.0)
    assert PoseError.parse((0.3, 0.2)) == PoseError(0.3, 0.2)
    assert PoseError.parse("none").zero
    for bad in ("-1,0.5", "1,-0.5", "nan,1", "1,inf", "1,1,nan", "1,1,-2", "1,1,181", "1", "1,2,3,4", "gnss,1,2",
                "fast", "1,x"):
        with pytest.raises(PlanError):
            PoseError.parse(bad)


def test_bounds_hold_95_percent_of_the_draws():
    """H: 95 % of positions within H horizontally (a radius); V: 95 % within ±V; YAW: 95 % within ±YAW."""
    plan = frames_at([[3.0, -2.0, 1.0]])
    err = PoseError(2.0, 0.5, 4.0)
    k = 40_000  # a share of 0.95 is estimated to ±0.0011 (1 sd)
    C, R = perturbed_poses(plan, err, k, np.random.default_rng(7))
    d = C[:, 0] - plan.C_world[0]
    assert abs(np.mean(np.hypot(d[:, 0], d[:, 1]) <= 2.0) - 0.95) < 0.005
    assert abs(np.mean(np.abs(d[:, 2]) <= 0.5) - 0.95) < 0.005
    # the heading error turns the camera about the vertical: R' = Rz(ψ)·R
    turn = np.einsum("sij,kj->sik", R[:, 0], plan.R_world_camera[0])
    np.testing.assert_allclose(turn[:, 2], np.broadcast_to([0, 0, 1], (k, 3)), atol=1e-12)
    psi = np.degrees(np.arctan2(turn[:, 1, 0], turn[:, 0, 0]))
    assert abs(np.mean(np.abs(psi) <= 4.0) - 0.95) < 0.005
    assert abs(np.std(psi) - 4.0 / norm.ppf(0.975)) < 0.05


def test_draw_picks_share_the_pool_evenly_and_independently():
    picks = draw_picks(64, 16, 50, np.random.default_rng(3))
    assert picks.shape == (64, 50) and picks.min() == 0 and picks.max() == 15
    for f in range(50):  # each frame uses each of its 16 samples in 4 draws
        assert np.array_equal(np.bincount(picks[:, f], minlength=16), np.full(16, 4))
    assert len({tuple(p) for p in picks}) == 64  # no two draws alike
    same = draw_picks(10, 10, 5, np.random.default_rng(3))
    assert all(sorted(same[:, f]) == list(range(10)) for f in range(5))


# -------------------------------------------------------------------------------------- metrics from the engine
def test_zero_error_gives_the_nominal_metrics_in_every_draw():
    scene = wall_scene([(10.0, -6.0, 6.0, -3.0, 3.0), (14.0, -9.0, 9.0, -4.0, 4.0)])
    plan = frames_at([[x, 0.0, 0.5] for x in np.linspace(-3, 3, 7)])
    settings = EvaluationSettings(engine="embree", metric=MetricParams(min_track=3, min_features=5))
    r = evaluate_under_error(scene, plan, settings, "none", 3, seed=5, pool=2, cache_dir=False, safety_distance_m=2)
    nominal = r.nominal.metrics.plan
    assert nominal.n_visible == 2 and nominal.T > 0  # something to compare
    assert all(m == nominal for m in r.draw_metrics)  # every field, exactly
    for name, s in r.summary.plan.items():
        assert s.mean == s.p5 == s.p95 == s.nominal, name
    np.testing.assert_array_equal(r.summary.elements.VR_p95, r.nominal.metrics.elements.VR)
    assert r.safety.draw_share == 0 and r.safety.least_m.min() == r.safety.nominal_least_m


def band_scene(t: float) -> Scene:
    """Element 0: a wall always fully in view (70 × 60 px). Element 1: a 70 px wide band that reaches above the
    image, its bottom at z0 = 4.15 + t. With the camera δ metres up, the pixel rows whose centre ray
    z = δ + 5 − 0.1·(v + ½) falls on the band number ⌊(δ + 5 − z0)/0.1 − ½⌋ + 1, and 9 rows (630 px) are the first
    to reach Ω = 625: the band is visible exactly when δ ≥ t."""
    return wall_scene([(10.0, -8.0, -1.0, -3.0, 3.0), (10.0, 1.0, 8.0, 4.15 + t, 9.15 + t)])


@pytest.mark.bench  # make bench; the horizontal error's law stays in make test
def test_vertical_error_gives_the_binomial_law_of_vr():
    """Four frames at one point, vertical error σ_v = 0.5 m (V = 0.98 m), threshold t = 0.25 m: each frame sees the
    band with p = 1 − Φ(t/σ_v) = 0.309, independently, so VR_1 ~ Binomial(4, p); VC = ½ or 1."""
    sigma, t, n, draws = 0.5, 0.25, 4, 1500
    p = 1 - norm.cdf(t / sigma)
    r = evaluate_under_error(band_scene(t), frames_at(np.zeros((n, 3))), SETTINGS, (0.0, sigma * norm.ppf(0.975)),
                             draws, seed=11, pool=draws, cache_dir=False, safety_distance_m=1)
    # as planned (δ = 0): the band shows 6 rows (420 px), observed but not visible
    assert r.nominal.metrics.plan.VC == 0.5 and r.nominal.metrics.plan.VR == 4.0
    assert r.nominal.metrics.elements.VR.tolist() == [4, 0]
    es = r.summary.elements
    assert es.VR_mean[0] == es.VR_p5[0] == es.VR_p95[0] == 4  # the big wall never leaves the view
    k = np.arange(n + 1)
    pmf = binom.pmf(k, n, p)
    sd = math.sqrt(n * p * (1 - p) / draws)
    assert abs(es.VR_mean[1] - n * p) < 4 * sd
    # Binomial(4, 0.309): P(≤ 0) = 0.229, P(≤ 2) = 0.910, P(≤ 3) = 0.991, so p5 = 0 and p95 = 3
    assert (es.VR_p5[1], es.VR_p95[1]) == (binom.ppf(0.05, n, p), binom.ppf(0.95, n, p)) == (0, 3)
    unseen = pmf[0]
    assert abs(es.visible_share[1] - (1 - unseen)) < 4 * math.sqrt(unseen * (1 - unseen) / draws)
    vc = r.summary.plan["VC"]
    assert (vc.nominal, vc.p5, vc.p95) == (0.5, 0.5, 1.0)
    assert abs(vc.mean - (1 - unseen / 2)) < 4 * 0.5 * math.sqrt(unseen * (1 - unseen) / draws)
    # VR = (4 + k)/(1 + [k > 0]): 4, 2.5, 3, 3.5, 4 for k = 0..4
    vr_of_k = np.array([4.0, 2.5, 3.0, 3.5, 4.0])
    mean = float(pmf @ vr_of_k)
    sd_vr = math.sqrt(float(pmf @ (vr_of_k - mean) ** 2) / draws)
    vr = r.summary.plan["VR"]
    assert abs(vr.mean - mean) < 4 * sd_vr
    assert (vr.p5, vr.p95) == (2.5, 4.0)  # P(VR = 2.5) = 0.41, P(VR = 4) = 0.24
    assert r.summary.plan["n_visible"].p5 == 1 and r.summary.plan["n_visible"].p95 == 2


def test_pooled_draws_keep_each_draws_law():
    """With 60 poses per frame shared by 1500 draws, each draw still sees the band in Binomial(4, p) frames: the
    mean over the draws is that of the 240 cast frames, a sample of the same p."""
    sigma, t, n, draws, pool = 0.5, 0.25, 4, 1500, 60
    p = 1 - norm.cdf(t / sigma)
    r = evaluate_under_error(band_scene(t), frames_at(np.zeros((n, 3))), SETTINGS, (0.0, sigma * norm.ppf(0.975)),
                             draws, seed=12, pool=pool, cache_dir=False, safety_distance_m=1)
    assert r.pool == pool and r.timings["frames_cast"] == n * pool
    es = r.summary.elements
    assert abs(es.VR_mean[1] - n * p) < 4 * n * math.sqrt(p * (1 - p) / (n * pool))
    assert (es.VR_p5[1], es.VR_p95[1]) == (0, 3)
    vc = r.summary.plan["VC"]
    assert (vc.p5, vc.p95) == (0.5, 1.0)


def test_horizontal_error_and_the_safety_distance():
    """A 100 m wall 10 m ahead fills the view whatever the error (VC = 1, VR = n in every draw); a frame comes
    within 9 m of it when it moves more than 1 m north: with σ_h = 1 m (H = 2.45 m) that is q = 1 − Φ(1) per frame."""
    n, draws = 3, 800
    scene = wall_scene([(10.0, -50.0, 50.0, -50.0, 50.0)])
    no_surface_features = EvaluationSettings(engine="embree", feature_density=0)  # 10,000 m²: corners only
    r = evaluate_under_error(scene, frames_at(np.zeros((n, 3))), no_surface_features, (math.sqrt(-2 * math.log(0.05)), 0.0),
                             draws, seed=13, pool=draws, cache_dir=False, safety_distance_m=9.0)
    for name in ("VC", "VR"):
        s = r.summary.plan[name]
        assert s.nominal == s.p5 == s.p95 == s.mean == (1.0 if name == "VC" else n)
    q = 1 - norm.cdf(1.0)
    any_close = 1 - (1 - q) ** n
    assert abs(r.safety.draw_share - any_close) < 4 * math.sqrt(any_close * (1 - any_close) / draws)
    assert abs(r.safety.frame_share - q) < 4 * math.sqrt(q * (1 - q) / (draws * n))
    assert r.safety.nominal_least_m == pytest.approx(10.0)
    # the sampling distance R = d̄/f changes with the distance: it spreads both ways
    R = r.summary.plan["R"]
    assert R.p5 < R.nominal < R.p95


def test_a_seed_reproduces_its_draws():
    scene = band_scene(0.25)
    plan = frames_at(np.zeros((4, 3)))
    run = lambda seed: evaluate_under_error(scene, plan, SETTINGS, "1,1,5", 24, seed=seed, pool=8,  # noqa: E731
                                            cache_dir=False, safety_distance_m=9.5)
    a, b, c = run(4), run(4), run(5)
    assert a.draw_metrics == b.draw_metrics
    np.testing.assert_array_equal(a.safety.least_m, b.safety.least_m)
    assert not np.array_equal(a.safety.least_m, c.safety.least_m)


def test_bad_draws_are_refused():
    scene = band_scene(0.25)
    plan = frames_at(np.zeros((1, 3)))
    for kwargs in ({"draws": 0}, {"draws": 4, "pool": 5}, {"draws": 4, "pool": 0}, {"seed": -1}):
        with pytest.raises(SightplanError):
            evaluate_under_error(scene, plan, SETTINGS, "gnss", **{"draws": 4, **kwargs})


def test_take_frames_equals_select_frames():
    rng = np.random.default_rng(0)
    frames = []
    for _ in range(9):
        e = np.sort(rng.choice(6, size=rng.integers(0, 5), replace=False)).astype(np.int32)
        frames.append(FrameObservation(e, rng.integers(1, 900, len(e)), rng.random(len(e)) * 20, rng.random(len(e)) * 90,
                                       np.sort(rng.choice(30, size=rng.integers(0, 8), replace=False)).astype(np.int32),
                                       float(rng.integers(1, 4)), 1000.0 + rng.random()))
    obs = Observations.from_frames(frames, np.ones(6, bool), np.ones(6, bool), 30)
    for index in ([], [3], [8, 0, 0, 5, 2], list(range(9))[::-1]):
        a, b = obs.take_frames(np.array(index, int)), obs.select_frames(np.array(index, int))
        for name in ("n_frames", "n_features"):
            assert getattr(a, name) == getattr(b, name)
        for name in Observations._ARRAYS:
            np.testing.assert_array_equal(getattr(a, name), getattr(b, name), err_msg=name)


# ------------------------------------------------------------------------------------------------ command line
def test_cli_evaluates_draws_and_writes_their_files(tmp_path):
    from test_cli import run_cli

    res = run_cli("evaluate", "sample", "--camera", "p4p", "--ring-frames", "6", "--scale", "0.05", "--no-picture",
                  "--position-error", "gnss,2", "--draws", "4", "--pool", "2", "--out", "out", cwd=tmp_path)
    assert res.returncode == 0, res.stderr
    assert "under position error ±1.5 m / ±0.5 m, heading ±2°" in res.stdout
    assert "4 draws (sharing 2 poses per frame)" in res.stdout
    doc = json.loads((tmp_path / "out" / "robustness.json").read_text())
    assert doc["draws"] == 4 and doc["pool"] == 2 and doc["seed"] == 0 and doc["frames"] == 6
    assert doc["error"]["vertical_m"] == 0.5 and doc["error"]["yaw_deg"] == 2.0
    report = json.loads((tmp_path / "out" / "report.json").read_text())
    assert doc["metrics"]["VC_pct"]["nominal"] == pytest.approx(report["metrics"]["VC_pct"])
    assert doc["safety"]["minimum_m"] == 5.0  # a ring records no checks: `sightplan check`'s default
    elements = (tmp_path / "out" / "robustness_elements.csv").read_text().splitlines()
    assert elements[0].startswith("index,global_id,name,ifc_class,VR_i,VR_i_mean,VR_i_p5,VR_i_p95")
    assert len(elements) - 1 == report["metrics"]["z"]
    draws_csv = (tmp_path / "out" / "robustness_draws.csv").read_text().splitlines()
    assert len(draws_csv) == 5 and draws_csv[0].startswith("draw,visible,VC_pct")


@pytest.mark.parametrize("args, words", [
    (["--position-error", "-1,0.5"], ["position error", "0 to 100"]),
    (["--position-error", "nan,0.5"], ["position error"]),
    (["--position-error", "1,0.5,nan"], ["heading error"]),
    (["--position-error", "fast"], ["H,V"]),
    (["--position-error", "gnss", "--draws", "0"], ["--draws", "1 to"]),
    (["--position-error", "gnss", "--draws", "8", "--pool", "9"], ["--pool", "pool"]),
    (["--position-error", "gnss", "--draw-seed", "-2"], ["--draw-seed"]),
    (["--draws", "8"], ["--draws", "--position-error"]),
])
def test_cli_refuses_bad_draw_options(tmp_path, args, words):
    from test_cli import assert_clean_error, run_cli

    assert_clean_error(run_cli("evaluate", "sample", *args, "--out", "out", cwd=tmp_path), *words)
