"""Measures of a reconstruction per element and per frame, on scenes whose answers are known by construction.

Γ: wall A (element 0) and wall B (element 1) side by side 20 m north of two cameras looking north, and box H
(element 2) 25 m north, hidden behind wall A from both cameras. A camera sees of a wall its south face and the side
facing the image centre (the other faces turn away from it), so wall A shows 2.5·3 + 0.3·3 = 8.4 m² of its
18.3 m² and wall B 2.5·2.4 + 0.3·2.4 = 6.72 m² of its 14.94 m². The reconstructions are points drawn here on
chosen parts of those boxes, with registration arrays chosen here.
"""

from __future__ import annotations

import json

import numpy as np
import pytest

from sightplan.camera.models import PinholeCamera
from sightplan.engines.registry import available_engines
from sightplan.errors import SightplanError
from sightplan.evaluate import EvaluationSettings, evaluate
from sightplan.geometry.distance import point_triangle_sq
from sightplan.loop import Reconstruction, read_reconstruction, write_reconstruction
from sightplan.loop.measure import (
    TOLERANCE_PX,
    measure_reconstruction,
    plan_resolution,
    validate_reconstruction,
)
from sightplan.model.scene import ElementTable, Scene
from sightplan.plan.types import Plan
from sightplan.validate import nearest_faces, validate
from test_validate import box_mesh

pytestmark = pytest.mark.skipif(not available_engines(), reason="no visibility engine")

R_NORTH = np.array([[1.0, 0.0, 0.0], [0.0, 0.0, 1.0], [0.0, -1.0, 0.0]])
CAM = PinholeCamera(320, 240, 800.0, 800.0, 160.0, 120.0)
A = (-3.0, -0.5, 20.0, 20.3, -1.5, 1.5)
B = (0.5, 3.0, 20.0, 20.3, -1.2, 1.2)
H = (-2.5, -1.0, 25.0, 25.5, -1.0, 1.0)
BOXES = [A, B, H]
CENTRES = np.array([[0.0, 0.0, 0.0], [0.3, 0.0, 0.1]])
SETTINGS = EvaluationSettings(engine="auto", scale=0.5)


def scene_of(boxes) -> Scene:
    vs, fs, fe = [], [], []
    for i, b in enumerate(boxes):
        v, f = box_mesh(b)
        vs.append(v)
        fs.append(f + 8 * i)
        fe += [i] * 12
    names = ["wall A", "wall B", "hidden box"][: len(boxes)]
    els = ElementTable.build([f"E{i}" for i in range(len(boxes))], name=names, ifc_class=["IfcWall"] * len(boxes))
    return Scene.from_arrays(np.concatenate(vs), np.concatenate(fs), np.array(fe), els)


def face_points(b, axis: int, side: int, n: int, rng, lo=None, hi=None):
    """n points uniform on one face of box b: the face normal to ``axis`` at its low (0) or high (1) side,
    optionally restricted to [lo, hi] on the other axes (dict axis → bound)."""
    lo = lo or {}
    hi = hi or {}
    p = np.empty((n, 3))
    for k in range(3):
        a, c = b[2 * k], b[2 * k + 1]
        if k == axis:
            p[:, k] = a if side == 0 else c
        else:
            p[:, k] = rng.uniform(lo.get(k, a), hi.get(k, c), n)
    return p


def box_points(b, n_per_m2: float, rng):
    """Points uniform over all six faces of box b."""
    out = []
    dims = [b[1] - b[0], b[3] - b[2], b[5] - b[4]]
    for axis in range(3):
        others = [dims[k] for k in range(3) if k != axis]
        n = int(round(others[0] * others[1] * n_per_m2))
        out += [face_points(b, axis, 0, n, rng), face_points(b, axis, 1, n, rng)]
    return np.concatenate(out)


def write_boxes_obj(path) -> None:
    """The three boxes as an OBJ file, one object (element) per box: E0, E1, E2."""
    lines = []
    for i, b in enumerate(BOXES):
        v, f = box_mesh(b)
        lines += [f"o E{i}"] + [f"v {x:.6f} {y:.6f} {z:.6f}" for x, y, z in v]
        lines += [f"f {a + 1 + 8 * i} {c + 1 + 8 * i} {d + 1 + 8 * i}" for a, c, d in f]
    path.write_text("\n".join(lines) + "\n")


