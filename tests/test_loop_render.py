"""Synthetic photographs of a plan (sightplan.loop.render): the element map is the engine's, the texture is fixed
in the world and to the element's GlobalId, the true poses read back as a COLMAP model.

Analytic scenes: walls in the plane y = 5 seen from cameras whose pixel centres fall on known points (the camera
and helpers of tests/test_ties.py), so which element and which surface point a pixel shows is known by hand."""

from __future__ import annotations

import json

import numpy as np
import pytest
from PIL import Image

from sightplan.camera.models import EquirectangularCamera, PinholeCamera
from sightplan.engines import make_engine
from sightplan.errors import SightplanError
from sightplan.loop.render import depth_maps, element_maps, read_renders, render_plan, surface_samples
from sightplan.model.scene import ElementTable, Scene
from sightplan.plan.load import load_plan
from sightplan.plan.types import Plan
from test_engine_analytic import FAST_ENGINES, R_NORTH, build_scene, wall_y
from test_ties import CAM, Y, by_hand, two_walls

R_SOUTH = np.array([[-1.0, 0.0, 0.0], [0.0, 0.0, -1.0], [0.0, -1.0, 0.0]])  # looking −Y: sees nothing of y = 5


def plan_of(camera, centres, rotations) -> Plan:
    return Plan.build(camera, np.asarray(rotations, float), np.asarray(centres, float))


@pytest.mark.parametrize("engine_name", FAST_ENGINES)
@pytest.mark.parametrize("gap", [0.0, 0.0009])
def test_the_element_map_is_the_engines_with_the_ties_rule(tmp_path, engine_name, gap):
    """Two walls overlapping over x −0.5…0.5 in one plane (coincident within a millimetre): where they tie the
    render shows the smaller element, 0, so element 1 shows only over x 0.5…2, the pixels counted by hand."""
    scene = two_walls(gap)
    centres = [[0.0, 0.0, 0.0], [1e-4, 0.0, 0.0], [0.3, -1.0, 0.1]]
    plan = plan_of(CAM, centres, [R_NORTH] * 3)
    renders = render_plan(scene, plan, tmp_path / "r", engine=engine_name)
    maps = element_maps(tmp_path / "r")
    assert renders.engine == engine_name and len(maps) == 3
    with make_engine(engine_name, scene) as engine:
        for i in range(3):
            ids, _ = engine.element_map(CAM, R_NORTH, plan.C_world[i])
            np.testing.assert_array_equal(maps[i], ids)
    for i in (0, 1):
        shift = centres[i][0]
        assert int((maps[i] == 1).sum()) == by_hand(0.5, 2.0, shift=shift)[0]
        assert int((maps[i] == 0).sum()) == by_hand(-2.0, 0.5, shift=shift)[0]


def test_the_element_map_at_a_lower_scale_is_the_engines_at_that_scale(tmp_path):
    scene = two_walls()
    plan = plan_of(CAM, [[0.2, 0.0, 0.0]], [R_NORTH])
    renders = render_plan(scene, plan, tmp_path / "r", scale=0.5)
    cam = renders.camera(0)
    assert (cam.width, cam.height, cam.fx, cam.cx) == (100, 50, 50.0, 50.0)
    with make_engine("embree", scene) as engine:
        ids, t = engine.element_map(CAM, R_NORTH, plan.C_world[0], 0.5)
    np.testing.assert_array_equal(element_maps(tmp_path / "r")[0], ids)
    np.testing.assert_allclose(depth_maps(tmp_path / "r")[0], t, rtol=1e-6)
    img = np.asarray(Image.open(tmp_path / "r" / renders.image_names[0]))
    assert img.shape == (50, 100, 3) and img.dtype == np.uint8


def wide_wall(names=("A", "B")) -> Scene:
    """A 20 m × 10 m wall of element 0 in the plane y = 5 and a small one of element 1 out of the views."""
    base = build_scene([wall_y(Y, -10.0, 10.0, -5.0, 5.0, 0), wall_y(Y, 30.0, 31.0, -1.0, 1.0, 1)], 2)
    return Scene.from_arrays(base.vertices, base.faces, base.face_element, ElementTable.build(list(names)))


def test_a_world_point_has_one_colour_from_two_poses(tmp_path):
    """P = (0.3, 5, 0.2) lies on the centre of pixel (140, 46) of a camera 2 m west of it and of pixel (60, 46) of
    one 2 m east of it (f = 100 px, principal point (100.5, 50.5)); both see it at the same distance and angle, so
    shading and texture filtering are the same: the two pixels have one colour. The same pixel (140, 46) of the east
    camera shows another point, 4 m away, in another colour: the texture is not drawn on the screen."""
    cam = PinholeCamera(200, 100, 100.0, 100.0, 100.5, 50.5, "p")
    P = np.array([0.3, Y, 0.2])
    plan = plan_of(cam, [P + [-2.0, -Y, -0.2], P + [2.0, -Y, -0.2]], [R_NORTH, R_NORTH])
    renders = render_plan(wide_wall(), plan, tmp_path / "r", texture_cell_m=0.05)
    west, east = (np.asarray(Image.open(tmp_path / "r" / n)).astype(int) for n in renders.image_names)
    maps = element_maps(tmp_path / "r")
    assert maps[0][46, 140] == 0 and maps[1][46, 60] == 0
    assert np.abs(west[46, 140] - east[46, 60]).max() <= 1
    assert np.abs(west[46, 140] - east[46, 140]).max() > 10
    assert west.std() > 10  # a texture, not a flat colour


