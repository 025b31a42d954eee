"""Validation against a reality model (METRICS.md §7) on scenes whose answers are known independently.

Γ is two walls (axis-aligned boxes) in front of pinhole cameras. Expected pixel values come
from a float64 slab ray caster written here (pixel-centre rays against the boxes) and expected
surface shares from closed-form box areas — never from sightplan's own helpers.
"""

from __future__ import annotations

import json
import math
import time

import numpy as np
import pytest

from sightplan.camera.models import PinholeCamera
from sightplan.engines.registry import available_engines
from sightplan.evaluate import EvaluationSettings
from sightplan.metrics import MetricParams
from sightplan.model.pointcloud import PointCloud
from sightplan.model.scene import ElementTable, Scene
from sightplan.plan.types import Plan
from sightplan.validate import outward_normal, points_near_mesh, synthetic_reality, validate

pytestmark = pytest.mark.skipif(not available_engines(), reason="no visibility engine")

# camera looking north (+Y); image right = +X, image down = −Z (columns: camera x, y, z axes in world)
R_NORTH = np.array([[1.0, 0.0, 0.0], [0.0, 0.0, 1.0], [0.0, -1.0, 0.0]])
CAM = PinholeCamera(320, 240, 800.0, 800.0, 160.0, 120.0)
# (x0, x1, y0, y1, z0, z1) of wall 1 (element 0) and wall 2 (element 1); edges fall between pixel centres
WALLS = [(-3.1, -0.45, 20.0, 20.3, -1.7, 1.9), (0.55, 2.9, 20.0, 20.3, -1.3, 1.1)]
# frame 0 sees both walls; frame 1 (8 m from wall 1) sees only wall 1's front: VR = (2, 1)
CENTRES = np.array([[0.0, 0.0, 0.0], [-1.8, 12.0, 0.1]])
SETTINGS = EvaluationSettings(engine="auto", metric=MetricParams(omega=625))


# --------------------------------------------------------------------------- geometry
def box_mesh(b):
    x0, x1, y0, y1, z0, z1 = b
    v = np.array([[x, y, z] for z in (z0, z1) for y in (y0, y1) for x in (x0, x1)], float)
    # vertex index = 4·iz + 2·iy + ix; outward winding
    f = np.array([[0, 2, 3], [0, 3, 1], [4, 5, 7], [4, 7, 6], [0, 1, 5], [0, 5, 4],
                  [2, 6, 7], [2, 7, 3], [0, 4, 6], [0, 6, 2], [1, 3, 7], [1, 7, 5]])
    return v, f


def box_area(b):
    dx, dy, dz = b[1] - b[0], b[3] - b[2], b[5] - b[4]
    return 2 * (dx * dy + dy * dz + dx * dz)


def scene_of(boxes, scale: float = 1.0) -> Scene:
    vs, fs, fe = [], [], []
    for i, b in enumerate(boxes):
        v, f = box_mesh(b)
        fs.append(f + 8 * i)
        vs.append(v * scale)
        fe += [i] * 12
    els = ElementTable.build([f"W{i + 1}" for i in range(len(boxes))], name=[f"wall {i + 1}" for i in range(len(boxes))],
                             ifc_class=["IfcWall"] * len(boxes))
    return Scene.from_arrays(np.concatenate(vs), np.concatenate(fs), np.array(fe), els)


def plan_of(centres) -> Plan:
    centres = np.asarray(centres, float).reshape(-1, 3)
    return Plan.build(CAM, np.repeat(R_NORTH[None], len(centres), axis=0), centres)


def cast_boxes(boxes, C, scale: float = 1.0):
    """Independent float64 slab caster: (H·W,) element (−1 none) and distance (inf none) of CAM's pixels from C."""
    u = np.arange(CAM.width) + 0.5
    v = np.arange(CAM.height) + 0.5
    X, Y = np.meshgrid((u - CAM.cx) / CAM.fx, (v - CAM.cy) / CAM.fy)
    d = np.stack([X, Y, np.ones_like(X)], axis=-1).reshape(-1, 3) @ R_NORTH.T
    d /= np.linalg.norm(d, axis=1, keepdims=True)
    best = np.full(len(d), np.inf)
    elem = np.full(len(d), -1)
    with np.errstate(divide="ignore", invalid="ignore"):
        for i, b in enumerate(boxes):
            lo, hi = np.array(b[0::2]) * scale, np.array(b[1::2]) * scale
            t1, t2 = (lo - C) / d, (hi - C) / d
            tn = np.nanmax(np.minimum(t1, t2), axis=1)
            tf = np.nanmin(np.maximum(t1, t2), axis=1)
            hit = (tn <= tf) & (tf > 0)
            t = np.where(tn > 0, tn, tf)
            closer = hit & (t < best)
            best[closer] = t[closer]
            elem[closer] = i
    return elem, best


