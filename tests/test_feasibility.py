"""Flight feasibility: missions split to keep line of sight and fit a battery, per-mission verdicts."""

from __future__ import annotations

import numpy as np
import pytest
import trimesh

from sightplan.camera.catalogue import get_camera
from sightplan.errors import PlanError
from sightplan.geometry.poses import R_from_gimbal
from sightplan.model.scene import ElementTable, Scene
from sightplan.plan.checks.battery import Aircraft, Rover, split_by_rover
from sightplan.plan.checks.feasibility import (
    FlightSettings,
    check_plan,
    corner_stations,
    plan_flights,
    split_by_line_of_sight,
)
from sightplan.plan.format import plan_from_dict, plan_to_dict
from sightplan.plan.types import Mission, Plan

# a 20 × 10 × 30 m tower: tall enough to hide one side of it from a ground station at the other
TOWER = trimesh.creation.box((20.0, 10.0, 30.0), trimesh.transformations.translation_matrix((10.0, 5.0, 15.0)))


@pytest.fixture(scope="module")
def tower() -> Scene:
    return Scene.from_arrays(TOWER.vertices, TOWER.faces, np.zeros(len(TOWER.faces)), ElementTable.build(["tower"]))


def _plan(C, missions=None) -> Plan:
    C = np.asarray(C, float)
    return Plan.build(get_camera("p4p"), R_from_gimbal(np.zeros(len(C)), np.zeros(len(C))), C, missions=missions)


def test_corner_stations_span_the_region(tower):
    plan = _plan([[-10, -5, 5], [30, 15, 5]])
    np.testing.assert_allclose(corner_stations(tower, plan), [[-10, -5, 1.5], [30, -5, 1.5], [30, 15, 1.5], [-10, 15, 1.5]])


def test_split_by_line_of_sight_moves_the_pilot_once(tower):
    # south side (y = −10) then north side (y = 20), at 5 m height: the tower hides the north side from the
    # south-west corner (−10, −10) and the south side from the north-east corner (30, 20)
    south = [[x, -10.0, 5.0] for x in (0.0, 10.0, 20.0)]
    north = [[x, 20.0, 5.0] for x in (20.0, 12.0, 6.0)]
    plan = _plan(south + north)
    stations = np.array([[-10.0, -10.0, 1.5], [30.0, 20.0, 1.5]])
    split = split_by_line_of_sight(tower, plan, 500.0, stations)
    # every sight line from (−10, −10) to a north waypoint crosses the tower's footprint (x = 0 is reached at
    # y = 10, 6.9 and 8.75 m, inside 0..10), and the NE corner cannot see (0, −10) behind the tower: the
    # SW station takes the south side, the NE one the north side
    assert [(m.start, m.stop) for m in split.missions] == [(0, 3), (3, 6)]
    assert split.missions[0].ground_station == (-10.0, -10.0, 1.5)
    assert split.missions[1].ground_station == (30.0, 20.0, 1.5)
    report = check_plan(tower, split, FlightSettings(safety_distance_m=2.0, aircraft=None))
    assert report.ok and all(m.line_of_sight_ok for m in report.missions)
    # the same plan flown from the SW corner only: exactly the three north waypoints are hidden
    single = check_plan(tower, plan, FlightSettings(safety_distance_m=2.0, aircraft=None, ground_stations=stations[:1]))
    assert list(np.flatnonzero(~single.in_sight)) == [3, 4, 5]
    assert single.missions[0].line_of_sight_ok is False
    assert "waypoints 3–5 are hidden from the ground station by the model" in single.violations
    # flown as one mission, the leg from the south side's east end (20, −10) to (20, 20) grazes the east wall
    assert [v for v in single.violations if "segment" in v] == ["segment 2→3 passes 0.00 m from the model"]


def test_a_waypoint_no_station_sees_is_reported_not_dropped(tower):
    plan = _plan([[0.0, -10.0, 5.0], [10.0, 2000.0, 5.0]])
    stations = np.array([[-10.0, -10.0, 1.5], [10.0, 1500.0, 1.5]])
    split = split_by_line_of_sight(tower, plan, 400.0, stations)
    # waypoint 1 is 500 m from the nearest station, beyond the radius: it goes with that station
    assert [(m.start, m.stop, m.ground_station) for m in split.missions] == [(0, 1, (-10.0, -10.0, 1.5)),
                                                                           (1, 2, (10.0, 1500.0, 1.5))]
    report = check_plan(tower, split, FlightSettings(safety_distance_m=2.0, vlos_radius_m=400.0, aircraft=None))
    assert report.violations == ("waypoint 1 is beyond the 400 m VLOS radius of the ground station (up to 500 m away)",)
    assert [m.line_of_sight_ok for m in report.missions] == [True, False]


