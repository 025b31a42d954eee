"""The evaluation pipeline: observations round trips, frame selection, the per-frame cache."""

from __future__ import annotations

import numpy as np
import pytest
import trimesh

from sightplan.camera.models import EquirectangularCamera, PinholeCamera
from sightplan.errors import ObservationsError, SightplanError
from sightplan.evaluate import EvaluationSettings, evaluate, pixel_counts
from sightplan.geometry.poses import R_from_gimbal
from sightplan.metrics import compute_metrics
from sightplan.model.scene import ElementTable, Scene
from sightplan.observations.table import Observations
from sightplan.plan.ring import ring_plan
from sightplan.plan.types import Plan


def boxes_scene() -> Scene:
    """Three boxes of known size on a ground slab (an occluder-only element)."""
    parts = [
        trimesh.creation.box((4, 4, 3), trimesh.transformations.translation_matrix((0, 0, 1.5))),
        trimesh.creation.box((2, 6, 8), trimesh.transformations.translation_matrix((8, 3, 4))),
        trimesh.creation.box((1, 1, 1), trimesh.transformations.translation_matrix((-6, -5, 0.5))),
        trimesh.creation.box((40, 40, 0.2), trimesh.transformations.translation_matrix((0, 0, -0.1))),
    ]
    V, F, E, off = [], [], [], 0
    for i, m in enumerate(parts):
        V.append(m.vertices)
        F.append(m.faces + off)
        E.append(np.full(len(m.faces), i))
        off += len(m.vertices)
    el = ElementTable.build(["a", "b", "c", "ground"], is_target=[True, True, True, False],
                            finish=["2024-01-10", "2024-02-10", None, None])
    return Scene.from_arrays(np.concatenate(V), np.concatenate(F), np.concatenate(E), el)


@pytest.fixture(scope="module")
def scene() -> Scene:
    return boxes_scene()


@pytest.fixture(scope="module")
def plan(scene) -> Plan:
    return ring_plan(scene, PinholeCamera(320, 240, 300, 300, 160, 120, "small"), n_frames=12, distance_m=6)


def test_observations_save_load_round_trip(scene, plan, tmp_path):
    ev = evaluate(scene, plan, cache_dir=False)
    path = tmp_path / "obs.npz"
    ev.observations.save(path)
    back = Observations.load(path)
    for name in Observations._ARRAYS:
        np.testing.assert_array_equal(getattr(back, name), getattr(ev.observations, name))
    assert compute_metrics(back).plan == ev.metrics.plan


def test_merge_of_batches_equals_whole(scene, plan):
    ev = evaluate(scene, plan, cache_dir=False)
    halves = [evaluate(scene, plan.subset(idx), cache_dir=False).observations for idx in (range(0, 5), range(5, 12))]
    merged = Observations.concatenate(halves)
    np.testing.assert_array_equal(pixel_counts(merged), pixel_counts(ev.observations))
    np.testing.assert_array_equal(merged.feature_frame, ev.observations.feature_frame)
    np.testing.assert_array_equal(merged.feature_id, ev.observations.feature_id)


def test_selecting_frames_needs_no_casting(scene, plan):
    """Observations of a frame subset equal a fresh evaluation of the subset plan."""
    idx = np.array([7, 2, 3, 11])
    ev = evaluate(scene, plan, cache_dir=False)
    sub = evaluate(scene, plan.subset(idx), cache_dir=False)
    np.testing.assert_array_equal(pixel_counts(ev.observations.select_frames(idx)), pixel_counts(sub.observations))
    assert compute_metrics(ev.observations.select_frames(idx)).plan == sub.metrics.plan


def test_frame_cache_recasts_only_changed_frames(scene, plan, tmp_path):
    first = evaluate(scene, plan, cache_dir=tmp_path)
    assert first.timings["frames_cast"] == len(plan)
    again = evaluate(scene, plan, cache_dir=tmp_path)
    assert again.timings["frames_cast"] == 0 and again.cache_hits == len(plan)
    assert again.metrics.plan == first.metrics.plan
    C = plan.C_world.copy()
    C[[1, 4], 2] += 0.5
    moved = Plan.build(plan.cameras, plan.R_world_camera, C, frame_camera=list(plan.frame_camera))
    third = evaluate(scene, moved, cache_dir=tmp_path)
    assert third.timings["frames_cast"] == 2
    fresh = evaluate(scene, moved, cache_dir=False)
    assert third.metrics.plan == fresh.metrics.plan
    # a different capture date is a different scene: nothing may come from the cache
    later = evaluate(scene.at("2024-01-31"), plan, cache_dir=tmp_path)
    assert later.timings["frames_cast"] == len(plan)


