"""The closed loop's per-element study on data generated here: its correlations are scipy's on the same pairs,
its logistic fit recovers the coefficients the data were drawn with, and its frame counts are counted again here."""

from __future__ import annotations

import csv
import json
from dataclasses import replace
from pathlib import Path

import numpy as np
import pytest
from scipy.stats import pearsonr, spearmanr

from sightplan.evaluate import Evaluation
from sightplan.loop.measure import ReconstructionMeasures
from sightplan.loop.study import (
    PREDICTORS,
    LoopStudyError,
    fit_logistic,
    frame_study,
    loop_study,
)
from sightplan.metrics import ElementMetrics, Metrics

TABLE2 = Path(__file__).resolve().parents[2] / "shared" / "spec" / "table2.csv"


def sigmoid(x):
    return 1.0 / (1.0 + np.exp(-x))


def generated(z: int = 400, n_frames: int = 30, seed: int = 0):
    """An evaluation's element metrics and a reconstruction's measures for z elements (the last 20 occluders), where
    completeness rises with VR and falls with R, and 40 targets are unseen (VR = 0, no visible sample)."""
    rng = np.random.default_rng(seed)
    target = np.arange(z) < z - 20
    VR = rng.integers(1, 40, z)
    VR[:40] = 0
    visible = VR > 0
    R = np.where(visible, rng.uniform(0.002, 0.03, z), np.nan)
    O = np.where(visible, rng.uniform(5, 70, z), np.nan)
    pixels = np.where(visible, rng.uniform(1e3, 1e6, z), rng.uniform(0, 600, z))
    em = ElementMetrics(is_target=target, VR=VR, visible=visible, observed=visible, R=R, O=O, pixels_total=pixels,
                        frames_observed=VR.copy())
    ev = Evaluation(observations=None, metrics=Metrics(plan=None, elements=em, frames=None, params=None),
                    settings=None, engine="test", n_features=0, timings={})
    samples = np.full(z, 200)
    vis = np.where(visible, rng.integers(20, 201, z), 0)
    c = np.clip(sigmoid(0.15 * VR - 150 * np.nan_to_num(R) + rng.normal(0, 0.6, z)), 0, 1)
    covered = np.round(c * vis).astype(int)
    points = np.round(covered * rng.uniform(0.5, 3, z)).astype(int)
    nu = rng.integers(0, 400, n_frames)
    registered = nu + rng.normal(0, 80, n_frames) > 120
    m = ReconstructionMeasures(
        tolerance_m=0.02, radius_m=0.1, resolution_m_px=0.01, samples_per_m2=100.0, points=points, samples=samples,
        visible_samples=vis, covered_samples=covered, area_m2=np.full(z, 2.0), is_target=target,
        global_id=np.array([f"G{i}" for i in range(z)], object), name=np.array([f"e{i}" for i in range(z)], object),
        ifc_class=np.array(["IfcWall"] * z, object), point_element=np.zeros(0, np.int32),
        point_distance_m=np.zeros(0), frame_names=tuple(f"f{i}" for i in range(n_frames)), registered=registered,
        position_error_m=np.where(registered, 0.01, np.nan), rotation_error_deg=np.where(registered, 0.1, np.nan),
        nu=nu, stable=nu >= 100, residual_m=0.01, scene_size_m=30.0)
    return ev, m


def test_correlations_are_scipys_on_the_defined_pairs():
    ev, m = generated()
    s = loop_study(ev, m)
    t = m.is_target
    assert s.n_elements == t.sum() == 380
    c = m.covered_samples[t] / np.where(m.visible_samples[t] > 0, m.visible_samples[t], np.nan)
    x = {"VR": ev.metrics.elements.VR[t], "R": 1000 * ev.metrics.elements.R[t], "O": ev.metrics.elements.O[t]}
    for p, values in x.items():
        ok = np.isfinite(values) & np.isfinite(c)
        got = s.correlation(p, "completeness")
        assert got.n == ok.sum() == 340  # 380 targets less the 40 unseen
        ref, refs = pearsonr(values[ok], c[ok]), spearmanr(values[ok], c[ok])
        assert got.pearson_r == pytest.approx(ref.statistic, abs=1e-12)
        assert got.pearson_p == pytest.approx(ref.pvalue, rel=1e-9, abs=1e-300)
        assert got.spearman_r == pytest.approx(refs.statistic, abs=1e-12)
    assert s.correlation("VR", "completeness").pearson_r > 0.3
    assert s.correlation("R", "completeness").pearson_r < -0.3
    pts = s.correlation("pixels", "points")
    assert pts.n == 380  # points and pixels are numbers on unseen elements too
    # the frames: point-biserial r is Pearson's r with the 0/1 variable, the confusion counted here
    f = s.frames
    assert f.r == pytest.approx(pearsonr(m.nu, m.registered.astype(float)).statistic)
    assert f.stable_registered == int((m.stable & m.registered).sum())
    assert f.unstable_unregistered == int((~m.stable & ~m.registered).sum())
    assert f.stable_registered + f.stable_unregistered + f.unstable_registered + f.unstable_unregistered == 30