def expected(gamma_boxes, psi_boxes, lam, omega=625.0):
    """(VR, c, A, complete, back) over CENTRES from the independent caster."""
    frames = [(cast_boxes(gamma_boxes, C), cast_boxes(psi_boxes, C)[1]) for C in CENTRES]
    z = len(gamma_boxes)
    VR = np.zeros(z, int)
    for (e, _), _ in frames:
        VR += np.bincount(e[e >= 0], minlength=z) >= omega
    back, comp = np.zeros(z), np.zeros(z)
    num = den = 0.0
    for (e, dg), dp in frames:
        m = e >= 0
        both = m & np.isfinite(dp)
        with np.errstate(invalid="ignore"):
            diff = np.abs(dg - dp)
        back += np.bincount(e[m], minlength=z)
        comp += np.bincount(e[both & (diff <= lam)], minlength=z)
        num += (VR[e[both]] * diff[both]).sum()
        den += VR[e[both]].sum()
    return VR, comp / back, num / den, comp, back


def moved(b, dy):
    return (b[0], b[1], b[2] + dy, b[3] + dy, b[4], b[5])


@pytest.fixture(scope="module")
def gamma() -> Scene:
    return scene_of(WALLS)


@pytest.fixture(scope="module")
def plan() -> Plan:
    return plan_of(CENTRES)


@pytest.fixture(scope="module")
def evaluation(gamma, plan):
    from sightplan.evaluate import evaluate

    return evaluate(gamma, plan, SETTINGS, cache_dir=False)


# --------------------------------------------------------------------------- mesh reality
def test_identical_reality_is_perfect(gamma, plan, evaluation):
    v = validate(gamma, plan, gamma, 0.05, SETTINGS, evaluation)
    assert v.A == 0.0
    assert v.c[:2].tolist() == [1.0, 1.0]
    assert v.Ce == v.Cv == v.Ct == v.precision == v.recall == v.F == 1.0
    assert v.VR[:2].tolist() == [2, 1] and v.n_visible == 2 and v.z == 2
    assert v.warnings == ()
    assert v.reality_kind == "mesh"


def test_removed_wall(gamma, plan, evaluation):
    psi = synthetic_reality(gamma, remove=[1])
    v = validate(gamma, plan, psi, 0.05, SETTINGS, evaluation)
    assert v.c[0] == 1.0 and v.c[1] == 0.0
    assert v.Ce == pytest.approx(0.5) and v.Cv == pytest.approx(0.5)
    share = box_area(WALLS[0]) / (box_area(WALLS[0]) + box_area(WALLS[1]))  # Ct samples every side of both boxes
    assert v.Ct == pytest.approx(share, abs=0.015)
    assert v.precision == 1.0  # what is left lies on Γ
    assert v.F == pytest.approx(2 * v.Ct / (1 + v.Ct))
    assert v.A == 0.0  # wall 2's pixels have no Ψ distance: they count in c_2, not in A
    assert math.isnan(v.A_i[1]) and v.A_i[0] == 0.0


@pytest.mark.parametrize("dy", [0.05, 0.2])
def test_shifted_wall(gamma, plan, evaluation, dy):
    """Wall 1 moved dy toward the cameras; e = 0.1 m so λ = 0.12 m."""
    lam = 0.12
    psi = synthetic_reality(gamma, shift={0: [0.0, -dy, 0.0]})
    v = validate(gamma, plan, psi, 0.1, SETTINGS, evaluation)
    VR, c, A, comp, back = expected(WALLS, [moved(WALLS[0], -dy), WALLS[1]], lam)
    assert v.lam == pytest.approx(lam)
    assert v.VR[:2].tolist() == VR.tolist() == [2, 1]
    assert np.abs(v.pixels[:2] - back).max() <= 2 and np.abs(v.pixels_complete[:2] - comp).max() <= 2
    assert v.c[:2] == pytest.approx(c, abs=2e-3)
    assert v.A == pytest.approx(A, rel=2e-3)
    # a head-on wall: |dΓ − dΨ| = dy/cos(angle) on wall 1's pixels, 0 on wall 2's
    n1 = back[0]
    head_on = dy * (VR[0] * n1) / (VR[0] * n1 + VR[1] * back[1])
    assert A == pytest.approx(head_on, rel=0.02)
    if dy < lam:
        assert v.c[0] == 1.0 and v.Ct == 1.0 and v.A_i[0] == pytest.approx(dy, rel=0.02)
    else:
        assert v.c[0] < 0.01 and v.c[1] == 1.0 and v.Ce == pytest.approx(0.5, abs=0.01)
    # most pixels (wall 1 fills frame 1) are off by more than λ: the registration warning fires
    assert (len(v.warnings) == 1 and "badly registered" in v.warnings[0]) if dy > lam else v.warnings == ()


