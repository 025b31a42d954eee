"""The fast paths give the numbers of the plain ones.

- Features: the frustum-culled feature test with Embree's occlusion query finds exactly
  the features of the brute-force test (every feature projected, one first-hit ray per
  candidate), so ν_f and T are the same.
- The cast: sightplan's 8-ray packets through its own Embree binding hit the triangles
  that embreex's one-ray-at-a-time ``rtcIntersect1`` hits on the same rays.
- The feature set is sampled once per scene and read back from the cache.
"""

from __future__ import annotations

import numpy as np
import pytest

from sightplan.camera.models import EquirectangularCamera, PinholeCamera
from sightplan.engines import kernels, make_engine
from sightplan.engines.embree import EmbreeEngine
from sightplan.engines.featurecull import FeatureIndex
from sightplan.evaluate import EvaluationSettings, evaluate
from sightplan.geometry.poses import R_from_gimbal
from sightplan.metrics import MetricParams
from sightplan.observations.features import cached_features, sample_features
from sightplan.plan.ring import ring_plan


@pytest.fixture(scope="module")
def features(duplex):
    return sample_features(duplex, 1.0, seed=5)


@pytest.fixture(scope="module")
def engine(duplex, features):
    with make_engine("embree", duplex, features, threads=2) as e:
        yield e


CAMERA = PinholeCamera(400, 300, 330, 330, 200, 150, "test")


@pytest.mark.parametrize("split", [False, True], ids=["one-pass", "threads"])
def test_culled_features_equal_the_brute_force_test(duplex, engine, split, monkeypatch):
    from sightplan.engines import featurecull

    # the Duplex has fewer blocks than the threshold above which the frustum pass is split over the engine's threads
    monkeypatch.setattr(featurecull, "PARALLEL_BLOCKS", 0 if split else 10**9)
    plan = ring_plan(duplex, CAMERA, n_frames=12, distance_m=6)
    lo, hi = duplex.bounds()
    poses = [(CAMERA, plan.R_world_camera[i], plan.C_world[i]) for i in range(len(plan))]
    # inside the house, 360°, and a pinhole looking straight down from above
    poses.append((EquirectangularCamera(64, 32, "pano"), R_from_gimbal(30, 0)[0], (lo + hi) / 2))
    poses.append((CAMERA, R_from_gimbal(0, -90)[0], np.r_[(lo + hi)[:2] / 2, hi[2] + 15]))
    seen = 0
    for cam, R, C in poses:
        fast = engine.visible_features(cam, R, C)
        reference = engine.visible_features_reference(cam, R, C)
        np.testing.assert_array_equal(fast, reference)
        seen += len(fast)
    assert seen > 2000  # the frames really see features


SITE_FAR_AWAY = np.array([512345.6, 5412345.7, 120.0])  # projected coordinates (UTM metres), as IFC sites give them