def test_plan_flights_split_leaves_no_waypoint_out_and_fits_every_battery(tower):
    rng = np.random.default_rng(3)
    # a ring of 120 waypoints 30 m around the tower at 10–40 m height
    az = np.linspace(0, 2 * np.pi, 120, endpoint=False)
    C = np.stack([10 + 30 * np.sin(az), 5 + 30 * np.cos(az), rng.uniform(10, 40, 120)], axis=1)
    ac = Aircraft("small battery", 6.0, 2.0, 2.0, flight_time_s=240.0, capture_s=2.0, reserve=0.2)
    settings = FlightSettings(safety_distance_m=5.0, vlos_radius_m=200.0, aircraft=ac)
    report = plan_flights(tower, _plan(C), settings)
    missions = report.plan.missions
    assert missions[0].start == 0 and missions[-1].stop == 120
    assert all(a.stop == b.start and a.stop > a.start for a, b in zip(missions, missions[1:]))
    assert len(missions) > 2
    for m in report.missions:
        assert m.time_s <= ac.usable_s and m.battery_ok and m.line_of_sight_ok
    assert report.ok, report.violations
    assert report.total_time_s == pytest.approx(sum(m.time_s for m in report.missions))
    d = report.to_dict()
    assert [w["frame"] for w in d["waypoints"]] == list(range(120))
    assert d["missions"][1]["resume_waypoint"] == missions[1].start


def test_per_mission_verdicts_name_the_one_bad_mission(tower):
    # mission 2 holds one waypoint 2 m from the tower's west wall (x = 0): the only safety violation
    C = [[-10.0, 5.0, 10.0], [-10.0, 8.0, 10.0], [-2.0, 5.0, 10.0]]
    plan = _plan(C, missions=(Mission("a", 0, 2), Mission("b", 2, 3)))
    report = check_plan(tower, plan, FlightSettings(safety_distance_m=5.0, aircraft=None, vlos_radius_m=None,
                                                    position_error_m="none"))
    assert [m.safety_ok for m in report.missions] == [True, False]
    # the waypoint, and mission b's flight to it and away from it (its take-off and landing stay clear)
    assert report.violations[0] == "waypoint 2 (frame_00002) is 2.00 m from the model"
    assert all("mission 'b'" in v for v in report.violations[1:]) and len(report.violations) > 1


@pytest.mark.parametrize(("kwargs", "message"), [
    ({"safety_distance_m": 600.0, "vlos_radius_m": 500.0}, "not less than the VLOS radius"),
    ({"safety_distance_m": 0.0}, "safety distance: 0 is out of range: a positive number"),
    ({"safety_distance_m": float("nan")}, "safety distance: NaN is not a finite number"),
    ({"ground_stations": np.array([[0.0, np.nan, 0.0]])}, "finite"),
    ({"altitude_limit_m": -5.0}, "altitude limit"),
])
def test_impossible_settings_are_refused(kwargs, message):
    with pytest.raises(PlanError, match=message):
        FlightSettings(**kwargs)


def test_mission_ground_station_survives_the_plan_file():
    plan = _plan([[0, 0, 5], [1, 0, 5]], missions=(Mission("a", 0, 1, (1.0, 2.0, 3.0)), Mission("b", 1, 2)))
    back = plan_from_dict(plan_to_dict(plan))
    assert back.missions == plan.missions


def test_a_walked_route_splits_by_the_rovers_battery_and_checks_clean(tower):
    # a straight 100 m walk 5 m south of the tower, a frame every 2 m (51 frames)
    C = np.stack([np.linspace(-40.0, 60.0, 51), np.full(51, -5.0), np.full(51, 1.5)], axis=1)
    walker = Rover("test walker", speed_m_s=1.0, capture_s=2.0, limit_time_s=60.0, reserve=0.0)
    settings = FlightSettings(safety_distance_m=0.3, vlos_radius_m=None, altitude_limit_m=None, aircraft=walker)
    report = plan_flights(tower, _plan(C), settings)
    expected, times = split_by_rover(_plan(C), walker)
    assert [(m.start, m.stop) for m in report.plan.missions] == [(m.start, m.stop) for m in expected.missions]
    # each frame costs 2 m at 1 m/s plus a 2 s shot: 4 s; 60 s hold 15 frames (the first part: 14 legs + 15 shots = 58 s)
    assert report.plan.missions[0].stop == 15
    for m, t in zip(report.missions, times):
        assert m.battery_ok and m.time_s == pytest.approx(t.time_s) and m.time_s <= 60.0
    assert report.ok