def test_reality_in_millimetres_warns(gamma):
    one = plan_of(CENTRES[:1])  # a camera at the origin: every distance scales by exactly 1000
    psi = scene_of(WALLS, scale=1000.0)
    v = validate(gamma, one, psi, 0.05, SETTINGS)
    text = " ".join(v.warnings)
    assert "registered or in another unit" in text and "1000" in text and "millimetres" in text
    assert v.counts["median_ratio"] == pytest.approx(1000.0, rel=1e-6)
    assert "bounding box" in text
    assert v.c[:2].tolist() == [0.0, 0.0]


def test_far_reality_warns_about_overlap(gamma, plan, evaluation):
    psi = synthetic_reality(gamma, shift={0: [500.0, 0, 0], 1: [500.0, 0, 0]})
    v = validate(gamma, plan, psi, 0.05, SETTINGS, evaluation)
    assert any("bounding box covers only 0%" in w for w in v.warnings)
    assert any("hit on none" in w for w in v.warnings)
    assert v.A is None and v.Ce == 0.0 and v.Ct == 0.0 and v.precision is None and v.F is None


def test_invisible_plan_has_no_accuracy(gamma):
    away = Plan.build(CAM, np.array([[[1.0, 0, 0], [0, 0, -1], [0, 1, 0]]]), np.zeros((1, 3)))  # looking south
    v = validate(gamma, away, gamma, 0.05, SETTINGS)
    assert v.A is None and v.Cv is None and v.Ce == 0.0 and v.n_visible == 0
    d = v.to_dict()
    assert d["metrics"]["A_m"] is None and json.dumps(d, allow_nan=False)


# --------------------------------------------------------------------------- point clouds
def test_dense_point_cloud(gamma, plan, evaluation):
    cloud = synthetic_reality(gamma, points_per_m2=40_000, seed=1)
    assert isinstance(cloud, PointCloud) and cloud.points.shape[1] == 3
    v = validate(gamma, plan, cloud, 0.05, SETTINGS, evaluation)
    assert v.reality_kind == "point cloud"
    assert v.c[:2] == pytest.approx([1.0, 1.0], abs=0.03)
    assert v.A < 0.1 * v.lam
    assert v.Ct > 0.99 and v.precision == 1.0
    assert v.parameters["point_spacing_m"] == pytest.approx(1 / math.sqrt(40_000), rel=0.15)
    assert v.warnings == ()


def test_point_cloud_as_plain_array_and_removed_wall(gamma, plan, evaluation):
    cloud = synthetic_reality(gamma, remove=[1], points_per_m2=40_000, seed=2)
    v = validate(gamma, plan, cloud.points, 0.05, SETTINGS, evaluation)
    assert v.c[0] == pytest.approx(1.0, abs=0.03) and v.c[1] == 0.0
    share = box_area(WALLS[0]) / (box_area(WALLS[0]) + box_area(WALLS[1]))
    assert v.Ct == pytest.approx(share, abs=0.015)


def test_sparse_point_cloud(gamma, plan, evaluation):
    """Documented behaviour: splats of one spacing fill the surfaces (c_i stays high), and Ct needs a point
    within r = max(λ, spacing): for a uniform random sampling of density ρ that is 1 − exp(−ρπr²) on a plane,
    about 1 − e^−π = 96 % at r = 1/√ρ."""
    rho, e = 25.0, 0.1
    lam = 1.2 * e
    cloud = synthetic_reality(gamma, points_per_m2=rho, seed=3)
    v = validate(gamma, plan, cloud, e, SETTINGS, evaluation)
    assert any("spacing" in w for w in v.warnings)
    assert v.parameters["point_spacing_m"] > lam
    assert (v.c[:2] > 0.85).all()
    r = v.parameters["ct_radius_m"]
    assert r == v.parameters["point_spacing_m"] == pytest.approx(1 / math.sqrt(rho), rel=0.15)
    assert v.Ct == pytest.approx(1 - math.exp(-rho * math.pi * r ** 2), abs=0.06)
    assert v.precision == 1.0


