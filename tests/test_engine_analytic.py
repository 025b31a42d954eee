"""Engines against geometry computed by hand (METRICS.md §1–2).

Every expected number here comes from an independent float64 ray caster written in this
file (pixel-centre rays against analytic rectangles), or from closed-form geometry — never
from sightplan's own helpers. Both engines run the small cases; embree also the large ones.
"""

from __future__ import annotations

import math

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st
from scipy import integrate

from sightplan.camera.models import EquirectangularCamera, PinholeCamera
from sightplan.engines import make_engine
from sightplan.engines.registry import available_engines
from sightplan.errors import ScheduleError
from sightplan.geometry.poses import R_from_gimbal
from sightplan.model.scene import ElementTable, Scene
from sightplan.observations.table import Observations

ENGINES = ["embree", "gl", "trimesh"]


def _engine_param(name: str):
    return pytest.param(name, marks=pytest.mark.skipif(name not in available_engines(), reason=f"{name} unavailable"))


ALL_ENGINES = [_engine_param(n) for n in ENGINES]
FAST_ENGINES = [_engine_param("embree"), _engine_param("gl")]  # the large frames: not the slow trimesh

# Camera looking north (+Y), image right = +X (east), image down = −Z. Columns of R are the
# camera's x, y, z axes in world coordinates.
R_NORTH = np.array([[1.0, 0.0, 0.0], [0.0, 0.0, 1.0], [0.0, -1.0, 0.0]])
ORIGIN = np.zeros(3)


# --------------------------------------------------------------------------- geometry
class Rect:
    """A rectangle ``centre ± e1 ± e2`` (half-extent vectors), two triangles, winding normal e1×e2."""

    def __init__(self, centre, e1, e2, element: int, flip: bool = False):
        self.c = np.asarray(centre, float)
        self.e1 = np.asarray(e1, float)
        self.e2 = np.asarray(e2, float)
        self.element = element
        self.flip = flip

    def mesh(self):
        c, a, b = self.c, self.e1, self.e2
        v = np.array([c - a - b, c + a - b, c + a + b, c - a + b])
        f = np.array([[0, 1, 2], [0, 2, 3]])
        if self.flip:
            f = f[:, ::-1]
        return v, f


def build_scene(rects: list[Rect], n_elements: int, **table) -> Scene:
    vs, fs, fe = [], [], []
    off = 0
    for r in rects:
        v, f = r.mesh()
        vs.append(v)
        fs.append(f + off)
        fe += [r.element] * len(f)
        off += len(v)
    els = ElementTable.build([f"E{i}" for i in range(n_elements)], **table)
    return Scene.from_arrays(np.concatenate(vs), np.concatenate(fs), np.array(fe), els)


def wall_y(y, x0, x1, z0, z1, element, flip=False) -> Rect:
    """Axis-aligned wall in the plane y = const; winding normal −Y (toward a camera south of it)."""
    c = [(x0 + x1) / 2, y, (z0 + z1) / 2]
    return Rect(c, [(x1 - x0) / 2, 0, 0], [0, 0, (z1 - z0) / 2], element, flip)  # (1,0,0)×(0,0,1) = (0,−1,0)


# --------------------------------------------------------------------------- rays
def pinhole_dirs_cam(cam: PinholeCamera) -> np.ndarray:
    """(H, W, 3) camera-frame ray directions through pixel centres (u+½, v+½)."""
    u = np.arange(cam.width) + 0.5
    v = np.arange(cam.height) + 0.5
    X, Y = np.meshgrid((u - cam.cx) / cam.fx, (v - cam.cy) / cam.fy)
    return np.stack([X, Y, np.ones_like(X)], axis=-1)


def equirect_dirs_cam(W: int, H: int) -> np.ndarray:
    lam = 2 * np.pi * (np.arange(W) + 0.5) / W - np.pi
    phi = np.pi / 2 - np.pi * (np.arange(H) + 0.5) / H
    L, P = np.meshgrid(lam, phi)
    return np.stack([np.cos(P) * np.sin(L), -np.sin(P), np.cos(P) * np.cos(L)], axis=-1)