def test_the_texture_follows_the_global_id_not_the_element_index(tmp_path):
    """The same walls with their element order swapped (index 0 ↔ 1, GlobalIds kept on their faces) render the
    same image; other GlobalIds render another."""
    cam = PinholeCamera(200, 100, 100.0, 100.0, 100.0, 50.0, "p")
    plan = plan_of(cam, [[0.0, 0.0, 0.0]], [R_NORTH])
    a = wide_wall(("A", "B"))
    swapped = Scene.from_arrays(a.vertices, a.faces, 1 - a.face_element, ElementTable.build(["B", "A"]))
    other = wide_wall(("C", "B"))
    images = []
    for k, scene in enumerate((a, swapped, other)):
        r = render_plan(scene, plan, tmp_path / str(k), texture_cell_m=0.05)
        images.append(np.asarray(Image.open(r.directory / r.image_names[0])))
    np.testing.assert_array_equal(images[0], images[1])
    assert np.abs(images[0].astype(int) - images[2].astype(int)).mean() > 5


def test_true_poses_read_back_as_a_colmap_model(tmp_path):
    rng = np.random.default_rng(4)
    from sightplan.geometry.poses import R_from_gimbal

    n = 7
    R = R_from_gimbal(rng.uniform(-30, 30, n), rng.uniform(-20, 10, n), rng.uniform(-5, 5, n))
    C = np.column_stack([rng.uniform(-3, 3, n), rng.uniform(-2, 1, n), rng.uniform(-1, 1, n)])
    cam = PinholeCamera(240, 160, 210.0, 205.0, 118.25, 83.5, "c")
    plan = Plan.build(cam, R, C, frame_names=[f"shot {k}" for k in range(n)])
    renders = render_plan(wide_wall(), plan, tmp_path / "r", scale=0.5)
    back = load_plan(tmp_path / "r" / "poses", fmt="colmap")
    assert len(back) == n and list(back.frame_names) == list(renders.image_names)
    np.testing.assert_allclose(back.R_world_camera, R, atol=1e-12)
    np.testing.assert_allclose(back.C_world, C, atol=1e-12)
    got = back.camera_of(0)
    assert (got.width, got.height) == (120, 80)
    assert (got.fx, got.fy, got.cx, got.cy) == pytest.approx((105.0, 102.5, 59.125, 41.75))
    assert renders.frame_names == tuple(f"shot {k}" for k in range(n))
    doc = json.loads((tmp_path / "r" / "render.json").read_text())
    assert doc["elements"] == ["A", "B"] and doc["scale"] == 0.5


def test_a_frame_that_sees_nothing_is_blank_and_all_sky(tmp_path):
    plan = plan_of(CAM, [[0.0, 0.0, 0.0], [0.0, 0.0, 0.0]], [R_NORTH, R_SOUTH])
    renders = render_plan(wide_wall(), plan, tmp_path / "r")
    assert renders.blank_frames == (1,)
    assert (element_maps(tmp_path / "r")[1] == -1).all()
    sky = np.asarray(Image.open(tmp_path / "r" / renders.image_names[1])).astype(int)
    assert np.abs(np.diff(sky, axis=1)).max() <= 1  # a gradient over rows only: nothing for SIFT to find


def test_surface_samples_lie_on_the_surfaces_seen(tmp_path):
    plan = plan_of(CAM, [[0.0, 0.0, 0.0], [1.0, 1.0, 0.5]], [R_NORTH, R_NORTH])
    render_plan(two_walls(), plan, tmp_path / "r")
    points, elements, frames = surface_samples(tmp_path / "r", stride=2)
    assert len(points) > 0 and set(np.unique(frames)) == {0, 1}
    np.testing.assert_allclose(points[:, 1], Y, atol=1e-5)  # every sample on the plane y = 5
    assert np.all(points[elements == 1, 0] >= 0.5 - 1e-4)  # element 1 shows only right of element 0


def test_equirectangular_frames_and_foreign_folders_are_refused(tmp_path):
    plan = plan_of(EquirectangularCamera(64, 32, "pano"), [[0.0, 0.0, 0.0]], [R_NORTH])
    with pytest.raises(SightplanError, match="pinhole"):
        render_plan(wide_wall(), plan, tmp_path / "r")
    with pytest.raises(SightplanError, match="sightplan render"):
        read_renders(tmp_path)


def test_the_render_command_on_the_sample(tmp_path, duplex):
    """``sightplan render sample PLAN``: three frames of a ring around the Duplex at a twentieth of the camera's
    size, one of them turned to the sky."""
    from sightplan.camera.catalogue import get_camera
    from sightplan.plan.format import write_plan
    from sightplan.plan.ring import ring_plan
    from test_cli import run_cli

    ring = ring_plan(duplex, get_camera("p4p"), n_frames=3, distance_m=10)
    R = ring.R_world_camera.copy()
    R[2] = np.eye(3)  # camera axes x east, y north, z (the optical axis) straight up: only sky
    write_plan(Plan.build(ring.cameras, R, ring.C_world, frame_camera=list(ring.frame_camera)), tmp_path / "plan.json")
    res = run_cli("render", "sample", "plan.json", "-o", "images", "--scale", "0.05", cwd=tmp_path)
    assert res.returncode == 0, res.stderr
    assert "rendered 3 frames (274×182 px" in res.stdout and "1 frame(s) show no element" in res.stdout
    renders = read_renders(tmp_path / "images")
    assert renders.blank_frames == (2,) and len(renders.global_ids) == duplex.n_elements
    bad = run_cli("render", "sample", "plan.json", "-o", "images", "--scale", "2", cwd=tmp_path)
    assert bad.returncode == 2 and "--scale must be in (0, 1]" in bad.stderr