def test_noisy_point_cloud_accuracy(gamma, plan, evaluation):
    """Gaussian noise σ per axis: |dΓ − dΨ| on a head-on wall is about the depth noise of the nearest splat."""
    cloud = synthetic_reality(gamma, points_per_m2=40_000, noise_m=0.01, seed=4)
    v = validate(gamma, plan, cloud, 0.05, SETTINGS, evaluation)
    assert 0.002 < v.A < 0.03
    assert (v.c[:2] > 0.95).all()


def test_sparse_cloud_with_outliers_reports_and_excludes_them(gamma, plan, evaluation):
    """An SfM-like cloud: 25 points per m² with 5 mm of noise, and one point in twenty thrown 2 m toward the cameras.
    The thrown points are the outliers, counted and left out; the accuracy is the noise's (median 0.674 σ and 90th
    percentile 1.645 σ of |N(0, σ)|); nothing says the cloud is badly registered."""
    sigma = 0.005
    cloud = synthetic_reality(gamma, points_per_m2=25.0, noise_m=sigma, seed=8).points.copy()
    thrown = np.arange(0, len(cloud), 20)
    cloud[thrown, 1] -= 2.0
    v = validate(gamma, plan, cloud, 0.1, SETTINGS, evaluation)
    assert v.outliers == len(thrown) and v.counts["distances"]["outliers"] == len(thrown)
    assert v.A_median == pytest.approx(0.674 * sigma, rel=0.25) and v.A_p90 == pytest.approx(1.645 * sigma, rel=0.25)
    assert v.A < 0.25 * v.lam and (v.c[:2] > 0.85).all()
    assert not any("badly registered" in w for w in v.warnings)
    assert v.precision == 1.0  # the thrown points lie outside Γ's box grown by λ, where precision looks
    d = v.plan_metrics()
    assert d["outliers"] == len(thrown) and d["A_median_m"] == v.A_median


def test_a_cloud_off_by_more_than_lambda_warns_and_keeps_its_points(gamma, plan, evaluation):
    """Every point 0.5 m north of where it was: the median distance (0.2–0.5 m, as the thin walls' faces come nearer
    or farther) exceeds λ = 0.12 m, which is the warning; the bound follows the median, so no point is an outlier."""
    cloud = synthetic_reality(gamma, points_per_m2=100.0, seed=9).points + [0.0, 0.5, 0.0]
    v = validate(gamma, plan, cloud, 0.1, SETTINGS, evaluation)
    assert any("median distance" in w and "badly registered" in w for w in v.warnings)
    assert 0.2 <= v.counts["distances"]["median_all_m"] <= 0.5
    assert v.outliers == 0


def test_cloud_distances_on_a_plane():
    """Points at known heights over one big square: median, 90th percentile and the points beyond the bound."""
    from sightplan.validate import cloud_distances

    v = np.array([[-50.0, -50.0, 0.0], [50.0, -50.0, 0.0], [50.0, 50.0, 0.0], [-50.0, 50.0, 0.0]])
    square = Scene.from_arrays(v, np.array([[0, 1, 2], [0, 2, 3]]), np.zeros(2, int), ElementTable.build(["floor"]))
    rng = np.random.default_rng(10)
    h = np.abs(rng.normal(0.0, 0.01, 2000))
    pts = np.column_stack([rng.uniform(-40, 40, 2000), rng.uniform(-40, 40, 2000), h])
    pts[:10, 2] = 3.0  # ten far above
    d = cloud_distances(pts, square, lam=0.012)
    assert d.n_outliers == 10 and d.outlier[:10].all()
    assert d.median_m == pytest.approx(np.median(h[10:]), rel=1e-9)
    assert d.p90_m == pytest.approx(np.percentile(h[10:], 90), rel=1e-9)