@pytest.mark.parametrize("origin", [np.zeros(3), SITE_FAR_AWAY], ids=["at the origin", "5,400 km from it"])
def test_one_ray_per_block_proves_the_features_behind_a_wall_hidden(origin):
    """A 20 × 10 m wall (two triangles) 5 m north of the cameras and a post before it; 30,000 features behind the
    wall, some seen past its edges, some within a millimetre of its back, and 3,000 before it. The features each
    block's one ray proves hidden (at least 1 mm beyond the triangle it hits, the sight line 0.1 mm inside its
    edges) cast no ray of their own; the set seen is still exactly that of one ray per feature. The same far from
    the origin, where a float32 coordinate's step is half a metre: the per-feature pass takes its points relative
    to their block."""
    from sightplan.observations.features import FeatureSet
    from test_engine_analytic import R_NORTH, build_scene, wall_y

    x, y, z = origin
    scene = build_scene([wall_y(y + 5.0, x - 10.0, x + 10.0, z - 5.0, z + 5.0, 0),
                         wall_y(y + 3.0, x - 0.5, x + 0.5, z - 5.0, z + 5.0, 1)], 2)
    rng = np.random.default_rng(3)
    behind = rng.uniform([-14.0, 5.0005, -7.0], [14.0, 12.0, 7.0], (30000, 3))
    behind[:2000, 1] = 5.0 + rng.uniform(0.0002, 0.0015, 2000)  # on its back face, within the proof's margin or not
    before = rng.uniform([-6.0, 1.0, -3.0], [6.0, 4.9, 3.0], (3000, 3))
    local = np.concatenate([behind, before])
    points = local + origin
    normals = np.tile([0.0, -1.0, 0.0], (len(points), 1))
    fs = FeatureSet(points, normals, np.zeros(len(points), np.int8), np.full(len(points), -1, np.int32), {})
    camera = PinholeCamera(640, 480, 400, 400, 320, 240, "wide")
    with make_engine("embree", scene, fs, threads=1) as engine:
        cover = engine.occluders
        for C in ([0.0, 0.0, 0.0], [3.0, -2.0, 1.0], [-2.0, -8.0, -2.0]):
            C = np.asarray(C) + origin
            fast = engine.visible_features(camera, R_NORTH, C)
            np.testing.assert_array_equal(fast, engine.visible_features_reference(camera, R_NORTH, C))
            args = (C, R_NORTH, camera.width, camera.height, camera.fx, camera.fy, camera.cx, camera.cy, engine.d_max)
            every = set(engine.feature_index.candidates(*args)[0].tolist())
            rays = set(engine.feature_index.candidates(*args, cover=cover)[0].tolist())
            proven = every - rays
            assert rays <= every and not proven & set(fast.tolist())
            assert set(fast.tolist()) & set(range(30000)) and set(fast.tolist()) & set(range(30000, 33000))
            deep = {i for i in every if i < 30000 and local[i, 1] > 5.0015}  # behind the wall by more than 1.5 mm
            hidden_deep = deep - set(fast.tolist())
            assert len(proven & hidden_deep) > 0.7 * len(hidden_deep), (len(proven), len(hidden_deep))
            assert not proven & {i for i in every if i < 2000 and local[i, 1] < 5.001}  # nearer than 1 mm: rays


