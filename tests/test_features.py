"""Simulated features (METRICS.md §5.1–5.2), checked against geometry worked out by hand."""

from __future__ import annotations

import itertools
import math

import numpy as np
import pytest

from sightplan.camera.models import EquirectangularCamera, PinholeCamera
from sightplan.engines import make_engine
from sightplan.engines.registry import available_engines
from sightplan.model.scene import ElementTable, Scene
from sightplan.observations.features import FeatureSet, sample_features

OFFSET = 0.001
BOTH = [pytest.param(e, marks=pytest.mark.skipif(e not in available_engines(), reason=e)) for e in ("embree", "trimesh")]


# --------------------------------------------------------------------------- geometry
def cube_mesh(origin=(0.0, 0.0, 0.0), size=1.0):
    """Closed cube, 12 triangles wound outward."""
    o = np.asarray(origin, float)
    v = np.array(list(itertools.product([0, 1], repeat=3)), float) * size + o  # index = 4x + 2y + z
    quads = [
        (0, 1, 3, 2),  # x = 0: (0,0,0),(0,0,1),(0,1,1),(0,1,0) → normal −x
        (4, 6, 7, 5),  # x = 1 → +x
        (0, 4, 5, 1),  # y = 0 → −y
        (2, 3, 7, 6),  # y = 1 → +y
        (0, 2, 6, 4),  # z = 0 → −z
        (1, 5, 7, 3),  # z = 1 → +z
    ]
    f = []
    for a, b, c, d in quads:
        f += [[a, b, c], [a, c, d]]
    return v, np.array(f)


def scene_of(meshes, is_target=None):
    vs, fs, fe = [], [], []
    off = 0
    for e, (v, f) in enumerate(meshes):
        vs.append(v)
        fs.append(f + off)
        fe += [e] * len(f)
        off += len(v)
    els = ElementTable.build([f"E{i}" for i in range(len(meshes))], is_target=is_target)
    return Scene.from_arrays(np.concatenate(vs), np.concatenate(fs), np.array(fe), els)


def test_cube_mesh_is_outward():
    v, f = cube_mesh()
    tri = v[f]
    n = np.cross(tri[:, 1] - tri[:, 0], tri[:, 2] - tri[:, 0])
    centroid = tri.mean(axis=1)
    assert (np.einsum("ij,ij->i", n, centroid - 0.5) > 0).all()


# --------------------------------------------------------------------------- corners
def corners_of(fs: FeatureSet):
    m = fs.kind == 0
    return fs.points[m], fs.normals[m], fs.element[m]


def test_unit_cube_corners_are_its_vertices():
    scene = scene_of([cube_mesh()])
    fs = sample_features(scene, density_per_m2=1.0, seed=0)
    pts, nrm, elem = corners_of(fs)
    assert len(pts) == 8
    got = {tuple(np.round(p, 9)) for p in pts}
    expected = set()
    for sx, sy, sz in itertools.product([0, 1], repeat=3):
        d = np.array([2 * sx - 1, 2 * sy - 1, 2 * sz - 1]) / math.sqrt(3)  # angle-weighted: 3 faces, 90° each
        expected.add(tuple(np.round(np.array([sx, sy, sz]) + OFFSET * d, 9)))
    assert got == expected
    # normals: the normalised diagonal pointing out of the cube
    for p, n in zip(pts, nrm):
        assert np.allclose(n, np.sign(p - 0.5) / math.sqrt(3))
    assert (elem == 0).all()


def test_unit_cube_surface_count_and_position():
    scene = scene_of([cube_mesh()])
    for density, n_expected in ((1.0, 6), (2.3, 14), (10.0, 60), (0.05, 0)):  # round(6 × density): 13.8 → 14, 0.3 → 0
        fs = sample_features(scene, density_per_m2=density, seed=3)
        assert np.count_nonzero(fs.kind == 1) == n_expected, density
        assert np.count_nonzero(fs.kind == 0) == 8
    fs = sample_features(scene, density_per_m2=50.0, seed=1)
    s = fs.kind == 1
    pts, nrm = fs.points[s], fs.normals[s]
    assert len(pts) == 300
    # normals are the winding (outward) face normals: ±unit axes
    assert np.allclose(np.abs(nrm).max(axis=1), 1.0) and np.allclose(np.linalg.norm(nrm, axis=1), 1.0)
    base = pts - OFFSET * nrm
    for p, n in zip(base, nrm):
        k = int(np.argmax(np.abs(n)))
        assert p[k] == pytest.approx(1.0 if n[k] > 0 else 0.0, abs=1e-12)
        others = [j for j in range(3) if j != k]
        assert (p[others] >= -1e-12).all() and (p[others] <= 1 + 1e-12).all()
    # every face gets some of the 300 points (1/6 each in expectation)
    faces = {(int(np.argmax(np.abs(n))), bool(n[np.argmax(np.abs(n))] > 0)) for n in nrm}
    assert len(faces) == 6
    assert (fs.element[s] == 0).all()


