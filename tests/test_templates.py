"""Plan templates: eq. 11 spacing on worked examples, waypoint counts by hand, view directions."""

from __future__ import annotations

import math

import numpy as np
import pytest
import trimesh

from sightplan.camera.catalogue import get_camera
from sightplan.errors import PlanError
from sightplan.evaluate import EvaluationSettings, evaluate
from sightplan.geometry.poses import gimbal_from_R
from sightplan.model.scene import ElementTable, Scene
from sightplan.plan.templates import facade_grid, indoor_route, indoor_routes, orbit, read_routes, waypoint_spacing

P4P = get_camera("p4p")  # 8.8 mm on 13.2 × 8.8 mm, 5472 × 3648: tan(hfov/2) = 0.75, tan(vfov/2) = 0.5


def box_scene(size=(20.0, 10.0, 8.0), corner=(0.0, 0.0, 0.0)) -> Scene:
    m = trimesh.creation.box(size, trimesh.transformations.translation_matrix(np.add(corner, np.divide(size, 2))))
    return Scene.from_arrays(m.vertices, m.faces, np.zeros(len(m.faces)), ElementTable.build(["box"]))


def test_spacing_matches_eq_11_and_the_qgroundcontrol_rule():
    # eq. 11: s = 2·g·tan(Φ/2)·(1 − l)
    assert waypoint_spacing(10, P4P.hfov_deg, 0.8) == pytest.approx(2 * 10 * 0.75 * 0.2)  # 3.0 m
    assert waypoint_spacing(10, P4P.vfov_deg, 0.8) == pytest.approx(2 * 10 * 0.5 * 0.2)  # 2.0 m
    # QGroundControl: footprint = distance × sensor width / focal length, spacing = footprint × (1 − overlap)
    footprint = 25.0 * 13.2 / 8.8
    assert waypoint_spacing(25, P4P.hfov_deg, 0.7) == pytest.approx(footprint * 0.3)


@pytest.mark.parametrize(("g", "fov", "overlap"), [(10, 70, 1.0), (10, 70, 1.2), (0, 70, 0.5), (10, 0, 0.5),
                                                   (float("nan"), 70, 0.5), (10, 70, -0.1)])
def test_spacing_refuses_impossible_input(g, fov, overlap):
    with pytest.raises(PlanError):
        waypoint_spacing(g, fov, overlap)


def test_facade_grid_count_for_a_box_by_hand():
    plan = facade_grid(box_scene(), P4P, safety_distance_m=10, overlap=0.8)
    # s_h = 3 m, s_v = 2 m. 20 m sides: ceil(20/3) + 1 = 8 columns; 10 m sides: ceil(10/3) + 1 = 5 columns.
    # Layers from the minimum height, 2 m above the ground (the box's base), to the 8 m top: ceil(6/2) + 1 = 4,
    # plus the top row: 5 frames per column. Every frame sees the box: none is dropped.
    assert [m.stop - m.start for m in plan.missions] == [8 * 5, 5 * 5, 8 * 5, 5 * 5]
    assert len(plan) == 130
    assert plan.C_world[:, 2].min() == pytest.approx(2.0)
    assert plan.parameters["dropped_frames"] == 0
    assert plan.parameters["spacing_horizontal_m"] == pytest.approx(3.0)
    assert plan.parameters["spacing_vertical_m"] == pytest.approx(2.0)


def test_facade_grid_keeps_the_safety_distance_and_looks_at_the_facade():
    g = 10.0
    plan = facade_grid(box_scene(), P4P, safety_distance_m=g, overlap=0.8)
    C, R = plan.C_world, plan.R_world_camera
    lo, hi = np.zeros(3), np.array([20.0, 10.0, 8.0])
    outside = np.maximum(lo[:2] - C[:, :2], 0) + np.maximum(C[:, :2] - hi[:2], 0)
    np.testing.assert_allclose(np.linalg.norm(outside, axis=1), g)  # every waypoint is g from its side
    fwd = R[:, :, 2]
    top = np.isclose(C[:, 2], hi[2] + g)
    assert top.sum() == 8 + 5 + 8 + 5  # one top waypoint per column
    np.testing.assert_allclose(np.degrees(np.arcsin(fwd[top, 2])), -45.0)
    south = plan.subset(range(plan.missions[0].start, plan.missions[0].stop))
    level = ~np.isclose(south.C_world[:, 2], hi[2] + g)
    inner = level & (south.C_world[:, 0] > 0.1) & (south.C_world[:, 0] < 19.9)
    np.testing.assert_allclose(south.R_world_camera[inner][:, :, 2], np.tile([0, 1, 0], (inner.sum(), 1)), atol=1e-12)
    west_end = level & np.isclose(south.C_world[:, 0], 0)  # first column turns 45° inward, toward the side's middle
    np.testing.assert_allclose(south.R_world_camera[west_end][:, :, 2], np.tile([math.sqrt(0.5), math.sqrt(0.5), 0],
                                                                                 (west_end.sum(), 1)), atol=1e-12)