def test_logistic_fit_recovers_the_coefficients():
    rng = np.random.default_rng(11)
    n = 6000
    X = np.column_stack([rng.normal(10, 4, n), rng.uniform(0, 1, n), rng.normal(0, 1, n)])
    beta = np.array([0.5, -3.0, 0.0])
    b0 = -4.0
    y = rng.random(n) < sigmoid(b0 + X @ beta)
    fit = fit_logistic(X, y, ("a", "b", "c"))
    assert fit.converged and fit.n == n and fit.positives == int(y.sum())
    assert fit.raw_coef == pytest.approx(beta, abs=0.12)
    assert fit.raw_intercept == pytest.approx(b0, abs=0.4)
    assert fit.p[0] < 1e-6 and fit.p[1] < 1e-6 and fit.p[2] > 0.001
    # its probabilities are the model's: accuracy against the truth's own, within a percent
    truth = ((sigmoid(b0 + X @ beta) >= 0.5) == y).mean()
    assert fit.accuracy == pytest.approx(truth, abs=0.01)
    assert fit.probability(X[:3]) == pytest.approx(sigmoid(fit.raw_intercept + X[:3] @ fit.raw_coef))
    assert 0 < fit.pseudo_r2 < 1


def test_logistic_fit_refuses_one_outcome_and_too_few_rows():
    X = np.arange(20.0)[:, None]
    with pytest.raises(LoopStudyError, match="both outcomes"):
        fit_logistic(X, np.ones(20))
    with pytest.raises(LoopStudyError, match="at least 10"):
        fit_logistic(X[:5], np.r_[0, 1, 0, 1, 0])
    # a separable set stays finite under the penalty
    fit = fit_logistic(X, (X[:, 0] >= 10).astype(float))
    assert np.isfinite(fit.coef).all() and fit.accuracy == 1.0


def test_frame_study_counts():
    f = frame_study([500, 50, 10, 300], [True, False, False, True], [True, True, False, False])
    assert (f.stable_registered, f.stable_unregistered, f.unstable_registered, f.unstable_unregistered) == (1, 1, 1, 1)
    assert f.agreement == 0.5
    assert frame_study([5, 6, 7], [True] * 3, [True] * 3).r is None  # every frame registered: r undefined


def test_the_study_writes_its_tables(tmp_path):
    ev, m = generated(z=120, seed=3)
    s = loop_study(ev, m, paper_table=TABLE2 if TABLE2.is_file() else None, info={"model": "generated"})
    paths = s.write(tmp_path)
    data = json.loads(paths["study"].read_text())
    assert data["elements"] == 100 and data["logistic"]["n"] == s.logistic.n
    assert data["reconstructed"] == int((s.columns["reconstructed"] == 1).sum())
    rows = list(csv.DictReader(paths["elements"].open()))
    assert len(rows) == 100 and rows[0]["global_id"] == "G0" and rows[0]["R"] == ""  # G0 is unseen
    frames = list(csv.DictReader(paths["frames"].open()))
    assert len(frames) == 30 and {r["registered"] for r in frames} <= {"0", "1"}
    assert [r["predictor"] for r in data["comparison"]] == [*PREDICTORS, "nu"]
    if TABLE2.is_file():  # the paper's r for VR × Ce over its 13 data sets
        from sightplan.study import read_study

        assert data["comparison"][0]["paper_r_Ce"] == pytest.approx(read_study(TABLE2).r("VR", "Ce"))
    for key in ("scatter_completeness", "scatter_points", "frames_plot"):
        assert paths[key].read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"


def test_the_papers_table_is_bundled_and_beside_the_study_by_default():
    from sightplan.loop.study import PAPER_TABLE
    from sightplan.study import read_study

    if TABLE2.is_file():
        assert PAPER_TABLE.read_bytes() == TABLE2.read_bytes()
    ev, m = generated(z=60)
    s = loop_study(ev, m)
    assert s.paper is not None and s.paper.n_rows == 13
    assert s.comparison()[0]["paper_r_Ce"] == pytest.approx(read_study(PAPER_TABLE).r("VR", "Ce")) == \
        pytest.approx(0.65, abs=0.005)  # the paper's strongest correlation (§4.3)
    assert loop_study(ev, m, paper_table=False).paper is None