def test_corners_flag():
    scene = scene_of([cube_mesh()])
    fs = sample_features(scene, density_per_m2=10.0, seed=0, corners=False)
    assert len(fs) == 60 and (fs.kind == 1).all()


def test_seeded_sampling_reproducible():
    scene = scene_of([cube_mesh()])
    a = sample_features(scene, density_per_m2=20.0, seed=7)
    b = sample_features(scene, density_per_m2=20.0, seed=7)
    c = sample_features(scene, density_per_m2=20.0, seed=8)
    assert np.array_equal(a.points, b.points) and np.array_equal(a.normals, b.normals)
    assert np.array_equal(a.kind, b.kind) and np.array_equal(a.element, b.element)
    assert len(c) == len(a)
    sa, sc = a.kind == 1, c.kind == 1
    assert not np.allclose(a.points[sa], c.points[sc])
    # corners do not depend on the seed
    assert np.array_equal(a.points[~sa], c.points[~sc])


def test_surface_sampling_proportional_to_area():
    """Two flat elements of 1 m² and 3 m²: 3/4 of the points on the big one, uniform within it."""
    sq = (np.array([[0, 0, 0], [1, 0, 0], [1, 1, 0], [0, 1, 0]], float), np.array([[0, 1, 2], [0, 2, 3]]))
    big = (np.array([[2, 0, 0], [5, 0, 0], [5, 1, 0], [2, 1, 0]], float), np.array([[0, 1, 2], [0, 2, 3]]))
    scene = scene_of([sq, big])
    fs = sample_features(scene, density_per_m2=1000.0, seed=0)
    assert np.count_nonzero(fs.kind == 0) == 0  # flat: no corners
    assert len(fs) == 4000
    share_big = np.mean(fs.element == 1)
    assert share_big == pytest.approx(0.75, abs=0.03)  # σ ≈ 0.007
    on_big = fs.points[fs.element == 1]
    assert on_big[:, 0].mean() == pytest.approx(3.5, abs=0.06)  # uniform in x ∈ [2, 5]: σ_mean ≈ 0.016
    assert on_big[:, 1].mean() == pytest.approx(0.5, abs=0.03)
    assert np.allclose(fs.points[:, 2], OFFSET)  # normal +z, offset 1 mm


def test_two_touching_cubes_share_merged_corners():
    a = cube_mesh((0, 0, 0))
    b = cube_mesh((1, 0, 0))
    fs = sample_features(scene_of([a, b]), density_per_m2=0.0, seed=0)
    pts, nrm, elem = corners_of(fs)
    assert len(fs) == len(pts) == 8 + 8 - 4
    shared = np.isclose(pts[:, 0] - OFFSET * nrm[:, 0], 1.0)
    assert shared.sum() == 4
    # at a shared vertex the ±x faces of the two cubes cancel: normal (0, ±1, ±1)/√2, owner −1
    for p, n in zip(pts[shared], nrm[shared]):
        y, z = round(p[1]), round(p[2])
        exp_n = np.array([0.0, 2 * y - 1, 2 * z - 1]) / math.sqrt(2)
        assert np.allclose(n, exp_n)
        assert np.allclose(p, np.array([1.0, y, z]) + OFFSET * exp_n)
    assert (elem[shared] == -1).all()
    # the other corners keep their cube's diagonal normal and owner
    for p, n, e in zip(pts[~shared], nrm[~shared], elem[~shared]):
        x = round(p[0])
        assert x in (0, 2)
        assert e == (0 if x == 0 else 1)
        assert np.allclose(n, np.array([x - 1, 2 * round(p[1]) - 1, 2 * round(p[2]) - 1]) / math.sqrt(3))


def test_corners_merge_on_1mm_grid():
    """A gap of 0.2 mm between the cubes still merges their touching vertices (1 mm grid)."""
    a = cube_mesh((0, 0, 0))
    b = cube_mesh((1.0002, 0, 0))
    fs = sample_features(scene_of([a, b]), density_per_m2=0.0, seed=0)
    assert len(fs) == 12
    assert np.count_nonzero(fs.element == -1) == 4