def cast(rects: list[Rect], C, dirs_world: np.ndarray, axis_world: np.ndarray, d_max: float = 1000.0,
         edge_tol: float = 1e-6):
    """Independent float64 caster. dirs_world (N, 3) any length; axis_world (N, 3) unit optical axis a per ray.

    Returns element (N,) (−1 = nothing), distance (N,), theta (N,) degrees, ambiguous (N,) — rays within
    ``edge_tol`` metres of a rectangle's edge (where float32 engines may legitimately differ).
    """
    C = np.asarray(C, float)
    n_rays = len(dirs_world)
    best_t = np.full(n_rays, np.inf)
    elem = np.full(n_rays, -1)
    normal = np.zeros((n_rays, 3))
    amb = np.zeros(n_rays, bool)
    for r in rects:
        n = np.cross(r.e1, r.e2)
        denom = dirs_world @ n
        with np.errstate(divide="ignore", invalid="ignore"):
            t = ((r.c - C) @ n) / denom
        P = C + t[:, None] * dirs_world
        s1 = (P - r.c) @ r.e1 / (r.e1 @ r.e1)
        s2 = (P - r.c) @ r.e2 / (r.e2 @ r.e2)
        dist = t * np.linalg.norm(dirs_world, axis=1)
        ok = np.isfinite(t) & (t > 0) & (dist <= d_max)
        inside = ok & (np.abs(s1) <= 1) & (np.abs(s2) <= 1)
        near = ok & (np.minimum(np.abs(1 - np.abs(s1)) * np.linalg.norm(r.e1),
                                np.abs(1 - np.abs(s2)) * np.linalg.norm(r.e2)) < edge_tol)
        amb |= near & (np.abs(s1) <= 1 + 1e-3) & (np.abs(s2) <= 1 + 1e-3)
        closer = inside & (t < best_t)
        best_t[closer] = t[closer]
        elem[closer] = r.element
        normal[closer] = n / np.linalg.norm(n)
    dist = best_t * np.linalg.norm(dirs_world, axis=1)
    # n_p oriented toward the camera, θ = arccos(clamp(n_p·(−a), 0, 1))
    sgn = np.where(np.einsum("ij,ij->i", normal, dirs_world) > 0, -1.0, 1.0)
    n_p = normal * sgn[:, None]
    cos = np.clip(np.einsum("ij,ij->i", n_p, -axis_world), 0, 1)
    theta = np.degrees(np.arccos(cos))
    return elem, dist, theta, amb


def cast_pinhole(rects, cam: PinholeCamera, R, C, d_max=1000.0):
    d = pinhole_dirs_cam(cam).reshape(-1, 3) @ np.asarray(R).T
    a = np.broadcast_to(np.asarray(R)[:, 2], d.shape)
    return cast(rects, C, d, a, d_max)


def expected_stats(elem, dist, theta, element):
    m = elem == element
    return int(m.sum()), float(dist[m].mean()) if m.any() else math.nan, float(theta[m].mean()) if m.any() else math.nan


def obs_of(fo, element):
    """(count, depth_mean, angle_mean) of one element in a FrameObservation (count 0 when absent)."""
    idx = np.flatnonzero(np.asarray(fo.element) == element)
    if len(idx) == 0:
        return 0, math.nan, math.nan
    assert len(idx) == 1, "an element appears twice in one frame"
    j = idx[0]
    return int(fo.count[j]), float(fo.depth_mean[j]), float(fo.angle_mean[j])


# --------------------------------------------------------------------------- fixtures
CAM = PinholeCamera(160, 120, 100.0, 100.0, 80.0, 60.0)
CAM_BIG = PinholeCamera(1600, 1200, 1000.0, 1000.0, 800.0, 600.0)
# wall at y = 10 m; projected edges x_img = 80 + 10·x → 49.7 … 120.7, y_img = 60 − 10·z → 44.7 … 80.2
WALL = dict(y=10.0, x0=-3.03, x1=4.07, z0=-2.02, z1=1.53)


def test_wall_helper_winding():
    """The hand-built wall has its winding normal toward −Y (toward a camera south of it)."""
    r = wall_y(element=0, **WALL)
    v, f = r.mesh()
    n = np.cross(v[f[0, 1]] - v[f[0, 0]], v[f[0, 2]] - v[f[0, 0]])
    assert n[1] < 0 and abs(n[0]) < 1e-12 and abs(n[2]) < 1e-12