def test_equirectangular_point_cloud(gamma):
    """Splatting by direction: a 360° frame at the origin sees both walls; a dense cloud fills them.

    A splat keeps its point's distance over a footprint of at least one pixel, so on a surface at
    angle θ to the rays d_p(Ψ) errs by up to (footprint in metres)·tan θ — here one pixel, π/H rad.
    """
    from sightplan.camera.models import EquirectangularCamera

    pano = Plan.build(EquirectangularCamera(2400, 1200), R_NORTH[None], np.zeros((1, 3)))
    settings = EvaluationSettings(metric=MetricParams(omega=1))
    v = validate(gamma, pano, synthetic_reality(gamma, points_per_m2=40_000, seed=6), 0.05, settings)
    assert v.pixels[:2].min() > 500
    assert v.c[:2] == pytest.approx([1.0, 1.0], abs=0.03)
    footprint = math.pi / 1200 * 20.3
    tan_max = math.hypot(3.1, 1.9) / 20.0
    assert 0 < v.A < footprint * tan_max < 0.2 * v.lam
    removed = validate(gamma, pano, synthetic_reality(gamma, remove=[0], points_per_m2=40_000, seed=6), 0.05, settings)
    assert removed.c[0] == 0.0 and removed.c[1] == pytest.approx(1.0, abs=0.03)


# --------------------------------------------------------------------------- helpers
def test_points_near_mesh_is_exact():
    v, f = box_mesh((0, 1, 0, 1, 0, 1))
    pts = np.array([[0.5, 0.5, 1.099], [0.5, 0.5, 1.101], [1.07, 1.07, 0.5], [1.08, 1.08, 0.5], [0.5, 0.5, 0.5],
                    [1.0 + 0.1 / math.sqrt(3) - 1e-6] * 3, [1.0 + 0.1 / math.sqrt(3) + 1e-6] * 3])
    # distances: 0.099, 0.101, 0.099 (edge), 0.113, 0.5 (centre), 0.1 − ε (corner), 0.1 + ε
    assert points_near_mesh(pts, v, f, 0.1).tolist() == [True, False, True, False, False, True, False]
    big = np.array([[0, 0, 0], [100, 0, 0], [0, 100, 0]], float)  # one large triangle: bisected, still exact
    q = np.array([[30, 30, 0.05], [30, 30, 0.15], [60, 60, 0.0]])
    assert points_near_mesh(q, big, [[0, 1, 2]], 0.1).tolist() == [True, False, False]


def test_outward_normal_and_scalar_shift():
    scene = scene_of([WALLS[0], (-3.1, -0.45, 30.0, 30.3, -1.7, 1.9)])  # two parallel walls 10 m apart
    assert outward_normal(scene, 0) == pytest.approx([0, -1, 0])
    assert outward_normal(scene, 1) == pytest.approx([0, 1, 0])
    psi = synthetic_reality(scene, shift={0: 0.25})
    assert psi.bounds()[0][1] == pytest.approx(19.75)
    assert psi.vertices[psi.faces[psi.face_element == 1]].min(axis=(0, 1))[1] == pytest.approx(30.0)


def test_synthetic_reality_errors(gamma):
    from sightplan.errors import ModelError

    with pytest.raises(ModelError, match="out of range"):
        synthetic_reality(gamma, remove=[5])
    with pytest.raises(ModelError, match="points_per_m2"):
        synthetic_reality(gamma, noise_m=0.01)


def test_element_rows_and_csv(gamma, plan, evaluation, tmp_path):
    v = validate(gamma, plan, synthetic_reality(gamma, remove=[1]), 0.05, SETTINGS, evaluation)
    rows = v.element_rows()
    assert [r["global_id"] for r in rows] == ["W1", "W2"]
    assert rows[1] == {"global_id": "W2", "name": "wall 2", "ifc_class": "IfcWall", "c_i": 0.0, "A_i": None,
                       "pixels": int(v.pixels[1])}
    text = v.write_csv(tmp_path / "e.csv").read_text().splitlines()
    assert text[0] == "global_id,name,ifc_class,c_i,A_i,pixels"
    assert text[2].startswith("W2,wall 2,IfcWall,0,,")


# --------------------------------------------------------------------------- CLI
def write_obj(path, boxes):
    lines = []
    for i, b in enumerate(boxes):
        v, f = box_mesh(b)
        lines.append(f"o wall{i + 1}")
        lines += [f"v {x:.6f} {y:.6f} {z:.6f}" for x, y, z in v]
        lines += [f"f {a + 1 + 8 * i} {b_ + 1 + 8 * i} {c + 1 + 8 * i}" for a, b_, c in f]
    path.write_text("\n".join(lines) + "\n")