def recon(points, registered=(True, True), pos=(0.01, 0.02), rot=(0.1, 0.2), residual=0.005) -> Reconstruction:
    n = len(points)
    reg = np.array(registered, bool)
    return Reconstruction(
        points=np.asarray(points, float), track_length=np.full(n, 3, np.int32), error_px=np.full(n, 0.5),
        frame_names=("frame_00000", "frame_00001"), registered=reg,
        position_error_m=np.where(reg, pos, np.nan), rotation_error_deg=np.where(reg, rot, np.nan),
        scale=1.0, R=np.eye(3), t=np.zeros(3), residual_m=residual, scene_size_m=12.0)


@pytest.fixture(scope="module")
def gamma() -> Scene:
    return scene_of(BOXES)


@pytest.fixture(scope="module")
def plan() -> Plan:
    return Plan.build(CAM, np.repeat(R_NORTH[None], len(CENTRES), axis=0), CENTRES)


@pytest.fixture(scope="module")
def ev(gamma, plan):
    return evaluate(gamma, plan, SETTINGS, cache_dir=False)


# --------------------------------------------------------------------------- nearest triangle
def test_nearest_faces_matches_a_brute_force_distance():
    rng = np.random.default_rng(3)
    v, f = box_mesh(A)
    pts = np.column_stack([rng.uniform(-3.3, -0.2, 4000), rng.uniform(19.7, 20.6, 4000), rng.uniform(-1.8, 1.8, 4000)])
    face, dist = nearest_faces(pts, v, f, 0.1)
    # distance to an axis-aligned box from outside or inside: the box's own closed form
    lo, hi = np.array(A[0::2]), np.array(A[1::2])
    outside = np.linalg.norm(np.maximum(0, np.maximum(lo - pts, pts - hi)), axis=1)
    inside = np.min(np.concatenate([pts - lo, hi - pts], axis=1), axis=1)
    truth = np.where(outside > 0, outside, inside)
    near = truth <= 0.1
    assert (face >= 0).sum() == near.sum() > 1000
    assert np.allclose(dist[near], truth[near], atol=1e-9)
    assert np.all(face[~near] == -1) and np.all(np.isinf(dist[~near]))
    # the face given is one at that distance, and no face of the box is nearer
    tri = v[f]
    to_face = np.sqrt([point_triangle_sq(*p, tri[k]) for p, k in zip(pts[near], face[near], strict=True)])
    assert np.allclose(to_face, dist[near], rtol=0, atol=1e-12)
    to_all = np.sqrt([[point_triangle_sq(*p, t) for t in tri] for p in pts[near][:300]])
    assert np.allclose(to_all.min(axis=1), to_face[:300], rtol=0, atol=1e-12)


# --------------------------------------------------------------------------- per element
def test_counts_completeness_and_the_hidden_element(gamma, plan, ev):
    rng = np.random.default_rng(1)
    pa = box_points(A, 20_000, rng)  # wall A, every face, 7 mm apart
    ph = box_points(H, 2_000, rng)  # the hidden box has points (as a stray match could make) but no visible surface
    off = face_points(B, 1, 0, 3000, rng)  # wall B's south face, moved 10 cm south: beyond τ
    off[:, 1] -= 0.10
    near = face_points(B, 1, 0, 40, rng)  # 40 points 1 cm south of wall B: within τ
    near[:, 1] -= 0.01
    rec = recon(np.concatenate([pa, ph, off, near]))
    m = measure_reconstruction(gamma, plan, rec, ev, tolerance_m=0.03, radius_m=0.05, samples_per_m2=400)
    assert m.points.tolist() == [len(pa), 40, len(ph)]
    assert (m.point_element == -1).sum() == len(off)
    # visible shares of the surface, by construction: 8.4/18.3, 6.72/14.94 and 0
    share = m.visible_samples / m.samples
    assert share[0] == pytest.approx(8.4 / 18.3, abs=0.02)
    assert share[1] == pytest.approx(6.72 / 14.94, abs=0.02)
    assert m.visible_samples[2] == 0 and m.samples[2] > 0
    c = m.completeness
    assert c[0] == pytest.approx(1.0, abs=0.002)
    assert 0 < c[1] <= 40 * np.pi * 0.05**2 / 6.72 + 0.01  # 40 discs of 5 cm cover at most 0.31 m² of 6.72 m²
    assert np.isnan(c[2]) and np.isnan(m.density_per_m2[2])
    assert m.density_per_m2[0] == pytest.approx(len(pa) / 8.4, rel=0.05)
    rows = {r["name"]: r for r in m.element_rows()}
    assert rows["hidden box"]["completeness"] is None and rows["hidden box"]["points"] == len(ph)
    assert json.loads(json.dumps(m.to_dict(), allow_nan=False))["summary"]["elements_with_points"] == 3