def test_wall_count_closed_form():
    """The caster agrees with counting pixel centres between the projected edges."""
    u = np.arange(160) + 0.5
    v = np.arange(120) + 0.5
    nx = np.count_nonzero((u >= 80 + 10 * WALL["x0"]) & (u <= 80 + 10 * WALL["x1"]))
    ny = np.count_nonzero((v >= 60 - 10 * WALL["z1"]) & (v <= 60 - 10 * WALL["z0"]))
    assert (nx, ny) == (71, 35)  # u = 50..120, v = 45..79
    elem, *_ = cast_pinhole([wall_y(element=0, **WALL)], CAM, R_NORTH, ORIGIN)
    assert np.count_nonzero(elem == 0) == 71 * 35


@pytest.mark.parametrize("engine", ALL_ENGINES)
@pytest.mark.parametrize("flip", [False, True], ids=["front", "back"])
def test_head_on_wall(engine, flip):
    rects = [wall_y(element=0, flip=flip, **WALL)]
    scene = build_scene(rects, 1)
    eng = make_engine(engine, scene)
    fo = eng.observe(CAM, R_NORTH, ORIGIN)
    elem, dist, theta, amb = cast_pinhole(rects, CAM, R_NORTH, ORIGIN)
    assert not amb.any()
    n, d, _ = expected_stats(elem, dist, theta, 0)
    assert n == 71 * 35
    count, depth, angle = obs_of(fo, 0)
    assert count == n
    assert depth == pytest.approx(d, rel=1e-6)
    assert depth > 10.0  # Euclidean distance, not depth along the axis (which is exactly 10)
    assert angle == pytest.approx(0.0, abs=1e-3)
    assert fo.pixel_scale == 1.0
    assert fo.sampling_focal_px == pytest.approx(100.0)
    # SSD ρ = d̄ / f_px
    obs = Observations.from_frames([fo], np.array([True]), np.array([True]), 0)
    assert obs.ssd[0] == pytest.approx(d / 100.0, rel=1e-6)
    eng.close()


@pytest.mark.parametrize("engine", FAST_ENGINES)
def test_head_on_wall_large(engine):
    rects = [wall_y(element=0, y=10.0, x0=-3.0303, x1=4.0707, z0=-2.0202, z1=1.5303)]
    scene = build_scene(rects, 1)
    eng = make_engine(engine, scene)
    fo = eng.observe(CAM_BIG, R_NORTH, ORIGIN)
    elem, dist, theta, amb = cast_pinhole(rects, CAM_BIG, R_NORTH, ORIGIN)
    assert not amb.any()
    n, d, _ = expected_stats(elem, dist, theta, 0)
    # x_img = 800 + 100·x: 496.97 … 1207.07 → 710 columns; y_img = 600 − 100·z: 446.97 … 802.02 → 355 rows
    assert n == 710 * 355
    count, depth, angle = obs_of(fo, 0)
    assert count == n
    assert depth == pytest.approx(d, rel=1e-6)
    assert angle == pytest.approx(0.0, abs=1e-3)
    assert fo.sampling_focal_px == pytest.approx(1000.0)


@pytest.mark.parametrize("engine", ALL_ENGINES)
def test_off_centre_principal_point_nonsquare(engine):
    """fx ≠ fy and an off-centre principal point: count by hand, ρ uses √(fx·fy)."""
    cam = PinholeCamera(160, 120, 120.0, 90.0, 70.3, 64.1)
    rects = [wall_y(element=0, **WALL)]
    eng = make_engine(engine, build_scene(rects, 1))
    fo = eng.observe(cam, R_NORTH, ORIGIN)
    elem, dist, theta, amb = cast_pinhole(rects, cam, R_NORTH, ORIGIN)
    assert not amb.any()
    u = np.arange(160) + 0.5
    v = np.arange(120) + 0.5
    nx = np.count_nonzero((u >= 70.3 + 12 * WALL["x0"]) & (u <= 70.3 + 12 * WALL["x1"]))
    ny = np.count_nonzero((v >= 64.1 - 9 * WALL["z1"]) & (v <= 64.1 - 9 * WALL["z0"]))
    n, d, _ = expected_stats(elem, dist, theta, 0)
    assert n == nx * ny
    count, depth, _ = obs_of(fo, 0)
    assert count == n
    assert depth == pytest.approx(d, rel=1e-6)
    assert fo.sampling_focal_px == pytest.approx(math.sqrt(120.0 * 90.0))


