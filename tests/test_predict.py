"""The completeness predictor: the triangulation angles against geometry, the fit and its leave-one-out testing on
data with a known relation."""

from __future__ import annotations

import math

import numpy as np
import pytest

from sightplan.camera.models import PinholeCamera
from sightplan.engines.registry import available_engines
from sightplan.evaluate import EvaluationSettings, evaluate, scene_features
from sightplan.metrics import triangulation_angles
from sightplan.model.scene import ElementTable, Scene
from sightplan.observations.table import FrameObservation, Observations
from sightplan.plan.types import Plan
from sightplan.predict.columns import PREDICTOR_COLUMNS, at_photo_size, predictor_columns
from sightplan.predict.model import (
    FEATURES,
    CompletenessModel,
    calibration,
    feature_matrix,
    fit_completeness,
    group_weights,
    leave_one_out,
)


def looking_north() -> np.ndarray:
    """World-from-camera rotation of a level camera looking along +y (x right, y down in the image)."""
    return np.column_stack([[1.0, 0.0, 0.0], [0.0, 0.0, -1.0], [0.0, 1.0, 0.0]])


def wall_scene() -> Scene:
    """One wall, 4 m × 3 m in the plane y = 0, facing −y (towards the cameras)."""
    v = np.array([[-2.0, 0, 0], [2.0, 0, 0], [2.0, 0, 3.0], [-2.0, 0, 3.0]])
    f = np.array([[0, 1, 2], [0, 2, 3]])
    return Scene.from_arrays(v, f, np.zeros(2, int), ElementTable.build(["wall"]))


def angle(p, a, b) -> float:
    u, w = a - p, b - p
    return math.degrees(math.acos(np.clip(u @ w / np.linalg.norm(u) / np.linalg.norm(w), -1, 1)))


def test_two_frames_seeing_one_point_give_the_angle_between_their_rays():
    # a feature at the origin seen by cameras at (±1, −2, 0): 2·atan(1/2) = 53.13°
    frames = [FrameObservation(np.array([0], np.int32), np.array([100], np.int64), np.array([2.2]), np.array([26.0]),
                               np.array([0], np.int32), 1.0, 1000.0) for _ in range(2)]
    obs = Observations.from_frames(frames, np.array([True]), np.array([True]), 1)
    t = triangulation_angles(obs, [[-1.0, -2.0, 0.0], [1.0, -2.0, 0.0]], [[0.0, 0.0, 0.0]], [0])
    expected = math.degrees(2 * math.atan(0.5))
    assert t.largest_deg[0] == pytest.approx(expected, abs=1e-9)
    assert t.median_deg[0] == t.max_deg[0] == pytest.approx(expected, abs=1e-9)
    assert math.isnan(t.matchable_deg[0]) is False and t.matchable_deg[0] == 0.0  # 53° is beyond matching (40°)
    assert t.triangulable[0] == 0.0 and t.views[0] == 2 and t.seen_share[0] == 1.0
    near = triangulation_angles(obs, [[-0.2, -2.0, 0.0], [0.2, -2.0, 0.0]], [[0.0, 0.0, 0.0]], [0])
    assert near.matchable_deg[0] == pytest.approx(math.degrees(2 * math.atan(0.1)), abs=1e-9)
    assert near.triangulable[0] == 1.0
    one = triangulation_angles(Observations.from_frames(frames[:1], np.array([True]), np.array([True]), 1),
                               [[-1.0, -2.0, 0.0]], [[0.0, 0.0, 0.0]], [0])
    assert one.largest_deg[0] == 0.0 and one.triangulable[0] == 0.0


@pytest.mark.skipif("embree" not in available_engines(), reason="embree")
def test_two_cameras_looking_at_a_wall_see_it_at_the_geometric_angle():
    scene = wall_scene()
    cam = PinholeCamera(width=400, height=300, fx=200.0, fy=200.0, cx=200.0, cy=150.0, name="c")
    centres = np.array([[-1.5, -6.0, 1.5], [1.5, -6.0, 1.5]])
    plan = Plan.build(cam, np.stack([looking_north()] * 2), centres)
    settings = EvaluationSettings(engine="embree", scale=0.5, feature_density=4.0)
    ev = evaluate(scene, plan, settings, cache_dir=False)
    fs = scene_features(scene, settings, cache=False)
    t = triangulation_angles(ev.observations, plan.C_world, fs.points, fs.element)
    seen = np.unique(ev.observations.feature_id[np.bincount(ev.observations.feature_id,
                                                            minlength=len(fs)).take(ev.observations.feature_id) == 2])
    assert len(seen) > 20  # most of the wall is in both views
    per_feature = np.array([angle(fs.points[u], centres[0], centres[1]) for u in seen])
    assert t.max_deg[0] == pytest.approx(per_feature.max(), abs=1e-9)
    assert t.largest_deg[0] == pytest.approx(np.median(per_feature), abs=1e-9)
    # at the wall's centre the two rays meet at 2·atan(1.5/6) = 28.07°; the features lie around it
    assert t.largest_deg[0] == pytest.approx(math.degrees(2 * math.atan(1.5 / 6)), abs=1.5)
    cols = predictor_columns(ev.observations, plan.C_world, fs.points, fs.element, metrics=ev.metrics)
    assert set(cols) == set(PREDICTOR_COLUMNS) and cols["VR"][0] == 2 and cols["stable_views"][0] == 0.0
    # the same frames as photographs of 100 px (a = 100 / 120,000 of each 400×300 frame's pixels)
    small = at_photo_size(ev.observations, [cam.width * cam.height] * 2, 100.0)
    assert small.pixels.sum() == pytest.approx(ev.observations.pixels.sum() * 100 / 120_000)
    assert np.allclose(small.ssd, ev.observations.ssd * math.sqrt(1200))