def test_flat_subdivided_plane_has_no_corners():
    n = 4
    xs, ys = np.meshgrid(np.linspace(0, 2, n + 1), np.linspace(0, 3, n + 1))
    v = np.stack([xs.ravel(), ys.ravel(), np.zeros(xs.size)], axis=1)
    f = []
    for i in range(n):
        for j in range(n):
            a = i * (n + 1) + j
            f += [[a, a + 1, a + n + 2], [a, a + n + 2, a + n + 1]]
    scene = scene_of([(v, np.array(f))])
    fs = sample_features(scene, density_per_m2=5.0, seed=0)
    assert np.count_nonzero(fs.kind == 0) == 0
    assert len(fs) == round(2 * 3 * 5.0)
    assert np.allclose(fs.normals, [0, 0, 1]) and np.allclose(fs.points[:, 2], OFFSET)


def test_bent_plane_corners_only_on_the_fold():
    """Two squares folded by 40° (> 30°) along a shared edge: only the 2 fold vertices are corners;
    folded by 20° (< 30°): none."""
    for angle, n_corners in ((40.0, 2), (20.0, 0)):
        a = math.radians(angle)
        v = np.array([[0, 0, 0], [1, 0, 0], [1, 1, 0], [0, 1, 0],
                      [1 + math.cos(a), 0, math.sin(a)], [1 + math.cos(a), 1, math.sin(a)]], float)
        f = np.array([[0, 1, 2], [0, 2, 3], [1, 4, 5], [1, 5, 2]])
        fs = sample_features(scene_of([(v, f)]), density_per_m2=0.0, seed=0)
        pts, nrm, _ = corners_of(fs)
        assert len(pts) == n_corners, angle
        if n_corners:
            # angle-weighted: at each fold vertex both squares contribute 90° in all (one right angle, or two
            # 45° angles), so the normal is the bisector of (0, 0, 1) and the fold's (−sin a, 0, cos a)
            exp_n = np.array([-math.sin(a), 0, 1 + math.cos(a)])
            exp_n /= np.linalg.norm(exp_n)
            for p, n in zip(pts, nrm):
                assert np.allclose(n, exp_n)
                assert p[0] - OFFSET * n[0] == pytest.approx(1.0)


def test_featureset_save_load_round_trip(tmp_path):
    scene = scene_of([cube_mesh()])
    fs = sample_features(scene, density_per_m2=7.0, seed=5)
    path = tmp_path / "features.npz"
    fs.save(path)
    back = FeatureSet.load(path)
    assert np.array_equal(back.points, fs.points)
    assert np.array_equal(back.normals, fs.normals)
    assert np.array_equal(back.kind, fs.kind)
    assert np.array_equal(back.element, fs.element)
    assert back.params == fs.params
    assert back.key == fs.key
    # a hand-made set round-trips too
    hand = FeatureSet(np.array([[1.0, 2.0, 3.0]]), np.array([[0.0, 0.0, 1.0]]), np.array([1], np.int8),
                      np.array([4], np.int32), {"note": "hand"})
    hand.save(tmp_path / "hand.npz")
    h = FeatureSet.load(tmp_path / "hand.npz")
    assert np.array_equal(h.points, hand.points) and h.params == {"note": "hand"} and h.element[0] == 4


# --------------------------------------------------------------------------- visibility through an engine
R_NORTH = np.array([[1.0, 0.0, 0.0], [0.0, 0.0, 1.0], [0.0, -1.0, 0.0]])
CAM = PinholeCamera(160, 120, 100.0, 100.0, 80.0, 60.0)
ORIGIN = np.zeros(3)


def quad_y(y, x0, x1, z0, z1):
    return np.array([[x0, y, z0], [x1, y, z0], [x1, y, z1], [x0, y, z1]], float), np.array([[0, 1, 2], [0, 2, 3]])


# (point, normal, observed by the pinhole camera at the origin looking north, observed by a 360° camera there)
HAND_FEATURES = [
    ("on wall, facing camera", (1.0, 10 - OFFSET, 1.0), (0, -1, 0), True, True),
    ("on wall, back side", (1.0, 10 + OFFSET, 1.0), (0, 1, 0), False, False),
    ("floating, facing away", (2.0, 8.0, 0.0), (0, 1, 0), False, False),
    ("floating, facing camera", (2.0, 8.0, 0.5), (0, -1, 0), True, True),
    ("behind occluder", (0.1, 10 - OFFSET, 0.1), (0, -1, 0), False, False),
    ("outside image", (9.0, 9.0, 0.0), (0, -1, 0), False, True),  # x_img = 80 + 100·9/9 = 180 ≥ 160
    ("same pixel A", (2.001, 10 - OFFSET, -1.002), (0, -1, 0), True, True),
    ("same pixel B", (2.004, 10 - OFFSET, -1.005), (0, -1, 0), True, True),
    ("normal sideways, toward camera", (3.0, 10 - OFFSET, 0.0), (-1, 0, 0), True, True),  # n·(C−P) = 3 > 0
    ("normal sideways, away", (3.0, 10 - OFFSET, 0.3), (1, 0, 0), False, False),  # n·(C−P) = −3
    ("behind the camera", (0.0, -5.0, 0.0), (0, 1, 0), False, True),
    ("behind the wall", (-1.0, 12.0, 0.0), (0, -1, 0), False, False),
    ("0.3 mm behind wall", (-2.0, 10 + 0.0003, 2.0), (0, -1, 0), True, True),  # hit at d − 0.31 mm > d − 0.5 mm
    ("0.8 mm behind wall", (-2.0, 10 + 0.0008, 1.9), (0, -1, 0), False, False),  # hit at d − 0.83 mm
]