def test_the_default_render_scale_and_the_estimate():
    """A 20 MP camera is photographed at 0.1 of its width (547 × 365 px); a small one at full size; the estimate is
    its rates times the pixels and frames."""
    from sightplan.camera.catalogue import get_camera
    from sightplan.camera.models import PinholeCamera
    from sightplan.loop.estimate import S_PER_FRAME, S_PER_MPX, default_scale, estimate
    from sightplan.plan.types import Plan

    big = Plan.build(get_camera("p4p"), np.repeat(np.eye(3)[None], 100, axis=0), np.zeros((100, 3)))
    assert default_scale(big) == 0.1
    e = estimate(big, 0.1)
    assert (e.frames, e.width, e.height) == (100, 547, 365)
    assert e.megapixels == pytest.approx(100 * 547 * 365 / 1e6)
    assert e.minutes == pytest.approx((S_PER_MPX * e.megapixels + S_PER_FRAME * 100) / 60)
    assert "100 frames × 547×365 px at render scale 0.1" in e.text()
    small = Plan.build(PinholeCamera(320, 240, 300.0, 300.0, 160.0, 120.0), np.eye(3)[None], np.zeros((1, 3)))
    assert default_scale(small) == 1.0


def test_bad_threshold_and_predictor():
    ev, m = generated(z=60)
    with pytest.raises(LoopStudyError, match="threshold"):
        loop_study(ev, m, threshold=0)
    with pytest.raises(LoopStudyError, match="unknown predictor"):
        loop_study(ev, m, logit=("VR", "colour"))


# --------------------------------------------------------------------------- the loop's back half, end to end
def test_loop_from_a_reconstruction_folder(tmp_path):
    """`sightplan loop --reconstruction` on the walls of test_loop_measure: wall A reconstructed, wall B not, the
    hidden box seen by no frame."""
    from sightplan.engines.registry import available_engines
    from sightplan.loop import write_reconstruction
    from sightplan.plan.format import write_plan
    from sightplan.plan.types import Plan
    from test_cli import assert_clean_error, run_cli
    from test_loop_measure import CAM, CENTRES, R_NORTH, A, box_points, recon, write_boxes_obj

    if not available_engines():
        pytest.skip("no visibility engine")
    write_boxes_obj(tmp_path / "boxes.obj")
    write_plan(Plan.build(CAM, np.repeat(R_NORTH[None], 2, axis=0), CENTRES), tmp_path / "plan.json")
    rec = recon(box_points(A, 3000, np.random.default_rng(8)), registered=(True, False))
    write_reconstruction(replace(rec, info={"render_scale": 0.5}), tmp_path / "recon")
    args = ["loop", "boxes.obj", "plan.json", "-o", "out", "--reconstruction", "recon", "--eval-scale", "0.5",
            "--no-cache"]
    res = run_cli(*args, cwd=tmp_path)
    assert res.returncode == 0, res.stdout + res.stderr
    assert "frames registered: 1 of 2" in res.stdout and "Pearson r" in res.stdout
    out = tmp_path / "out"
    rows = {r["name"]: r for r in csv.DictReader((out / "elements.csv").open())}
    assert len(rows) == 3
    assert float(rows["E0"]["completeness"]) > 0.95 and float(rows["E1"]["completeness"]) == 0.0
    assert rows["E2"]["completeness"] == "" and rows["E2"]["points"] == "0"
    assert float(rows["E0"]["points"]) == pytest.approx(3000 * 18.3, rel=0.01)
    page = (out / "index.html").read_text()
    assert "id='comparison'" in page and "data:image/png;base64," in page and "the model coloured" in page
    assert "Table 2 correlations over 13 data sets" in page and "+0.65" in page  # the bundled table: r(VR, Ce)
    assert "No logistic fit" in page  # three elements: too few for a fit, and the page says so
    data = json.loads((out / "study.json").read_text())
    assert data["frames"]["registered"] == 1 and data["elements"] == 3
    # the photographs were taken at half the plan's resolution: the evaluation counts their pixels, a quarter of
    # the plan's, and ρ is the walls' 20 m over the halved 400 px focal length
    assert data["info"]["render_scale"] == 0.5
    measures = json.loads((out / "measures.json").read_text())
    assert measures["resolution_m_px"] == pytest.approx(20.0 / 400.0, rel=0.05)
    assert json.loads((out / "validation.json").read_text())["metrics"]["Ce"] > 0.3
    assert_clean_error(run_cli("loop", "boxes.obj", "plan.json", "--reconstruction", "nowhere", "-o", "x",
                               cwd=tmp_path), "not a reconstruction directory")