# --------------------------------------------------------------------------- the fit
def synthetic(groups=("a", "b", "c", "d"), n=400, seed=0):
    """Columns whose completeness is σ(−2 + 1.5·log1p(VR) + 3·seen_share) plus binomial noise of 40 samples."""
    rng = np.random.default_rng(seed)
    rows = {k: [] for k in (*PREDICTOR_COLUMNS, "completeness", "group")}
    for g in groups:
        vr = rng.integers(0, 30, n).astype(float)
        seen = rng.uniform(0, 1, n)
        eta = -2 + 1.5 * np.log1p(vr) + 3 * seen
        p = 1 / (1 + np.exp(-eta))
        c = rng.binomial(40, p) / 40
        cols = {"VR": vr, "R": np.where(vr > 0, rng.uniform(5, 30, n), np.nan),
                "O": np.where(vr > 0, rng.uniform(0, 80, n), np.nan), "pixels": rng.uniform(0, 1e5, n),
                "seen_share": seen, "tri_median": rng.uniform(0, 60, n), "tri_largest": rng.uniform(0, 120, n),
                "tri_matchable": rng.uniform(0, 40, n), "triangulable": rng.uniform(0, 1, n),
                "views": rng.integers(1, 40, n).astype(float), "stable_views": rng.uniform(0, 1, n)}
        for k, v in cols.items():
            rows[k].append(v)
        rows["completeness"].append(c)
        rows["group"].append(np.full(n, g))
    return {k: np.concatenate(v) for k, v in rows.items()}


def test_the_fit_recovers_a_known_relation_and_is_calibrated_on_groups_it_did_not_see():
    d = synthetic()
    X = feature_matrix(d)
    m = fit_completeness(X, d["completeness"], ridge=1e-6)
    raw = dict(zip(FEATURES, m.coef / m.scale, strict=True))
    assert raw["log_VR"] == pytest.approx(1.5, abs=0.15)
    assert raw["seen_share"] == pytest.approx(3.0, abs=0.3)
    assert max(abs(raw[f]) for f in FEATURES if f not in ("log_VR", "seen_share", "visible")) < 0.3
    held, pred = leave_one_out(X, d["completeness"], d["group"], {"VR": d["VR"], "seen_share": d["seen_share"]})
    truth = 1 / (1 + np.exp(-(-2 + 1.5 * np.log1p(d["VR"]) + 3 * d["seen_share"])))
    assert np.abs(pred - truth).mean() < 0.01 and np.abs(pred - truth).max() < 0.07
    for h in held:
        assert h.calibration.slope == pytest.approx(1.0, abs=0.1)
        assert h.calibration.r > 0.85 and abs(h.calibration.bias) < 0.03
        assert h.best_single in ("VR", "seen_share") and h.calibration.r > abs(h.best_single_r)
        assert 0.8 <= h.coverage <= 0.97  # a 90 % interval from the other groups' residuals
    assert calibration(truth, truth).slope == pytest.approx(1.0)


def test_a_model_travels_through_json_with_its_intervals(tmp_path):
    d = synthetic(groups=("a", "b"), n=200)
    X = feature_matrix(d)
    m = fit_completeness(X, d["completeness"], weights=group_weights(d["group"]), info={"fitted_on": "synthetic"})
    m = m.with_intervals(m.predict(X), d["completeness"])
    back = CompletenessModel.read(m.write(tmp_path / "m.json"))
    assert np.allclose(back.predict(X), m.predict(X)) and back.info["fitted_on"] == "synthetic"
    p = back.predict(X)
    lo, hi = back.interval(p)
    assert ((0 <= lo) & (lo <= p) & (p <= hi) & (hi <= 1)).all()
    assert 0.85 <= ((d["completeness"] >= lo) & (d["completeness"] <= hi)).mean() <= 0.95
    assert np.allclose(group_weights(np.array(["a", "a", "b"])), [0.75, 0.75, 1.5])


# --------------------------------------------------------------------------- evaluate --predict-completeness
def test_evaluate_predicts_completeness_with_an_interval(tmp_path):
    import csv
    import json

    from test_cli import run_cli

    res = run_cli("evaluate", "sample", "--ring-frames", "6", "--scale", "0.05", "--no-picture",
                  "--predict-completeness", "--out", str(tmp_path / "r"), cwd=tmp_path)
    assert res.returncode == 0, res.stdout + res.stderr
    assert "predicted completeness" in res.stdout and "90 % interval" in res.stdout
    with open(tmp_path / "r" / "elements.csv", newline="") as fh:
        rows = [r for r in csv.DictReader(fh) if r["predicted_completeness"]]
    assert rows and all(r["visibility"] != "unseen" for r in rows)
    for r in rows:
        lo, p, hi = float(r["predicted_low"]), float(r["predicted_completeness"]), float(r["predicted_high"])
        assert 0 <= lo <= p <= hi <= 1
    doc = json.loads((tmp_path / "r" / "report.json").read_text())["completeness_prediction"]
    assert doc["elements_predicted"] == len(rows) == len(doc["elements"]) and doc["interval_level"] == 0.9
    assert all(0 <= e["low"] <= e["predicted"] <= e["high"] <= 1 for e in doc["elements"])