def test_corrupt_cache_entry_is_recomputed(scene, plan, tmp_path):
    evaluate(scene, plan, cache_dir=tmp_path)
    for f in tmp_path.rglob("*.npz"):
        f.write_bytes(b"garbage")
    ev = evaluate(scene, plan, cache_dir=tmp_path)
    assert ev.timings["frames_cast"] == len(plan)


def test_resolution_scale_counts_are_full_resolution_pixels(scene, plan):
    full = evaluate(scene, plan, cache_dir=False)
    half = evaluate(scene, plan, EvaluationSettings(scale=0.5), cache_dir=False)
    a, b = pixel_counts(full.observations), pixel_counts(half.observations)
    big = a > 2000
    np.testing.assert_allclose(b[big], a[big], rtol=0.06)
    assert full.metrics.plan.VC == half.metrics.plan.VC


def test_occluder_counts_in_no_metric(scene, plan):
    ev = evaluate(scene, plan, cache_dir=False)
    assert ev.metrics.plan.z == 3
    assert not ev.metrics.elements.visible[3]  # the ground is seen in every frame, but is no target
    assert (ev.observations.element == 3).any()


def test_capture_date_removes_unbuilt_elements(scene, plan):
    early = scene.at("2024-01-15")  # box b is finished on 2024-02-10
    assert list(early.present) == [True, False, True, True]
    ev = evaluate(early, plan, cache_dir=False)
    assert ev.metrics.plan.z == 2
    assert not (ev.observations.element == 1).any()
    with pytest.raises(SightplanError, match="no element of the model exists on 2023-12-01"):
        scene.at("2023-12-01", unscheduled="absent")


def test_equirectangular_frames_evaluate(scene):
    """A panorama 1.6 m above a 40 m slab: rays steeper than atan(1.6/12) below the horizon
    (the nearest slab edge is 12 m away) all land on the slab or a box; none above the horizon does."""
    W, H = 256, 128
    cam = EquirectangularCamera(W, H, "pano")
    plan = Plan.build(cam, R_from_gimbal([0], [0]), [[0, -8, 1.6]])
    ev = evaluate(scene, plan, cache_dir=False)
    lat = np.pi / 2 - np.pi * (np.arange(H) + 0.5) / H
    surely_down = int((lat < -np.arctan(1.6 / 12)).sum()) * W
    below = int((lat < 0).sum()) * W
    counts = pixel_counts(ev.observations)[0]
    assert counts.sum() >= surely_down
    assert counts[3] <= below  # the slab (top at z=0) is never seen above the horizon
    assert ev.metrics.plan.n_observed >= 1


def test_observations_from_a_newer_version_are_refused(scene, plan, tmp_path):
    import json

    ev = evaluate(scene, plan.subset([0]), cache_dir=False)
    path = tmp_path / "obs.npz"
    ev.observations.save(path)
    with np.load(path) as z:
        arrays = {k: z[k] for k in z.files}
    header = json.loads(str(arrays["header"]))
    header["version"] = 99
    arrays["header"] = np.array(json.dumps(header))
    np.savez(path, **arrays)
    with pytest.raises(ObservationsError, match="newer sightplan"):
        Observations.load(path)


def test_empty_plan_is_refused(scene, plan):
    with pytest.raises(SightplanError, match="no frames"):
        evaluate(scene, plan.subset([]), cache_dir=False)