@pytest.mark.parametrize("engine", ALL_ENGINES)
@pytest.mark.parametrize("tilt", [20.0, 55.0, -35.0])
def test_tilted_wall_theta_equals_tilt(engine, tilt):
    """A wall turned by α about the vertical axis, seen on-axis: θ_p = |α| at every pixel."""
    a = math.radians(tilt)
    rect = Rect([0.3, 10.0, 0.2], [3.013 * math.cos(a), 3.013 * math.sin(a), 0], [0, 0, 1.517], 0)
    scene = build_scene([rect], 1)
    eng = make_engine(engine, scene)
    fo = eng.observe(CAM, R_NORTH, ORIGIN)
    elem, dist, theta, amb = cast_pinhole([rect], CAM, R_NORTH, ORIGIN)
    assert np.allclose(theta[elem == 0], abs(tilt))
    n, d, th = expected_stats(elem, dist, theta, 0)
    n_amb = int(amb.sum())
    count, depth, angle = obs_of(fo, 0)
    assert abs(count - n) <= n_amb
    assert depth == pytest.approx(d, rel=1e-3 if n_amb else 1e-6)
    assert angle == pytest.approx(abs(tilt), abs=1e-3)


@pytest.mark.parametrize("engine", ALL_ENGINES)
def test_off_axis_camera_facing_surface_is_clamped_to_90(engine):
    """Pixels seeing a wall whose camera-facing normal points away from −a count θ = 90°.

    Camera looks north; a wall in the plane x = 3 (normal ±X) seen obliquely on the right of
    the image: n_p = (−1, 0, 0) (toward the camera), −a = (0, −1, 0): n_p·(−a) = 0 → θ = 90°.
    A wall turned by 100° from head-on: n_p·(−a) = cos(100°) < 0 → clamped → θ = 90°.
    """
    side = Rect([3.0, 10.0, 0.0], [0, 4.0, 0], [0, 0, 2.0], 0)
    a = math.radians(100.0)
    # normal of e1×e2 = (sin a, −cos a, 0) = (0.985, 0.174, 0): seen from the origin through the left part
    turned = Rect([-3.0, 10.0, 0.0], [2.0 * math.cos(a), 2.0 * math.sin(a), 0], [0, 0, 2.0], 1)
    rects = [side, turned]
    eng = make_engine(engine, build_scene(rects, 2))
    fo = eng.observe(CAM, R_NORTH, ORIGIN)
    elem, dist, theta, amb = cast_pinhole(rects, CAM, R_NORTH, ORIGIN)
    for e in (0, 1):
        n, d, th = expected_stats(elem, dist, theta, e)
        assert n > 50 and th == pytest.approx(90.0)
        count, depth, angle = obs_of(fo, e)
        assert abs(count - n) <= amb.sum()
        assert angle == pytest.approx(90.0, abs=1e-3)
        assert depth == pytest.approx(d, rel=1e-3)


@pytest.mark.parametrize("engine", ALL_ENGINES)
def test_occluder_hides_exactly_its_projection(engine):
    wall = wall_y(element=0, **WALL)
    # occluder at y = 5: x_img = 80 + 20·x, y_img = 60 − 20·z → x ∈ [−0.513, 0.722] → 69.74 … 94.44 (24 columns: 70.5 … 93.5),
    # z ∈ [−0.398, 0.283] → 54.34 … 67.96 (14 rows); fully in front of the wall's projection
    occ = wall_y(element=1, y=5.0, x0=-0.513, x1=0.722, z0=-0.398, z1=0.283)
    rects = [wall, occ]
    eng = make_engine(engine, build_scene(rects, 2, is_target=[True, False]))
    fo = eng.observe(CAM, R_NORTH, ORIGIN)
    occ_px = 24 * 14
    elem, dist, theta, amb = cast_pinhole(rects, CAM, R_NORTH, ORIGIN)
    assert not amb.any()
    n0, d0, _ = expected_stats(elem, dist, theta, 0)
    n1, d1, _ = expected_stats(elem, dist, theta, 1)
    assert (n0, n1) == (71 * 35 - occ_px, occ_px)
    c0, dd0, _ = obs_of(fo, 0)
    c1, dd1, a1 = obs_of(fo, 1)
    assert (c0, c1) == (n0, n1)
    assert dd0 == pytest.approx(d0, rel=1e-6)
    assert dd1 == pytest.approx(d1, rel=1e-6)
    assert a1 == pytest.approx(0.0, abs=1e-3)


