"""Safety distance: exact distances from waypoints and segments to the model's triangles."""

from __future__ import annotations

import numpy as np
import pytest
import trimesh

from sightplan.camera.catalogue import get_camera
from sightplan.errors import PlanError
from sightplan.geometry.poses import R_from_gimbal
from sightplan.model.scene import ElementTable, Scene
from sightplan.plan.checks import check_safety, point_distances, segment_distances
from sightplan.plan.templates import facade_grid
from sightplan.plan.types import Mission, Plan

BOX = trimesh.creation.box((20.0, 10.0, 8.0), trimesh.transformations.translation_matrix((10.0, 5.0, 4.0)))


@pytest.fixture(scope="module")
def box() -> Scene:
    return Scene.from_arrays(BOX.vertices, BOX.faces, np.zeros(len(BOX.faces)), ElementTable.build(["box"]))


def test_point_distances_to_a_box(box):
    pts = [[5, -3, 4],        # 3 m in front of the south face
           [-3, -4, 4],       # beside the south-west vertical edge: hypot(3, 4) = 5 m
           [-1, -2, 10],      # off the top south-west corner: sqrt(1 + 4 + 4) = 3 m
           [10, 5, 4],        # inside, 4 m below the top and above the bottom: nearest face 4 m away
           [10, 5, 20]]       # 12 m above the roof
    np.testing.assert_allclose(point_distances(box, pts), [3, 5, 3, 4, 12], atol=1e-12)


def test_point_distances_agree_with_trimesh(box):
    rng = np.random.default_rng(7)
    pts = rng.uniform(-15, 35, (300, 3))
    _, expected, _ = trimesh.proximity.closest_point(BOX, pts)
    np.testing.assert_allclose(point_distances(box, pts), expected, atol=1e-9)


def test_segment_distances_to_a_box(box):
    start = [[-5, -2, 4],    # along the south face, 2 m away
             [-5, 5, 4],     # straight through the box
             [-10, -10, 12], # far at both ends, crossing over the roof (z = 8) at z = 12
             [0, -6, 0]]     # a vertical segment 6 m south of the south-west edge region
    end = [[25, -2, 4], [25, 5, 4], [30, 20, 12], [0, -6, 30]]
    d = segment_distances(box, start, end)
    assert d[0] == pytest.approx(2.0)
    assert d[1] == 0.0
    assert d[2] == pytest.approx(4.0)
    assert d[3] == pytest.approx(6.0)


def test_check_safety_finds_the_one_violation(box):
    plan = facade_grid(box, get_camera("p4p"), safety_distance_m=10, overlap=0.8)
    ok = check_safety(box, plan, minimum_m=9.99)
    assert ok.ok and ok.waypoint_m.min() == pytest.approx(10.0)
    # a plan built to break the rule exactly once: its middle segment cuts the corner of the box
    C = np.array([[-5.0, -5.0, 4.0], [-5.0, 3.0, 4.0], [3.0, -5.0, 4.0], [3.0, -12.0, 4.0]])
    plan = Plan.build(get_camera("p4p"), R_from_gimbal([0] * 4, [0] * 4), C, missions=(Mission("m", 0, 4),))
    rep = check_safety(box, plan, minimum_m=4.0)
    # waypoints: 5·√2 = 7.07, 5, 5, 12 m away; the middle segment passes the (0, 0) edge at 1·√2 = 1.41 m
    np.testing.assert_allclose(rep.waypoint_m, [np.hypot(5, 5), 5, 5, 12])
    np.testing.assert_allclose(rep.segment_m, [5, np.sqrt(2), 5])
    assert rep.violations == ("segment 1→2 passes 1.41 m from the model",)


def _plan(points):
    C = np.asarray(points, float)
    return Plan.build(get_camera("p4p"), R_from_gimbal([0] * len(C), [0] * len(C)), C)