def hand_feature_set():
    pts = np.array([f[1] for f in HAND_FEATURES], float)
    nrm = np.array([f[2] for f in HAND_FEATURES], float)
    return FeatureSet(pts, nrm, np.ones(len(pts), np.int8), np.zeros(len(pts), np.int32), {})


def wall_scene():
    wall = quad_y(10.0, -5.0, 5.0, -3.0, 3.0)
    occ = quad_y(5.0, -0.5, 0.5, -0.5, 0.5)
    return scene_of([wall, occ], is_target=[True, False])


def test_same_pixel_features_share_a_pixel():
    def pix(p):
        return int(np.floor(80 + 100 * p[0] / p[1])), int(np.floor(60 - 100 * p[2] / p[1]))

    a, b = HAND_FEATURES[6][1], HAND_FEATURES[7][1]
    assert pix(a) == pix(b)


@pytest.mark.parametrize("engine", BOTH)
def test_feature_visibility_pinhole(engine):
    fs = hand_feature_set()
    eng = make_engine(engine, wall_scene(), features=fs)
    fo = eng.observe(CAM, R_NORTH, ORIGIN)
    got = set(np.asarray(fo.features).tolist())
    for i, (label, *_rest, exp, _eq) in enumerate(HAND_FEATURES):
        assert (i in got) == exp, label


@pytest.mark.parametrize("engine", BOTH)
def test_feature_visibility_equirect(engine):
    fs = hand_feature_set()
    eng = make_engine(engine, wall_scene(), features=fs)
    fo = eng.observe(EquirectangularCamera(64, 32), np.eye(3), ORIGIN)
    got = set(np.asarray(fo.features).tolist())
    for i, (label, *_rest, exp) in enumerate(HAND_FEATURES):
        assert (i in got) == exp, label


@pytest.mark.parametrize("engine", BOTH)
def test_feature_d_max(engine):
    fs = hand_feature_set()
    eng = make_engine(engine, wall_scene(), features=fs, d_max=9.0)
    got = set(np.asarray(eng.observe(CAM, R_NORTH, ORIGIN).features).tolist())
    # only "floating, facing camera" (distance √(4 + 64 + 0.25) ≈ 8.26 m) is within 9 m
    assert got == {3}


@pytest.mark.parametrize("engine", BOTH)
def test_feature_visibility_on_cube(engine):
    """Camera 5 m south of a unit cube looking north: the features seen are exactly the surface features of
    the −y face and the 4 corners with y = 0 (outward diagonal normals with a −y component)."""
    scene = scene_of([cube_mesh()])
    fs = sample_features(scene, density_per_m2=30.0, seed=2)
    eng = make_engine(engine, scene, features=fs)
    C = np.array([0.5, -5.0, 0.5])
    fo = eng.observe(CAM, R_NORTH, C)
    surf_front = (fs.kind == 1) & np.isclose(fs.normals[:, 1], -1.0)
    corner_front = (fs.kind == 0) & (fs.normals[:, 1] < 0)
    assert corner_front.sum() == 4 and surf_front.sum() > 5
    expected = set(np.flatnonzero(surf_front | corner_front).tolist())
    assert set(np.asarray(fo.features).tolist()) == expected


def test_corners_streamed_in_small_element_blocks_equal_one_block():
    """Sampled a few elements at a time, the corners (merged across elements) are those of one pass."""
    from sightplan.observations.features import corner_features, element_blocks

    scene = scene_of([cube_mesh((x, 0, 0)) for x in (0.0, 1.0, 1.0002, 3.0)])
    assert [len(b) for b in element_blocks(scene.face_element, 20)] == [12, 12, 12, 12]
    whole = corner_features(scene, block_faces=10**6)
    for block in (1, 20, 30):
        part = corner_features(scene, block_faces=block)
        np.testing.assert_allclose(part[0], whole[0], atol=1e-12)
        np.testing.assert_allclose(part[1], whole[1], atol=1e-6)
        assert np.array_equal(part[2], whole[2])
    assert len(whole[0]) == 20 and (whole[2] == -1).sum() == 8  # the two touching and the two coincident cubes