@pytest.mark.parametrize("engine", ALL_ENGINES)
def test_back_face_counts_the_same(engine):
    """Seen from behind (camera north of the wall looking south) the wall counts the same."""
    rects = [wall_y(element=0, **WALL)]
    eng = make_engine(engine, build_scene(rects, 1))
    # camera at y = 20 looking south: right = −X, down = −Z, forward = −Y
    R_south = np.array([[-1.0, 0.0, 0.0], [0.0, 0.0, -1.0], [0.0, -1.0, 0.0]])
    C = np.array([0.5, 20.0, 0.0])
    fo = eng.observe(CAM, R_south, C)
    elem, dist, theta, amb = cast_pinhole(rects, CAM, R_south, C)
    assert not amb.any()
    n, d, _ = expected_stats(elem, dist, theta, 0)
    # x_img = 80 − 10·(x − 0.5): x ∈ [−3.03, 4.07] → 44.3 … 115.3 → 71 columns; rows as before: 35
    assert n == 71 * 35
    count, depth, angle = obs_of(fo, 0)
    assert count == n
    assert depth == pytest.approx(d, rel=1e-6)
    assert angle == pytest.approx(0.0, abs=1e-3)


@pytest.mark.parametrize("engine", ALL_ENGINES)
def test_d_max(engine):
    rects = [wall_y(element=0, **WALL)]
    scene = build_scene(rects, 1)
    # the whole wall is farther than 9.9 m
    fo = make_engine(engine, scene, d_max=9.9).observe(CAM, R_NORTH, ORIGIN)
    assert obs_of(fo, 0)[0] == 0
    # default d_max = 1000 m: a wall 1200 m away is not seen, one 900 m away is
    far = build_scene([wall_y(element=0, y=1200.0, x0=-300.3, x1=300.7, z0=-200.3, z1=200.7)], 1)
    assert obs_of(make_engine(engine, far).observe(CAM, R_NORTH, ORIGIN), 0)[0] == 0
    near = build_scene([wall_y(element=0, y=900.0, x0=-300.3, x1=300.7, z0=-200.3, z1=200.7)], 1)
    assert obs_of(make_engine(engine, near).observe(CAM, R_NORTH, ORIGIN), 0)[0] > 0
    # a d_max cutting through the wall: d_max is a Euclidean distance, so only pixels whose
    # ray distance (not axial depth) is ≤ d_max count
    d_cut = 10.3
    elem, dist, theta, _ = cast_pinhole(rects, CAM, R_NORTH, ORIGIN, d_max=d_cut)
    elem_all, dist_all, *_ = cast_pinhole(rects, CAM, R_NORTH, ORIGIN)
    assert np.min(np.abs(dist_all[elem_all == 0] - d_cut)) > 1e-4  # no pixel on the boundary
    n, d, _ = expected_stats(elem, dist, theta, 0)
    assert 0 < n < 71 * 35
    count, depth, _ = obs_of(make_engine(engine, scene, d_max=d_cut).observe(CAM, R_NORTH, ORIGIN), 0)
    assert count == n
    assert depth == pytest.approx(d, rel=1e-6)


@pytest.mark.parametrize("engine", ALL_ENGINES)
def test_schedule_element_built_after_capture_neither_counts_nor_occludes(engine):
    wall = wall_y(element=0, **WALL)
    occ = wall_y(element=1, y=5.0, x0=-0.513, x1=0.722, z0=-0.398, z1=0.283)
    scene = build_scene([wall, occ], 2, finish=["2024-03-01", "2024-06-01"])
    before = scene.at("2024-05-01")
    assert list(before.present) == [True, False]
    fo = make_engine(engine, before).observe(CAM, R_NORTH, ORIGIN)
    assert obs_of(fo, 0)[0] == 71 * 35
    assert obs_of(fo, 1)[0] == 0
    after = scene.at("2024-06-01")  # built on the capture day: exists at the end of it
    fo = make_engine(engine, after).observe(CAM, R_NORTH, ORIGIN)
    assert obs_of(fo, 0)[0] == 71 * 35 - 24 * 14
    assert obs_of(fo, 1)[0] == 24 * 14
    # start basis: the occluder started before the capture
    started = build_scene([wall, occ], 2, start=["2024-01-01", "2024-04-01"], finish=["2024-03-01", "2024-06-01"])
    fo = make_engine(engine, started.at("2024-05-01", basis="start")).observe(CAM, R_NORTH, ORIGIN)
    assert obs_of(fo, 1)[0] == 24 * 14
    # nothing built yet
    with pytest.raises(ScheduleError):
        scene.at("2024-01-01")