def test_no_points_means_no_count_and_no_completeness(gamma, plan, ev):
    rng = np.random.default_rng(2)
    rec = recon(box_points(H, 500, rng))  # points only where no camera looks
    m = measure_reconstruction(gamma, plan, rec, ev, tolerance_m=0.03, radius_m=0.05, samples_per_m2=400)
    assert m.points[:2].tolist() == [0, 0]
    assert m.completeness[:2].tolist() == [0.0, 0.0]
    assert m.density_per_m2[:2].tolist() == [0.0, 0.0]


def test_half_a_face_gives_its_share_of_the_visible_surface(gamma, plan, ev):
    """Points on the west half of wall A's south face (x < −1.75): covered is that half (3.75 m²) plus the strip
    of width r east of it (3 m · r), of 8.4 m² visible."""
    rng = np.random.default_rng(4)
    pts = face_points(A, 1, 0, 150_000, rng, hi={0: -1.75})
    r = 0.02
    m = measure_reconstruction(gamma, plan, recon(pts), ev, tolerance_m=0.01, radius_m=r, samples_per_m2=400)
    assert m.completeness[0] == pytest.approx((3.75 + 3 * r) / 8.4, abs=0.015)


def test_frames_and_default_tolerance(gamma, plan, ev):
    rng = np.random.default_rng(5)
    rec = recon(box_points(A, 2000, rng), registered=(True, False), pos=(0.04, 0.0), rot=(0.3, 0.0), residual=0.01)
    m = measure_reconstruction(gamma, plan, rec, ev, image_scale=0.5)
    rho = plan_resolution(ev) / 0.5
    assert m.resolution_m_px == pytest.approx(rho)
    assert m.tolerance_m == pytest.approx(1.2 * 0.01 + TOLERANCE_PX * rho)
    # r: the spacing of the points on the model, about 1/√(points per m²) for these uniform points
    spacing = m.parameters["point_spacing_m"]
    assert spacing == pytest.approx(1 / np.sqrt(2000), rel=0.2) and m.radius_m == max(m.tolerance_m, spacing)
    # ρ is depth / focal length: the walls stand 20 m away from cameras of 800 px per radian
    assert plan_resolution(ev) == pytest.approx(20.0 / 800.0, rel=0.05)
    rows = m.frame_rows()
    assert [r["registered"] for r in rows] == [True, False]
    assert rows[0]["position_error_m"] == pytest.approx(0.04) and rows[1]["position_error_m"] is None
    assert [r["nu"] for r in rows] == ev.metrics.frames.nu.tolist()
    s = m.summary()
    assert s["frames_registered"] == 1 and s["rotation_error_deg_max"] == pytest.approx(0.3)


def test_a_reconstruction_of_another_plan_is_refused(gamma, ev):
    one = Plan.build(CAM, R_NORTH[None], CENTRES[:1])
    with pytest.raises(SightplanError, match="2 frames and the plan 1"):
        measure_reconstruction(gamma, one, recon(np.zeros((5, 3))), tolerance_m=0.1, radius_m=0.1)


# --------------------------------------------------------------------------- as the validation's reality
def test_validate_reconstruction_equals_validate_with_its_points(gamma, plan, ev):
    rng = np.random.default_rng(6)
    rec = recon(box_points(A, 5000, rng) + rng.normal(0, 0.002, (1, 3)), residual=0.02)
    a = validate_reconstruction(gamma, plan, rec, settings=SETTINGS, evaluation=ev)
    b = validate(gamma, plan, rec.points, 0.02, SETTINGS, ev)
    assert a.registration_error_m == 0.02
    assert a.plan_metrics() == b.plan_metrics()
    assert a.c.tolist() == b.c.tolist()
    # wall A is there, wall B is not: half the targets' completeness from the one present
    assert a.c[1] == 0 and a.c[0] > 0.9
    given = validate_reconstruction(gamma, plan, rec, 0.05, settings=SETTINGS, evaluation=ev)
    assert given.lam == pytest.approx(0.06)