def test_overview_picture_shows_each_visibility_class(scene, plan, tmp_path):
    import matplotlib.image as mpimg

    from sightplan.engines import make_engine
    from sightplan.engines.views import overview_view
    from sightplan.report.overview import UNSEEN, VISIBLE, draw_overview, visibility_colours

    ev = evaluate(scene, plan, cache_dir=False)
    em = ev.metrics.elements
    assert em.visible[0] and em.visible[1]
    colours = visibility_colours(em)
    colours[1] = UNSEEN  # paint box b as unseen to see both classes in the picture
    with make_engine("embree", scene) as eng:
        view = overview_view(eng, plan.C_world)
    u, v = view.project(plan.C_world)
    assert len(u) == len(plan) and (0 <= u).all() and (u < 1200).all() and (0 <= v).all() and (v < 800).all()
    path = draw_overview(view, colours, tmp_path / "overview.png", plan.C_world, title="test")
    img = mpimg.imread(path)[..., :3]
    hue = img / np.maximum(img.max(axis=2, keepdims=True), 1e-6)  # undo the shading's brightness

    def share(rgb):
        ref = np.asarray(rgb) / max(rgb)
        return np.mean(np.abs(hue - ref).max(axis=2) < 0.08)

    assert share(VISIBLE) > 0.002 and share(UNSEEN) > 0.002


def test_shaded_view_matches_a_known_wall():
    """A head-on wall: the shading cosine is the ray's cosine to the axis, the distance d/cos."""
    from sightplan.engines import make_engine

    V = np.array([[-2, 10, 0], [2, 10, 0], [2, 10, 3], [-2, 10, 3]], float)
    wall = Scene.from_arrays(V, [[0, 1, 2], [0, 2, 3]], [0, 0], ElementTable.build(["w"]))
    cam = PinholeCamera(40, 30, 20, 20, 20, 15)
    with make_engine("embree", wall) as eng:
        ids, t, cos = eng.shaded_view(cam, R_from_gimbal(0, 0)[0], np.array([0, 0, 1.5]))
    u, v = np.meshgrid(np.arange(40) + 0.5, np.arange(30) + 0.5)
    ray_cos = 1 / np.sqrt(((u - 20) / 20) ** 2 + ((v - 15) / 20) ** 2 + 1)
    hit = ids == 0
    assert hit.sum() == 8 * 6  # ±2 m at 10 m is ±4 px at f = 20; 0..3 m around 1.5 m is ±3 px
    np.testing.assert_allclose(cos[hit], ray_cos[hit], atol=1e-6)
    np.testing.assert_allclose(t[hit], 10 / ray_cos[hit], rtol=1e-6)


def test_merging_refuses_batches_that_do_not_belong_together(scene, plan):
    from sightplan.observations.features import sample_features

    a = evaluate(scene, plan.subset([0, 1]), cache_dir=False).observations
    other_seed = evaluate(scene, plan.subset([2]), features=sample_features(scene, 1.0, seed=5), cache_dir=False)
    assert other_seed.observations.n_features == a.n_features  # same count: only the key tells them apart
    with pytest.raises(ObservationsError, match="different features"):
        Observations.concatenate([a, other_seed.observations])
    coarse = evaluate(scene, plan.subset([2]), EvaluationSettings(scale=0.5), cache_dir=False).observations
    with pytest.raises(ObservationsError, match="different scale"):
        Observations.concatenate([a, coarse])
    later = evaluate(scene.at("2024-01-15"), plan.subset([2]), cache_dir=False).observations
    with pytest.raises(ObservationsError, match="capture dates"):
        Observations.concatenate([a, later])


def test_features_of_another_scene_are_refused(scene, plan):
    from sightplan.observations.features import sample_features

    undated = sample_features(scene)
    with pytest.raises(SightplanError, match="another scene"):
        evaluate(scene.at("2024-01-15"), plan, features=undated, cache_dir=False)


@pytest.mark.parametrize("kwargs", [{"d_max": float("inf")}, {"feature_density": float("nan")}, {"feature_seed": -1},
                                    {"scale": 0.0}])
def test_settings_that_are_not_numbers_are_refused(kwargs):
    with pytest.raises(SightplanError):
        EvaluationSettings(**kwargs)


def test_no_storey_cutaways_without_storeys(scene, tmp_path):
    from sightplan.engines.views import storey_views
    from sightplan.report.overview import draw_storeys

    assert storey_views(scene, "embree") == []
    assert draw_storeys([], np.zeros((4, 3)), tmp_path / "s.png") is None