def test_unscheduled_elements():
    wall = wall_y(element=0, **WALL)
    occ = wall_y(element=1, y=5.0, x0=-0.513, x1=0.722, z0=-0.398, z1=0.283)
    scene = build_scene([wall, occ], 2, finish=["2024-03-01", None])
    assert list(scene.at("2024-05-01").present) == [True, True]
    assert list(scene.at("2024-05-01", unscheduled="absent").present) == [True, False]


# --------------------------------------------------------------------------- equirectangular cube
def cube_rects(centre, half=1.0, inward=False) -> list[Rect]:
    """Six faces, face (axis k, sign s) is element 2k + (s > 0); outward winding unless ``inward``."""
    rects = []
    eye = np.eye(3)
    for k in range(3):
        for s in (-1, 1):
            e1, e2 = eye[(k + 1) % 3] * half, eye[(k + 2) % 3] * half  # e1×e2 = +e_k
            if s < 0:
                e1, e2 = e2, e1
            if inward:
                e1, e2 = e2, e1
            rects.append(Rect(np.asarray(centre) + s * half * eye[k], e1, e2, 2 * k + (s > 0)))
    return rects


def equirect_expected(rects, W, H, R, C):
    d_cam = equirect_dirs_cam(W, H).reshape(-1, 3)
    d_world = d_cam @ R.T
    k = np.argmax(np.abs(d_cam), axis=1)
    a_cam = np.zeros_like(d_cam)
    a_cam[np.arange(len(k)), k] = np.sign(d_cam[np.arange(len(k)), k])
    a_world = a_cam @ R.T
    elem, dist, theta, amb = cast(rects, C, d_world, a_world, edge_tol=1e-5)
    # rays whose two largest |components| are nearly tied: the cube face of the ray is ambiguous
    srt = np.sort(np.abs(d_cam), axis=1)
    amb_axis = (srt[:, 2] - srt[:, 1]) < 1e-5
    return elem, dist, theta, amb, amb_axis, k


@pytest.mark.parametrize("inward", [False, True], ids=["outward", "inward"])
@pytest.mark.parametrize("engine,H", [("trimesh", 48), ("embree", 48), ("embree", 400)])
def test_equirect_cube_from_centre(engine, H, inward):
    if engine not in available_engines():
        pytest.skip(engine)
    W = 2 * H
    C = np.array([2.0, -1.0, 3.0])
    rects = cube_rects(C, half=1.5, inward=inward)
    scene = build_scene(rects, 6)
    cam = EquirectangularCamera(W, H)
    R = np.eye(3)  # camera axes = world axes
    fo = make_engine(engine, scene).observe(cam, R, C)
    # own classification: the face hit is the axis of the largest |component| of the ray
    d = equirect_dirs_cam(W, H).reshape(-1, 3)
    k = np.argmax(np.abs(d), axis=1)
    s = np.sign(d[np.arange(len(d)), k]) > 0
    face = 2 * k + s
    srt = np.sort(np.abs(d), axis=1)
    n_amb = int(np.count_nonzero(srt[:, 2] - srt[:, 1] < 1e-5))
    expected = np.bincount(face, minlength=6)
    assert expected.sum() == W * H
    got = np.array([obs_of(fo, e)[0] for e in range(6)])
    assert (got > 0).all()
    assert got.sum() == W * H  # every ray hits the closed cube
    assert np.abs(got - expected).max() <= n_amb
    # cross-check with the independent caster and the distances
    elem, dist, theta, amb, _, _ = equirect_expected(rects, W, H, R, C)
    assert np.abs(np.bincount(elem, minlength=6) - expected).max() <= amb.sum()
    for e in range(6):
        c, dep, ang = obs_of(fo, e)
        assert dep == pytest.approx(dist[elem == e].mean(), rel=1e-3 if n_amb else 1e-6)
        # from the exact centre every ray falls in the cube face it hits: θ = 0 everywhere
        assert ang == pytest.approx(0.0, abs=1e-3)
    assert fo.sampling_focal_px == pytest.approx(W / (2 * math.pi))
    # shares from the (λ, φ) areas: pixels are uniform in (λ, φ) over [−π, π] × [−π/2, π/2]
    if H >= 400:
        top_area, _ = integrate.quad(lambda lam: math.pi / 2 - math.atan(max(abs(math.sin(lam)), abs(math.cos(lam)))),
                                     -math.pi, math.pi, points=[-3 * math.pi / 4, -math.pi / 4, math.pi / 4, 3 * math.pi / 4])
        front_area, _ = integrate.quad(lambda lam: 2 * math.atan(math.cos(lam)), -math.pi / 4, math.pi / 4)
        assert 2 * top_area + 4 * front_area == pytest.approx(2 * math.pi**2, rel=1e-9)
        # camera −Y is up (φ > 0): world −Y face is element 2; +Z (forward) is element 5
        assert got[2] == pytest.approx(W * H * top_area / (2 * math.pi**2), rel=5e-3)
        assert got[3] == pytest.approx(W * H * top_area / (2 * math.pi**2), rel=5e-3)
        for e in (0, 1, 4, 5):
            assert got[e] == pytest.approx(W * H * front_area / (2 * math.pi**2), rel=5e-3)