def test_validate_cli_with_a_reconstruction_folder(tmp_path, gamma):
    from plyfile import PlyData, PlyElement

    from sightplan.plan.format import write_plan
    from test_cli import assert_clean_error, run_cli

    write_boxes_obj(tmp_path / "boxes.obj")
    write_plan(Plan.build(CAM, np.repeat(R_NORTH[None], 2, axis=0), CENTRES), tmp_path / "plan.json")
    rng = np.random.default_rng(7)
    rec = recon(box_points(A, 5000, rng), registered=(True, False), residual=0.03)
    write_reconstruction(rec, tmp_path / "recon")
    pts = np.array([tuple(p) for p in rec.points], dtype=[("x", "f8"), ("y", "f8"), ("z", "f8")])
    PlyData([PlyElement.describe(pts, "vertex")]).write(str(tmp_path / "cloud.ply"))
    common = ("--scale", "0.5", "--no-cache")
    res = run_cli("validate", "boxes.obj", "plan.json", "--reconstruction", "recon", "--out", "a", *common,
                  cwd=tmp_path)
    assert res.returncode == 0, res.stdout + res.stderr
    assert "1 of 2" in res.stdout and "frames registered" in res.stdout
    res = run_cli("validate", "boxes.obj", "plan.json", "cloud.ply", "-e", "0.03", "--out", "b", *common, cwd=tmp_path)
    assert res.returncode == 0, res.stdout + res.stderr
    a = json.loads((tmp_path / "a" / "validation.json").read_text())
    b = json.loads((tmp_path / "b" / "validation.json").read_text())
    assert a["metrics"] == b["metrics"] and a["elements"] == b["elements"] and a["lambda_m"] == pytest.approx(0.036)
    assert a["reconstruction"]["frames_registered"] == 1 and a["reconstruction"]["unregistered"] == ["frame_00001"]
    assert "reconstruction" not in b

    (tmp_path / "empty").mkdir()
    bad = run_cli("validate", "boxes.obj", "plan.json", "--reconstruction", "empty", "--out", "c", cwd=tmp_path)
    assert_clean_error(bad, "points.npz", "not a sightplan reconstruction")
    (tmp_path / "broken").mkdir()
    write_reconstruction(rec, tmp_path / "broken")
    (tmp_path / "broken" / "registration.json").write_text("{")
    assert_clean_error(run_cli("validate", "boxes.obj", "plan.json", "--reconstruction", "broken", cwd=tmp_path),
                       "not a readable reconstruction")
    assert_clean_error(run_cli("validate", "boxes.obj", "plan.json", cwd=tmp_path), "REALITY", "--reconstruction")
    assert_clean_error(run_cli("validate", "boxes.obj", "plan.json", "cloud.ply", cwd=tmp_path),
                       "registration error")
    assert read_reconstruction(tmp_path / "recon").n_registered == 1


def test_loop_and_validate_give_the_same_numbers_for_the_same_reconstruction(tmp_path):
    """Photographs at a quarter of the camera's size: wall A shows 25 × 30 = 750 of their pixels, wall B 25 × 24 =
    600, under Ω = 625 (at full size both are over 9,000). `loop` and `validate --reconstruction` both count Ω in the
    photographs' pixels and cast them at their own size, so wall A alone is visible and A, Ce, Cv, Ct agree exactly."""
    from dataclasses import replace

    from typer.testing import CliRunner

    import sightplan.cli.validate_cmd  # noqa: F401  (registers the command)
    from sightplan.cli.main import app
    from sightplan.loop import loop
    from sightplan.model.load import load_model
    from sightplan.plan.format import write_plan

    the_plan = Plan.build(CAM, np.repeat(R_NORTH[None], 2, axis=0), CENTRES)
    write_boxes_obj(tmp_path / "boxes.obj")
    write_plan(the_plan, tmp_path / "plan.json")
    rng = np.random.default_rng(11)
    pts = np.concatenate([face_points(A, 1, 0, 400, rng), face_points(B, 1, 0, 300, rng)])
    pts[::50, 1] -= 3.0  # a few SfM outliers in front of the walls
    rec = replace(recon(pts, residual=0.03), info={"render_scale": 0.25})
    write_reconstruction(rec, tmp_path / "recon")
    scene, _ = load_model(tmp_path / "boxes.obj", cache=False)  # the model as the command loads it
    looped = loop(scene, the_plan, tmp_path / "loop", reconstruction=tmp_path / "recon")
    res = CliRunner().invoke(app, ["validate", str(tmp_path / "boxes.obj"), str(tmp_path / "plan.json"),
                                   "--reconstruction", str(tmp_path / "recon"), "--out", str(tmp_path / "v"),
                                   "--no-cache"], env={"COLUMNS": "200"})
    assert res.exit_code == 0, res.output
    a = json.loads((tmp_path / "loop" / "validation.json").read_text())
    b = json.loads((tmp_path / "v" / "validation.json").read_text())
    assert a["metrics"]["visible"] == 1 and a["metrics"]["Cv"] is not None
    assert a["metrics"] == b["metrics"] and a["elements"] == b["elements"]
    assert a["metrics"]["outliers"] == len(pts[::50]) and a["counts"]["distances"] == b["counts"]["distances"]
    assert looped.validation.Cv == a["metrics"]["Cv"] and next(iter(looped.plan.cameras.values())).width == 80
    assert b["inputs"]["render_scale"] == 0.25 and "outliers" in res.output