def test_facade_grid_flies_a_snake_between_neighbouring_waypoints():
    plan = facade_grid(box_scene(), P4P, safety_distance_m=10, overlap=0.8)
    for m in plan.missions:
        steps = np.linalg.norm(np.diff(plan.C_world[m.start:m.stop], axis=0), axis=1)
        assert steps.max() <= 10.0 + 1e-9  # a layer step (2 m), a column step (≤ 3 m) or up to the top row (g)


def test_facade_grid_sees_every_side_of_the_box():
    scene = box_scene()
    ev = evaluate(scene, facade_grid(scene, P4P, 10, 0.8), EvaluationSettings(scale=0.1), cache_dir=False)
    assert ev.metrics.plan.VC == 1.0
    assert ev.metrics.plan.O < 30  # mostly canonical views


def test_facade_grid_refuses_a_flat_model_and_a_360_camera():
    flat = box_scene(size=(20.0, 10.0, 1e-9))
    with pytest.raises(PlanError, match="no extent"):
        facade_grid(flat, P4P, 10)
    with pytest.raises(PlanError, match="pinhole"):
        facade_grid(box_scene(), get_camera("theta-z1"), 10)


def test_orbit_rings_by_overlap():
    scene = box_scene()
    plan = orbit(scene, P4P, radii_m=[30, 50], heights_m=[5, 20], overlap=0.8)
    # step = s / r = 2·tan(hfov/2)·(1 − l) rad = 0.3 rad = 17.19°, whatever the radius: ceil(360 / 17.19) = 21
    assert [m.stop - m.start for m in plan.missions] == [21, 21]
    centre = np.array([10.0, 5.0, 4.0])
    for m, r, z in zip(plan.missions, (30, 50), (5, 20)):
        C = plan.C_world[m.start:m.stop]
        np.testing.assert_allclose(np.hypot(C[:, 0] - 10, C[:, 1] - 5), r)
        np.testing.assert_allclose(C[:, 2], z)
        to_centre = centre - C
        to_centre /= np.linalg.norm(to_centre, axis=1, keepdims=True)
        np.testing.assert_allclose(plan.R_world_camera[m.start:m.stop][:, :, 2], to_centre, atol=1e-12)


def test_orbit_by_step_and_bad_rings():
    scene = box_scene()
    assert len(orbit(scene, P4P, [30], [5], step_deg=10)) == 36
    with pytest.raises(PlanError, match="inside the model's footprint"):
        orbit(scene, P4P, [5], [5])
    with pytest.raises(PlanError, match="one height per ring"):
        orbit(scene, P4P, [30, 40], [5])


def test_lawnmower_grid_by_hand():
    from sightplan.plan.templates import lawnmower

    plan = lawnmower(box_scene(), P4P, altitude_m=38.0, front_overlap=0.8, side_overlap=0.7)
    # 30 m above the 8 m top: along a line 2·30·0.5·0.2 = 6 m, across 2·30·0.75·0.3 = 13.5 m
    assert plan.parameters["spacing_along_m"] == pytest.approx(6.0)
    assert plan.parameters["spacing_across_m"] == pytest.approx(13.5)
    # lines over 20 m: ceil(20/13.5) + 1 = 3; frames over 10 m: ceil(10/6) + 1 = 3
    assert len(plan) == 9
    np.testing.assert_allclose(plan.C_world[:, 2], 38.0)
    np.testing.assert_allclose(plan.C_world[:3, 1], [0, 5, 10])  # first line northward…
    np.testing.assert_allclose(plan.C_world[3:6, 1], [10, 5, 0])  # …second line back south
    np.testing.assert_allclose(plan.R_world_camera[:, :, 2], np.tile([0, 0, -1], (9, 1)), atol=1e-12)  # nadir
    np.testing.assert_allclose(-plan.R_world_camera[:, :, 1], np.tile([0, 1, 0], (9, 1)), atol=1e-12)  # image top north