@pytest.mark.parametrize("rotated", [False, True], ids=["aligned", "rotated"])
@pytest.mark.parametrize("engine,H", [("trimesh", 48), ("embree", 48), ("embree", 300)])
def test_equirect_cube_off_centre(engine, H, rotated):
    """Off-centre inside a cube. Camera axes aligned with the cube: θ_p is 0° where the ray's cube-face
    axis matches the hit wall, else 90° (the wall's normal is then perpendicular to that axis). Rotated
    camera: θ_p from the own caster. Counts and θ̄ from the own caster."""
    if engine not in available_engines():
        pytest.skip(engine)
    W = 2 * H
    centre = np.array([0.0, 0.0, 0.0])
    rects = cube_rects(centre, half=2.0)
    scene = build_scene(rects, 6)
    C = np.array([0.61, -0.43, 0.27])
    R = R_from_gimbal(30.0, 10.0, 0.0)[0] if rotated else np.eye(3)
    cam = EquirectangularCamera(W, H)
    fo = make_engine(engine, scene).observe(cam, R, C)
    elem, dist, theta, amb, amb_axis, _ = equirect_expected(rects, W, H, R, C)
    if not rotated:
        assert set(np.unique(np.round(theta, 6))) <= {0.0, 90.0}
    assert (elem >= 0).all()
    for e in range(6):
        m = elem == e
        n = int(m.sum())
        n_amb = int((amb & m).sum()) + int((amb_axis & m).sum())
        c, dep, ang = obs_of(fo, e)
        assert abs(c - n) <= int(amb.sum())
        exp_theta = theta[m].mean()
        assert ang == pytest.approx(exp_theta, abs=90.0 * (n_amb + abs(c - n) + 1e-9) / n + 1e-3)
        assert dep == pytest.approx(dist[m].mean(), rel=1e-3)
    assert 0 < np.mean(theta) < 90  # the case does mix both values


# --------------------------------------------------------------------------- resolution scale
@pytest.mark.parametrize("engine", ALL_ENGINES)
def test_resolution_scale_half(engine):
    rects = [wall_y(element=0, **WALL)]
    eng = make_engine(engine, build_scene(rects, 1))
    fo = eng.observe(CAM, R_NORTH, ORIGIN, scale=0.5)
    assert fo.pixel_scale == pytest.approx(4.0)
    assert fo.sampling_focal_px == pytest.approx(100.0)  # the full-resolution camera's
    half = PinholeCamera(80, 60, 50.0, 50.0, 40.0, 30.0)
    elem, dist, theta, amb = cast_pinhole(rects, half, R_NORTH, ORIGIN)
    assert not amb.any()
    n_half, d_half, _ = expected_stats(elem, dist, theta, 0)
    # x_img = 40 + 5·x: 24.85 … 60.35 → u = 25..59 (35); y_img = 30 − 5·z: 22.35 … 40.1 → v = 22..39 (18)
    assert n_half == 35 * 18
    count, depth, _ = obs_of(fo, 0)
    assert count == n_half
    assert depth == pytest.approx(d_half, rel=1e-6)
    full = 71 * 35
    # within one rendered row/column: a scaled pixel is 2 × 2 full-resolution pixels
    assert abs(count * fo.pixel_scale - full) <= 2 * (71 + 35) + 4