def _behind_and_before(rng, n_behind, y_wall, half_x, half_z):
    """Features facing south: n_behind behind a wall at y_wall (a tenth within 1.5 mm of its back), and some
    before it."""
    behind = rng.uniform([-half_x, y_wall + 0.0015, -half_z], [half_x, y_wall + 4.0, half_z], (n_behind, 3))
    behind[: n_behind // 10, 1] = y_wall + rng.uniform(0.0002, 0.0015, n_behind // 10)
    before = rng.uniform([-half_x, 1.0, -half_z], [half_x, y_wall - 0.5, half_z], (2000, 3))
    points = np.concatenate([behind, before])
    return points, np.tile([0.0, -1.0, 0.0], (len(points), 1))


def test_the_first_big_triangle_behind_a_window_s_bars_proves_the_room_hidden():
    """A 6 × 4 m pane 5 m north, behind 857 overlapping glazing bars 8 mm wide (the window of the restaurant
    benchmark): a ray toward a block of features hits a bar, too narrow to hide the block, but the first big
    triangle along it (inscribed circle ≥ 0.1 m: the pane) does. The set seen equals one ray per feature; with the
    big triangles most of the room needs no ray, without them almost all of it does; nothing within 1 mm of the
    pane is proven."""
    import dataclasses

    from sightplan.observations.features import FeatureSet
    from test_engine_analytic import R_NORTH, build_scene, wall_y

    bars = [wall_y(4.99, x - 0.004, x + 0.004, -2.0, 2.0, 1) for x in np.arange(-3.0, 3.0, 0.007)]
    scene = build_scene([wall_y(5.0, -3.0, 3.0, -2.0, 2.0, 0), *bars], 2)
    points, normals = _behind_and_before(np.random.default_rng(4), 20000, 5.0, 2.0, 1.5)
    fs = FeatureSet(points, normals, np.zeros(len(points), np.int8), np.full(len(points), -1, np.int32), {})
    camera = PinholeCamera(640, 480, 400, 400, 320, 240, "wide")
    C = np.zeros(3)
    with make_engine("embree", scene, fs, threads=1) as engine:
        np.testing.assert_array_equal(engine.visible_features(camera, R_NORTH, C),
                                      engine.visible_features_reference(camera, R_NORTH, C))
        seen = set(engine.visible_features(camera, R_NORTH, C).tolist())
        args = (C, R_NORTH, camera.width, camera.height, camera.fx, camera.fy, camera.cx, camera.cy, engine.d_max)
        index = engine.feature_index
        every = set(index.candidates(*args)[0].tolist())
        with_big = set(index.candidates(*args, cover=engine.occluders)[0].tolist())
        bars_only = dataclasses.replace(engine.occluders, big_hit=None)
        without = set(index.candidates(*args, cover=bars_only)[0].tolist())
    deep = {i for i in every if i < 20000 and points[i, 1] > 5.0015}
    assert deep and not deep & seen and len(every & set(range(20000, 22000))) > 1000
    assert len(deep - with_big) > 0.9 * len(deep), (len(deep - with_big), len(deep))
    assert len(deep - without) < 0.1 * len(deep), (len(deep - without), len(deep))
    assert not (every - with_big) & seen


def test_the_triangles_the_frame_s_pixels_hit_prove_features_hidden():
    """A wall of 10 cm tiles 5 m north (each tile smaller than a block of features, none of them big): one ray per
    block proves little, the half-tile each feature's own pixel hit (5 cm at scale 0.25) proves most of the room
    hidden. ``observe`` hands the feature test its pixels' triangles; at every scale its set equals one ray per
    feature."""
    from sightplan.observations.features import FeatureSet
    from test_engine_analytic import R_NORTH, build_scene, wall_y

    tiles = [wall_y(5.0, x, x + 0.1, z, z + 0.1, 0) for x in np.arange(-3.0, 3.0, 0.1) for z in np.arange(-2.0, 2.0, 0.1)]
    scene = build_scene(tiles, 1)
    points, normals = _behind_and_before(np.random.default_rng(6), 20000, 5.0, 2.0, 1.5)
    fs = FeatureSet(points, normals, np.zeros(len(points), np.int8), np.full(len(points), -1, np.int32), {})
    camera = PinholeCamera(640, 480, 400, 400, 320, 240, "wide")
    C = np.zeros(3)
    with make_engine("embree", scene, fs, threads=2) as engine:
        reference = engine.visible_features_reference(camera, R_NORTH, C)
        for scale in (1.0, 0.5, 0.25):
            np.testing.assert_array_equal(engine.observe(camera, R_NORTH, C, scale).features, reference)
        small = camera.scaled(0.25)
        dirs = np.empty((small.width * small.height, 3), np.float32)
        engine.pixel_directions(small, R_NORTH, 0, len(dirs), dirs)
        prims = engine.first_hit(np.broadcast_to((C - engine.centre).astype(np.float32), dirs.shape), dirs)
        pixels = (prims.reshape(small.height, small.width), small.width / camera.width, small.height / camera.height)
        args = (C, R_NORTH, camera.width, camera.height, camera.fx, camera.fy, camera.cx, camera.cy, engine.d_max)
        every = set(engine.feature_index.candidates(*args)[0].tolist())
        blocks = set(engine.feature_index.candidates(*args, cover=engine.occluders)[0].tolist())
        own = set(engine.feature_index.candidates(*args, cover=engine.occluders, pixels=pixels)[0].tolist())
    deep = {i for i in every if i < 20000 and points[i, 1] > 5.0015}
    assert len(deep - blocks) < 0.5 * len(deep), (len(deep - blocks), len(deep))
    assert len(deep - own) > 0.6 * len(deep), (len(deep - own), len(deep))  # 5 cm pixels on 10 cm tiles: 75 %
    assert not (every - own) & set(reference.tolist())
    assert not (every - own) & {i for i in range(2000) if points[i, 1] < 5.001}


def test_big_triangles_are_those_whose_inscribed_circle_is_wide_enough():
    """A 3-4-5 right triangle has an inscribed circle of radius 1 (area 6, half-perimeter 6); a sliver of the same
    area has one of 0.0006."""
    from sightplan.engines.featurecull import big_triangles

    vertices = np.array([[0.0, 0, 0], [3, 0, 0], [0, 4, 0], [0, 0, 5], [10000, 0, 5], [0, 0.0012, 5]])
    faces = np.array([[0, 1, 2], [3, 4, 5]])
    np.testing.assert_array_equal(big_triangles(vertices, faces, 0.999), [0])
    assert len(big_triangles(vertices, faces, 1.001)) == 0
    np.testing.assert_array_equal(big_triangles(vertices, faces, 0.0005), [0, 1])


def test_a_frame_gives_the_same_bits_whatever_the_threads(duplex, features):
    """The threads take a frame's chunks as they free up; each chunk's sums are added in the chunks' order, so one,
    two and three threads give the same floating-point sums, to the bit."""
    plan = ring_plan(duplex, CAMERA, n_frames=4, distance_m=6)
    got = []
    for threads in (1, 2, 3):
        with make_engine("embree", duplex, features, threads=threads) as e:
            got.append([e.observe(CAMERA, plan.R_world_camera[i], plan.C_world[i]) for i in range(len(plan))])
    for other in got[1:]:
        for a, b in zip(got[0], other):
            assert len(a.element) > 10
            for name in ("element", "count", "depth_mean", "angle_mean", "features"):
                assert np.array_equal(getattr(a, name), getattr(b, name)), name


@pytest.mark.parametrize("wall", ["one quad", "10 cm tiles"])
def test_features_half_a_millimetre_behind_a_wall_are_decided_as_the_reference_decides(wall):
    """4,000 features behind a wall 5 m away, 0.49 to 0.51 mm behind it, where the 0.5 mm tolerance decides and a
    float32 ray's rounding (0.5 µm at 5 m) could tip an occlusion query either way, as could the rounding of a BVH's
    box tests at either end of a query's stretch (the tiles make many boxes): the engine's set equals the
    reference's (first hit's distance against the feature's), some seen, some not."""
    from sightplan.observations.features import FeatureSet
    from test_engine_analytic import R_NORTH, build_scene, wall_y

    if wall == "one quad":
        scene = build_scene([wall_y(5.0, -2.0, 2.0, -2.0, 2.0, 0)], 1)
    else:
        scene = build_scene([wall_y(5.0, x, x + 0.1, z, z + 0.1, 0) for x in np.arange(-2.0, 2.0, 0.1)
                             for z in np.arange(-2.0, 2.0, 0.1)], 1)
    rng = np.random.default_rng(8)
    n = 4000
    points = np.c_[rng.uniform(-1.5, 1.5, n), 5.0 + rng.uniform(0.00049, 0.00051, n), rng.uniform(-1.0, 1.0, n)]
    fs = FeatureSet(points, np.tile([0.0, -1.0, 0.0], (n, 1)), np.zeros(n, np.int8), np.zeros(n, np.int32), {})
    camera = PinholeCamera(640, 480, 400, 400, 320, 240, "wide")
    with make_engine("embree", scene, fs, threads=1) as engine:
        fast = engine.visible_features(camera, R_NORTH, np.zeros(3))
        reference = engine.visible_features_reference(camera, R_NORTH, np.zeros(3))
    np.testing.assert_array_equal(fast, reference)
    assert 0.1 * n < len(reference) < 0.9 * n


def test_frustum_candidates_equal_the_per_feature_tests():
    """Random features and random cameras: culled blocks never hold a feature that passes."""
    rng = np.random.default_rng(1)
    pts = rng.uniform(-20, 20, (20000, 3))
    nrm = rng.normal(size=(20000, 3))
    nrm /= np.linalg.norm(nrm, axis=1)[:, None]
    index = FeatureIndex(pts, nrm)
    for k in range(20):
        C = rng.uniform(-30, 30, 3)
        R = R_from_gimbal(rng.uniform(0, 360), rng.uniform(-90, 30))[0]
        d_max = [1000.0, 15.0][k % 2]
        ids, dirs, dist = index.candidates(C, R, CAMERA.width, CAMERA.height, CAMERA.fx, CAMERA.fy, CAMERA.cx,
                                           CAMERA.cy, d_max)
        rel = pts - C
        d = np.linalg.norm(rel, axis=1)
        cam = rel @ R
        with np.errstate(divide="ignore", invalid="ignore"):
            x = CAMERA.fx * cam[:, 0] / cam[:, 2] + CAMERA.cx
            y = CAMERA.fy * cam[:, 1] / cam[:, 2] + CAMERA.cy
        ok = ((np.einsum("ij,ij->i", nrm, rel) < 0) & (d <= d_max) & (cam[:, 2] > 0) & (x >= 0) & (x < CAMERA.width)
              & (y >= 0) & (y < CAMERA.height))
        order = np.argsort(ids)
        np.testing.assert_array_equal(ids[order], np.flatnonzero(ok))
        np.testing.assert_allclose(dist[order], d[ok])
        np.testing.assert_allclose(dirs[order], rel[ok] / d[ok, None], atol=1e-6)


@pytest.mark.parametrize("origin, length", [(np.zeros(3), 1.0), (SITE_FAR_AWAY, 1.0), (np.zeros(3), 100.0)],
                         ids=["at the origin", "5,400 km from it", "normals 100 long"])
def test_features_whose_sight_line_grazes_their_surface_face_the_camera_as_the_brute_force_test_says(origin, length):
    """The per-feature pass tests facing in float32, which cannot decide n·r within its rounding of zero; it keeps
    those features for the float64 test. 20,000 features around 30 cameras, each normal at right angles to the
    sight line from one of them, tipped by at most 10⁻⁶ either way (or not at all): the candidates are exactly the
    features that pass the brute-force tests, some of the grazing ones in, some out. The same with normals of
    length 100 (a feature set read from a file need not hold unit normals; the tests depend only on their sign)."""
    rng = np.random.default_rng(11)
    n = 20000
    pts = rng.uniform(-20, 20, (n, 3)) + origin
    nrm = rng.normal(size=(n, 3))
    nrm /= np.linalg.norm(nrm, axis=1)[:, None]
    from test_engine_analytic import R_NORTH

    index = None
    for k in range(30):
        C = rng.uniform(-30, 30, 3) + origin
        R = R_from_gimbal(rng.uniform(0, 360), rng.uniform(-90, 30))[0]
        if index is None:  # the normals graze the sight lines from this first camera, 80 m south, seeing them all
            C, R = origin + [0.0, -80.0, 0.0], R_NORTH
            r = pts - C
            r /= np.linalg.norm(r, axis=1)[:, None]
            nrm -= np.einsum("ij,ij->i", nrm, r)[:, None] * r
            nrm /= np.linalg.norm(nrm, axis=1)[:, None]
            tip = rng.choice([-1e-6, -1e-8, -1e-10, 0.0, 1e-10, 1e-8, 1e-6], n)
            nrm = nrm + tip[:, None] * r
            nrm *= length / np.linalg.norm(nrm, axis=1)[:, None]
            index = FeatureIndex(pts, nrm)
        ids, dirs, dist = index.candidates(C, R, CAMERA.width, CAMERA.height, CAMERA.fx, CAMERA.fy, CAMERA.cx,
                                           CAMERA.cy, 1000.0)
        rel = pts - C
        cam = rel @ R
        with np.errstate(divide="ignore", invalid="ignore"):
            x = CAMERA.fx * cam[:, 0] / cam[:, 2] + CAMERA.cx
            y = CAMERA.fy * cam[:, 1] / cam[:, 2] + CAMERA.cy
        facing = (nrm[:, 0] * rel[:, 0] + nrm[:, 1] * rel[:, 1]) + nrm[:, 2] * rel[:, 2] < 0  # as the reference sums it
        ok = facing & (cam[:, 2] > 0) & (x >= 0) & (x < CAMERA.width) & (y >= 0) & (y < CAMERA.height)
        np.testing.assert_array_equal(np.sort(ids), np.flatnonzero(ok))
        if k == 0:
            inside = (cam[:, 2] > 0) & (x >= 0) & (x < CAMERA.width) & (y >= 0) & (y < CAMERA.height)
            assert inside.all() and 0.3 * n < ok.sum() < 0.7 * n


def test_features_a_hair_from_the_camera_face_it_as_the_brute_force_test_says():
    """Blocks of features within 10⁻¹⁶ to 10⁻¹² m of the camera, their normals at right angles to their sight lines
    give or take 10⁻⁶: the float32 pass's slack shrinks with the block's distance and does not vanish, so the
    candidates are exactly the features that face the camera."""
    rng = np.random.default_rng(2)
    C = np.array([0.3, 0.7, 0.1])
    for reach in (1e-16, 1e-15, 1e-14, 1e-12):
        pts = C + rng.uniform(-reach, reach, (64 * 50, 3))
        r = pts - C  # some points round to C itself: seen by no test
        length = np.linalg.norm(r, axis=1)[:, None]
        r = np.divide(r, length, out=np.zeros_like(r), where=length > 0)
        nrm = rng.normal(size=pts.shape)
        nrm -= np.einsum("ij,ij->i", nrm, r)[:, None] * r
        nrm += rng.choice([-1e-6, -1e-7, 0.0, 1e-7, 1e-6], len(pts))[:, None] * r
        nrm /= np.linalg.norm(nrm, axis=1)[:, None]
        ids, _, _ = FeatureIndex(pts, nrm).candidates(C, None, 0, 0, 1.0, 1.0, 0.0, 0.0, 1000.0)
        rel = pts - C
        facing = ((nrm[:, 0] * rel[:, 0] + nrm[:, 1] * rel[:, 1]) + nrm[:, 2] * rel[:, 2] < 0) & (rel.any(axis=1))
        np.testing.assert_array_equal(np.sort(ids), np.flatnonzero(facing))
        assert 0.3 * len(pts) < facing.sum() < 0.7 * len(pts)


@pytest.mark.parametrize("origin", [np.zeros(3), SITE_FAR_AWAY], ids=["at the origin", "5,400 km from it"])
def test_a_camera_a_hair_before_a_wall_sees_what_the_reference_sees(origin):
    """A tilted 10 × 10 m wall and 20,000 features behind it, seen by a 360° camera 10⁻⁷ to 10⁻¹⁰ m before it. Once
    its float32 origin and the wall's float32 corners are rounded, a ray may start beyond the wall and see what lies
    behind it; the reference's rays do. So a triangle that near the camera's plane proves nothing, and the set seen
    is the reference's, whatever it holds."""
    from sightplan.observations.features import FeatureSet
    from test_engine_analytic import R_NORTH, Rect, build_scene

    rng = np.random.default_rng(3)
    e1, e2 = np.array([0.6, 0.8, 0.0]) * 5, np.array([-0.48, 0.36, 0.8]) * 5
    normal = np.cross(e1, e2) / np.linalg.norm(np.cross(e1, e2))
    c = origin + [1.3, 2.1, 0.7]
    scene = build_scene([Rect(c, e1, e2, 0)], 1)
    n = 20000
    pts = (c + rng.uniform(-1, 1, (n, 1)) * e1 + rng.uniform(-1, 1, (n, 1)) * e2
           + rng.uniform(0.002, 3, (n, 1)) * normal)
    fs = FeatureSet(pts, np.tile(-normal, (n, 1)), np.zeros(n, np.int8), np.full(n, -1, np.int32), {})
    camera = EquirectangularCamera(256, 128, "pano")
    seen = []
    with make_engine("embree", scene, fs, threads=1) as engine:
        for gap in (1e-7, 1e-8, 1e-9, 1e-10):
            for _ in range(4):
                C = c + rng.uniform(-0.9, 0.9) * e1 + rng.uniform(-0.9, 0.9) * e2 - gap * normal
                fast = engine.visible_features(camera, R_NORTH, C)
                np.testing.assert_array_equal(fast, engine.visible_features_reference(camera, R_NORTH, C))
                seen.append(len(fast))
    assert max(seen) > 0  # some rays do start beyond the wall


def test_stability_metrics_equal_with_the_brute_force_feature_test(duplex, features, monkeypatch):
    plan = ring_plan(duplex, CAMERA, n_frames=10, distance_m=6)
    settings = EvaluationSettings(engine="embree", metric=MetricParams(omega=50, min_track=3, min_features=20))
    fast = evaluate(duplex, plan, settings, features=features, cache_dir=False)
    monkeypatch.setattr(EmbreeEngine, "visible_features", EmbreeEngine.visible_features_reference)
    slow = evaluate(duplex, plan, settings, features=features, cache_dir=False)
    assert fast.metrics.plan.T > 10
    assert fast.metrics.plan.T == slow.metrics.plan.T
    np.testing.assert_array_equal(fast.metrics.frames.nu, slow.metrics.frames.nu)


def test_packets_hit_what_single_rays_hit(duplex, engine):
    embreex = pytest.importorskip("embreex")  # noqa: F841  (the library the binding opens)
    from embreex import rtcore_scene
    from embreex.mesh_construction import TriangleMesh

    single = rtcore_scene.EmbreeScene()
    TriangleMesh(single, engine.local_vertices.astype(np.float32), duplex.faces.astype(np.int32))
    plan = ring_plan(duplex, CAMERA, n_frames=4, distance_m=6)
    n = CAMERA.width * CAMERA.height
    for i in range(len(plan)):
        dirs = np.empty((n, 3), np.float32)
        kernels.pinhole_directions(0, n, CAMERA.width, CAMERA.fx, CAMERA.fy, CAMERA.cx, CAMERA.cy,
                                   plan.R_world_camera[i], dirs)
        origin = np.broadcast_to((plan.C_world[i] - engine.centre).astype(np.float32), dirs.shape)
        a = engine.first_hit(origin, dirs)
        b = np.asarray(single.run(origin, dirs, query="INTERSECT"), np.int32)
        assert (b >= 0).mean() > 0.2
        assert (a == b).mean() >= 0.9995
        # the fused cast (generation, packets, reduction) counts the pixels of those hits per element
        fo = engine.observe(CAMERA, plan.R_world_camera[i], plan.C_world[i])
        t, _ = engine._plane_distance(b, origin, dirs)
        hit = (b >= 0) & (t >= 0) & (t <= engine.d_max)
        expected = np.bincount(duplex.face_element[b[hit]], minlength=duplex.n_elements)
        got = np.zeros(duplex.n_elements, np.int64)
        got[fo.element] = fo.count
        assert np.abs(got - expected).sum() <= 0.0005 * n


def test_features_are_sampled_once_and_cached(duplex, tmp_path):
    a = cached_features(duplex, 0.5, seed=2, cache_dir=tmp_path)
    files = list(tmp_path.glob("features-*.npz"))
    assert len(files) == 1
    b = cached_features(duplex, 0.5, seed=2, cache_dir=tmp_path)
    assert a.key == b.key and a.params == b.params
    np.testing.assert_array_equal(a.kind, b.kind)
    np.testing.assert_array_equal(a.element, b.element)
    assert a.key == sample_features(duplex, 0.5, seed=2).key
    cached_features(duplex, 0.5, seed=3, cache_dir=tmp_path)  # other parameters: another file
    assert len(list(tmp_path.glob("features-*.npz"))) == 2
    files[0].write_bytes(b"not a feature file")  # a damaged file is sampled again
    assert cached_features(duplex, 0.5, seed=2, cache_dir=tmp_path).key == a.key


def test_one_ray_compiles_nothing_new(engine):
    """The kernels that call Embree cannot be cached, so each compiles once per process and type of arguments; a
    block of features with a single ray left once compiled them again in the middle of a frame (0.5 s). One ray,
    one occlusion query, and many share the many-ray kernels, and give the same answers as within a batch."""
    from sightplan.engines import packets

    rng = np.random.default_rng(2)
    dirs = rng.normal(size=(50, 3)).astype(np.float32)
    dirs /= np.linalg.norm(dirs, axis=1)[:, None]
    origin = (np.array([0.0, -8.0, 1.5]) - engine.centre).astype(np.float32)
    many = engine.first_hit(origin, dirs)
    free = engine.unoccluded_rays(origin, dirs, np.full(50, 5.0, np.float32))
    compiled = (len(packets.first_hits.signatures), len(packets.unoccluded.signatures))
    for i in range(3):
        assert engine.first_hit(origin, dirs[i:i + 1]).tolist() == [many[i]]
        assert engine.unoccluded_rays(origin, dirs[i:i + 1], np.array([5.0], np.float32)).tolist() == [free[i]]
    assert (len(packets.first_hits.signatures), len(packets.unoccluded.signatures)) == compiled
    assert (many >= 0).any() and (~free).any()