def test_lawnmower_by_ground_sampling_distance_and_bad_altitudes():
    from sightplan.plan.templates import lawnmower

    plan = lawnmower(box_scene(), P4P, gsd_m=0.01)
    assert plan.parameters["clearance_m"] == pytest.approx(0.01 * 3648)  # GSD × focal in px
    assert plan.parameters["altitude_m"] == pytest.approx(8 + 36.48)
    with pytest.raises(PlanError, match="does not clear"):
        lawnmower(box_scene(), P4P, altitude_m=5)
    with pytest.raises(PlanError, match="or a safety distance"):
        lawnmower(box_scene(), P4P)
    assert lawnmower(box_scene(), P4P, safety_distance_m=12.0).parameters["clearance_m"] == pytest.approx(12.0)


def test_indoor_route_samples_the_polyline():
    cam = get_camera("theta-z1")
    plan = indoor_route(cam, [[0, 0, 1.6], [10, 0, 1.6], [10, 5, 1.6]], step_m=2.0)
    # 15 m of route every ≤ 2 m: ceil(7.5) + 1 = 9 frames, 1.875 m apart, both ends included
    assert len(plan) == 9
    np.testing.assert_allclose(plan.C_world[0], [0, 0, 1.6])
    np.testing.assert_allclose(plan.C_world[-1], [10, 5, 1.6])
    np.testing.assert_allclose(plan.C_world[6], [10, 1.25, 1.6])  # 11.25 m along: 1.25 m up the second leg
    np.testing.assert_allclose(plan.R_world_camera[1][:, 2], [1, 0, 0], atol=1e-12)  # first leg runs east
    np.testing.assert_allclose(plan.R_world_camera[6][:, 2], [0, 1, 0], atol=1e-12)  # second leg runs north
    with pytest.raises(PlanError, match="repeats"):
        indoor_route(cam, [[0, 0, 1.6], [0, 0, 1.6]], 1.0)


def test_orbit_aimed_at_the_nearest_surface():
    box = box_scene()  # 20 × 10 × 8 m from the origin, centre (10, 5)
    plan = orbit(box, P4P, [30.0, 12.0], [4.0, 20.0], step_deg=90, aim="surface")
    heading, pitch, _ = gimbal_from_R(plan.R_world_camera)
    # ring 1 at 4 m: due north (10, 35) faces the north wall head-on, due east (40, 5) the east wall
    np.testing.assert_allclose(plan.C_world[:2], [[10, 35, 4], [40, 5, 4]], atol=1e-9)
    np.testing.assert_allclose(heading[:2], [180, 270], atol=1e-6)
    np.testing.assert_allclose(pitch[:2], [0, 0], atol=1e-6)
    # ring 2 at 20 m, 12 m out: due north (10, 17) looks down at the roof's north edge (10, 10, 8)
    assert heading[4] == pytest.approx(180, abs=1e-6)
    assert pitch[4] == pytest.approx(-math.degrees(math.atan2(12, 7)), abs=1e-6)
    with pytest.raises(PlanError, match="aim"):
        orbit(box, P4P, [30.0], [4.0], aim="roof")


def test_routes_per_storey_from_a_csv(tmp_path):
    f = tmp_path / "routes.csv"
    f.write_text("route,x,y,z\nground,0,0,1.5\nground,10,0,1.5\nfirst,0,0,4.5\nfirst,0,6,4.5\nfirst,3,6,4.5\n")
    polylines, names = read_routes(f)
    plan = indoor_routes(get_camera("theta-z1"), polylines, names=names, step_m=2.0)
    # ground: 10 m → 6 frames; first: 6 + 3 = 9 m → ceil(4.5) + 1 = 6 frames
    assert [(m.name, m.stop - m.start) for m in plan.missions] == [("ground", 6), ("first", 6)]
    assert plan.C_world[6:, 2].tolist() == [4.5] * 6
    f.write_text("route,x,y,z\nground,0,0,one\n")
    with pytest.raises(PlanError, match="line 2"):
        read_routes(f)
    with pytest.raises(PlanError, match="first: .*repeats"):
        indoor_routes(get_camera("theta-z1"), [[[0, 0, 0], [1, 0, 0]], [[0, 0, 0], [0, 0, 0]]], 1.0, names=["g", "first"])