def test_cli_end_to_end(tmp_path, gamma):
    from plyfile import PlyData, PlyElement
    from typer.testing import CliRunner

    import sightplan.cli.validate_cmd  # noqa: F401  (registers the command)
    from sightplan.cli.main import app
    from sightplan.plan.format import write_plan

    write_obj(tmp_path / "walls.obj", WALLS)
    write_obj(tmp_path / "reality.obj", WALLS[:1])
    write_plan(plan_of(CENTRES), tmp_path / "plan.json")
    cloud = synthetic_reality(gamma, remove=[1], points_per_m2=20_000, seed=5).points
    pts = np.array([tuple(p) for p in cloud], dtype=[("x", "f8"), ("y", "f8"), ("z", "f8")])
    PlyData([PlyElement.describe(pts, "vertex")]).write(str(tmp_path / "cloud.ply"))
    runner = CliRunner()
    for reality, kind in (("reality.obj", "mesh"), ("cloud.ply", "point cloud")):
        out = tmp_path / f"out-{kind.replace(' ', '-')}"
        res = runner.invoke(app, ["validate", str(tmp_path / "walls.obj"), str(tmp_path / "plan.json"),
                                  str(tmp_path / reality), "--registration-error", "0.05", "--out", str(out),
                                  "--no-cache"], env={"COLUMNS": "160"})
        assert res.exit_code == 0, res.output
        assert "Ce" in res.output and "precision" in res.output
        report = json.loads((out / "validation.json").read_text())
        assert report["reality"] == kind and report["lambda_m"] == pytest.approx(0.06)
        assert report["metrics"]["Ce"] == pytest.approx(0.5, abs=0.02)
        rows = (out / "validation_elements.csv").read_text().splitlines()
        assert rows[0] == "global_id,name,ifc_class,c_i,A_i,pixels" and len(rows) == 3
    bad = runner.invoke(app, ["validate", str(tmp_path / "walls.obj"), str(tmp_path / "plan.json"),
                              str(tmp_path / "missing.obj"), "--registration-error", "0.05", "--out", str(tmp_path / "x")])
    assert bad.exit_code == 2
    mm = tmp_path / "mm.obj"
    write_obj(mm, [tuple(1000 * x for x in b) for b in WALLS])
    res = runner.invoke(app, ["validate", str(tmp_path / "walls.obj"), str(tmp_path / "plan.json"), str(mm),
                              "--registration-error", "0.05", "--out", str(tmp_path / "mm-out"), "--no-cache"],
                        env={"COLUMNS": "200"})
    assert res.exit_code == 0, res.output
    assert "warning" in res.output and "another unit" in res.output


# --------------------------------------------------------------------------- Duplex timing
@pytest.mark.bench
def test_duplex_300_frames_timing():
    """Timing only (printed, not asserted): 300-frame ring at scale 0.25 against the Duplex with elements removed."""
    from sightplan.camera.catalogue import get_camera
    from sightplan.evaluate import evaluate
    from sightplan.model.load import load_model
    from sightplan.plan.ring import ring_plan

    scene, _ = load_model("sample")
    plan = ring_plan(scene, get_camera("p4p"), n_frames=300)
    settings = EvaluationSettings(scale=0.25)
    t0 = time.perf_counter()
    ev = evaluate(scene, plan, settings, cache_dir=False)
    t_eval = time.perf_counter() - t0
    targets = np.flatnonzero(ev.metrics.elements.visible)
    removed = targets[:: 10]
    psi = synthetic_reality(scene, remove=removed)
    t0 = time.perf_counter()
    v = validate(scene, plan, psi, 0.02, settings, ev)
    t_val = time.perf_counter() - t0
    print(f"\nDuplex, 300 frames at scale 0.25: evaluate {t_eval:.1f} s, validate {t_val:.1f} s "
          f"(cast {v.timings['cast_s']:.1f} s, Ct {v.timings['ct_s']:.1f} s, precision {v.timings['precision_s']:.1f} s); "
          f"A={v.A:.4g} Ce={v.Ce:.3f} Cv={v.Cv:.3f} Ct={v.Ct:.3f} P={v.precision:.3f} F={v.F:.3f}, "
          f"{len(removed)} of {v.n_visible} visible elements removed")
    assert v.n_frames == 300 and v.precision == 1.0  # Ψ is a part of Γ
    assert v.c[removed].mean() < v.c[np.setdiff1d(targets, removed)].mean()