@pytest.mark.parametrize("engine", ALL_ENGINES)
def test_resolution_scale_equirect(engine):
    """A 360° frame at scale ½: 4 full-resolution pixels per rendered pixel; counts match the half-size grid."""
    C = np.array([0.3, 0.2, -0.1])
    rects = cube_rects(np.zeros(3), half=2.0)
    eng = make_engine(engine, build_scene(rects, 6))
    fo = eng.observe(EquirectangularCamera(96, 48), np.eye(3), C, scale=0.5)
    assert fo.pixel_scale == pytest.approx(4.0)
    assert fo.sampling_focal_px == pytest.approx(96 / (2 * math.pi))
    elem, dist, theta, amb, _, _ = equirect_expected(rects, 48, 24, np.eye(3), C)
    got = np.array([obs_of(fo, e)[0] for e in range(6)])
    assert np.abs(got - np.bincount(elem, minlength=6)).max() <= amb.sum()


@pytest.mark.parametrize("engine", ALL_ENGINES)
def test_far_from_origin_coordinates(engine):
    """Georeferenced-size coordinates (≈ 5·10⁶ m): counts and distances are unchanged."""
    shift = np.array([512345.67, 5432109.87, 312.5])
    rects = [wall_y(element=0, **WALL)]
    moved = [Rect(r.c + shift, r.e1, r.e2, r.element) for r in rects]
    fo = make_engine(engine, build_scene(moved, 1)).observe(CAM, R_NORTH, shift)
    elem, dist, theta, _ = cast_pinhole(rects, CAM, R_NORTH, ORIGIN)
    n, d, _ = expected_stats(elem, dist, theta, 0)
    count, depth, angle = obs_of(fo, 0)
    assert count == n == 71 * 35
    assert depth == pytest.approx(d, abs=1e-3)
    assert angle == pytest.approx(0.0, abs=1e-2)


@pytest.mark.parametrize("engine", FAST_ENGINES)
def test_resolution_scale_large(engine):
    rects = [wall_y(element=0, y=10.0, x0=-3.0303, x1=4.0707, z0=-2.0202, z1=1.5303)]
    eng = make_engine(engine, build_scene(rects, 1))
    fo_full = eng.observe(CAM_BIG, R_NORTH, ORIGIN)
    fo = eng.observe(CAM_BIG, R_NORTH, ORIGIN, scale=0.25)
    assert fo.pixel_scale == pytest.approx(16.0)
    full = obs_of(fo_full, 0)[0]
    c = obs_of(fo, 0)[0]
    assert abs(c * 16 - full) <= 4 * (710 + 355) + 16
    assert obs_of(fo, 0)[1] == pytest.approx(obs_of(fo_full, 0)[1], rel=1e-3)


# --------------------------------------------------------------------------- engines agree
BIG_WALL = [wall_y(element=0, y=20.0, x0=-25.0, x1=25.0, z0=-15.0, z1=15.0)]
SMALL_CAM = PinholeCamera(64, 48, 50.0, 50.0, 32.0, 24.0)


@pytest.fixture(scope="module")
def both_engines():
    if not {"embree", "trimesh"} <= set(available_engines()):
        pytest.skip("needs both engines")
    scene = build_scene(BIG_WALL, 1)
    return make_engine("embree", scene), make_engine("trimesh", scene)


@settings(max_examples=15, deadline=None, suppress_health_check=[HealthCheck.function_scoped_fixture])
@given(
    x=st.floats(-5, 5), y=st.floats(0, 12), z=st.floats(-3, 3),
    heading=st.floats(-35, 35), pitch=st.floats(-25, 25), roll=st.floats(-30, 30),
)
def test_engines_agree_random_poses(both_engines, x, y, z, heading, pitch, roll):
    emb, tri = both_engines
    R = R_from_gimbal(heading, pitch, roll)[0]
    C = np.array([x, y, z])
    fe = emb.observe(SMALL_CAM, R, C)
    ft = tri.observe(SMALL_CAM, R, C)
    elem, dist, theta, amb = cast_pinhole(BIG_WALL, SMALL_CAM, R, C)
    n, d, th = expected_stats(elem, dist, theta, 0)
    ce, de, ae = obs_of(fe, 0)
    ct, dt, at = obs_of(ft, 0)
    tol = max(1, int(amb.sum()) + 1, int(0.002 * n))
    assert abs(ce - ct) <= tol
    assert abs(ce - n) <= tol and abs(ct - n) <= tol
    if n:
        if ce == ct == n:
            assert de == pytest.approx(dt, rel=1e-4)
            assert de == pytest.approx(d, rel=1e-4)
            assert ae == pytest.approx(th, abs=1e-2)
            assert at == pytest.approx(th, abs=1e-2)
        else:
            assert de == pytest.approx(dt, rel=1e-2)