def test_line_of_sight_breaks_exactly_once_each_way(box):
    from sightplan.plan.checks import check_line_of_sight

    gs = np.array([-10.0, -10.0, 1.5])
    plan = _plan([[-10, 30, 10],     # west of the box, clear sight, 40 m away
                  [30, 20, 4],       # the sight line crosses the box: hidden
                  [-10, 290, 5]])    # 300 m away: beyond a 200 m radius
    rep = check_line_of_sight(box, plan, radius_m=200, ground_station=gs, engine="embree")
    np.testing.assert_allclose(rep.distance_m, [np.linalg.norm([0, 40, 8.5]), np.linalg.norm([40, 30, 2.5]),
                                                np.linalg.norm([0, 300, 3.5])])
    assert list(rep.in_range) == [True, True, False]
    assert list(rep.unblocked) == [True, False, True]
    assert rep.mission_ok == (False,)
    assert len(rep.violations) == 2


def test_default_ground_station_is_the_regions_south_west_corner(box):
    from sightplan.plan.checks import default_ground_station

    plan = _plan([[-5, 12, 4], [25, -3, 4]])
    np.testing.assert_allclose(default_ground_station(box, plan), [-5, -3, 1.5])


def test_altitude_limit_follows_the_structure(box):
    from sightplan.plan.checks import check_altitude

    plan = _plan([[10, 5, 125],      # over the 8 m box: limit 8 + 120 = 128, fine
                  [600, 5, 130],     # 590 m away from it: limit 0 + 120, 10 m too high
                  [600, 5, 119]])    # below 120 m: fine
    rep = check_altitude(box, plan)
    np.testing.assert_allclose(rep.limit_z, [128, 120, 120])
    np.testing.assert_allclose(rep.over_m, [-3, 10, -1])
    assert rep.violations == ("waypoint 1 is 10.0 m above the altitude limit",)


def test_leg_and_mission_times_by_hand():
    from sightplan.plan.checks.battery import AIRCRAFT, leg_time, mission_time

    p4p = AIRCRAFT["p4p"]  # 8 m/s, 3 m/s up/down, 2 m/s², 2 s per photo
    # 100 m: accelerating and braking take 8²/2 = 32 m, so 100/8 + 8/2 = 16.5 s; 16 m never reaches 8 m/s: 2·√(16/2)
    np.testing.assert_allclose(leg_time([100.0, 16.0], 8.0, 2.0), [16.5, 2 * np.sqrt(8)])
    t, dist = mission_time(np.array([[0, 100, 0], [0, 100, 30]], float), np.zeros(3), p4p)
    # out 100 m (16.5 s), climb 30 m (30/3 + 3/2 = 11.5 s), back 100 m while descending (max(16.5, 11.5)), 2 photos
    assert t == pytest.approx(16.5 + 11.5 + 16.5 + 2 * 2)
    assert dist == pytest.approx(100 + 30 + np.hypot(100, 30))


def test_battery_split_covers_every_waypoint_and_fits_each_battery():
    from sightplan.plan.checks.battery import Aircraft, mission_time, split_by_battery

    ac = Aircraft("test", 8.0, 3.0, 2.0, flight_time_s=200.0, capture_s=2.0, reserve=0.25)  # 150 s usable
    C = np.stack([np.full(40, 20.0), np.arange(40) * 5.0, np.full(40, 10.0)], axis=1)  # a 195 m line, 5 m apart
    gs = np.zeros(3)
    plan, times = split_by_battery(_plan(C), gs, ac)
    assert len(plan.missions) > 1
    assert [m.start for m in plan.missions][0] == 0 and plan.missions[-1].stop == 40
    assert all(a.stop == b.start for a, b in zip(plan.missions, plan.missions[1:]))  # no waypoint left out
    for m, t in zip(plan.missions, times):
        assert t.time_s <= ac.usable_s
        assert t.time_s == pytest.approx(mission_time(C[m.start:m.stop], gs, ac)[0])
        if m.stop < 40:  # greedy: one more waypoint would not fit
            assert mission_time(C[m.start:m.stop + 1], gs, ac)[0] > ac.usable_s
    with pytest.raises(PlanError, match="cannot be reached"):
        split_by_battery(_plan([[5000.0, 0, 10]]), gs, ac)
