"""Safe from take-off to landing: the site's ground (never a basement), take-off points a pilot can use, the whole
trajectory checked and written out, the position error, and templates that pass their own checks on every model.

The fixture (:mod:`site_fixture`) is a 12 × 8 m house with a basement floor at −3.3 m standing on an 80 × 80 m
terrain block whose top is at −0.15 m: every take-off and ground is at −0.15, known by construction."""

from __future__ import annotations

from dataclasses import replace

import numpy as np
import pytest
import trimesh

from sightplan.camera.catalogue import get_camera
from sightplan.export import export_plan
from sightplan.geo import Georeference
from sightplan.geometry.poses import R_from_gimbal
from sightplan.model.load import load_model
from sightplan.model.scene import ElementTable, Scene
from sightplan.plan.checks.feasibility import FlightSettings, check_plan
from sightplan.plan.checks.gate import export_violations
from sightplan.plan.checks.safety import point_distances, segment_distances
from sightplan.plan.ground import ground_of, with_ground_z, without_terrain
from sightplan.plan.templates.registry import plan_from_template
from sightplan.plan.types import Mission, Plan
from site_fixture import write_basement_house

P4P = get_camera("p4p")
TERRAIN_TOP = -0.15
SAFETY = 10.0
DRONE_TEMPLATES = [("facade", {}), ("facade", {"footprint": "outline"}), ("orbit", {}), ("lawnmower", {}),
                   ("lawnmower", {"oblique_pitch_deg": -60.0})]


@pytest.fixture(scope="module")
def house(tmp_path_factory) -> Scene:
    path = write_basement_house(tmp_path_factory.mktemp("site") / "house.ifc")
    return load_model(str(path), cache=False)[0]


@pytest.fixture(scope="module")
def house_plans(house):
    settings = FlightSettings(safety_distance_m=SAFETY)
    return {f"{name} {params}": plan_from_template(name, house, P4P, params, settings) for name, params in DRONE_TEMPLATES}


def test_ground_is_the_terrain_not_the_basement(house):
    g = ground_of(house)
    assert g.source == "terrain" and g.level_m == pytest.approx(TERRAIN_TOP)
    assert float(house.bounds()[0][2]) == pytest.approx(-3.5)  # the basement slab's bottom: not the ground
    # beyond the terrain's edge, the terrain's top at its nearest vertex; over the house, still the terrain
    assert g.z([[0, 0], [6, 4], [500, -300]]) == pytest.approx([TERRAIN_TOP] * 3)


def test_ground_without_terrain_is_the_lowest_exterior_door(house):
    keep = ~np.isin(house.elements.ifc_class.astype(str), ["IfcSite"])
    bare = Scene.from_arrays(house.vertices, house.faces[keep[house.face_element]],
                             house.face_element[keep[house.face_element]], house.elements, metadata=house.metadata)
    g = ground_of(bare)
    # the front door's sill (z = 0) on the south wall; the interior door stands at 0 too but opens on no outside
    assert (g.source, g.level_m) == ("exterior door", 0.0)
    assert "exterior door" in g.reason and "-3.50" in g.reason
    # the user's height wins over everything
    assert ground_of(with_ground_z(bare, 1.25)).level_m == 1.25
    assert ground_of(with_ground_z(house, 1.25)).source == "user"


def test_sample_ground_is_its_door_sills_not_its_footings():
    scene, _ = load_model("sample")
    g = ground_of(scene)
    # the Duplex's footings reach −1.55 m; its entrance doors stand on z = 0 (Level 1)
    assert (g.source, g.level_m) == ("exterior door", 0.0) and float(scene.bounds()[0][2]) == pytest.approx(-1.55)


@pytest.mark.parametrize("which", [f"{n} {p}" for n, p in DRONE_TEMPLATES])
def test_every_template_takes_off_from_the_terrain_and_passes_its_checks(house, house_plans, which, tmp_path):
    plan, report = house_plans[which]
    assert report.ok, report.violations
    assert plan.parameters["takeoff_m"][2] == pytest.approx(TERRAIN_TOP)
    assert [p.takeoff_m[2] for p in report.paths] == pytest.approx([TERRAIN_TOP] * len(report.paths))
    v = report.error_m[1]
    assert (plan.C_world[:, 2] - v >= TERRAIN_TOP + 2.0 - 1e-3).all()  # the minimum height at the worst error
    obstacles = without_terrain(house)
    assert point_distances(obstacles, plan.C_world).min() >= SAFETY + np.hypot(*report.error_m)
    # the whole trajectory by exact distances: every take-off climb, flight out, return and landing
    seg = np.concatenate([p.segments() for p in report.paths])
    assert segment_distances(obstacles, seg[:, 0], seg[:, 1]).min() >= SAFETY + np.hypot(*report.error_m) - 1e-2
    # a pilot stands outside the footprint, at least the safety distance from the model
    for m in plan.missions:
        gs = np.array(m.ground_station)
        assert not (0 <= gs[0] <= 12 and 0 <= gs[1] <= 8)
        assert point_distances(obstacles, [[gs[0], gs[1], TERRAIN_TOP]])[0] >= SAFETY
    # exported without --force; the heights read back by pymavlink are the frames' heights above −0.15 m
    assert export_violations(plan, plan.parameters["takeoff_m"], house) == []
    mavwp = pytest.importorskip("pymavlink.mavwp")
    georef = Georeference.from_scene_metadata(house.metadata)
    paths = export_plan(plan, "wpl", tmp_path / "x.waypoints", georef, plan.parameters["takeoff_m"])
    loader = mavwp.MAVWPLoader()
    heights = []
    for path in paths:
        items = [loader.wp(k) for k in range(loader.load(str(path)))]
        assert items[0].z == pytest.approx(10.0 + TERRAIN_TOP, abs=1e-3)  # home on the terrain (RefElevation 10)
        assert items[-1].command == 21  # the return is written out and ends with a landing, not an RTL
        stops = [w for k, w in enumerate(items[:-1]) if w.command == 16 and items[k + 1].command == 205]
        heights += [w.z for w in stops]
    want = np.unique(np.round(plan.C_world[:, 2] - TERRAIN_TOP, 2))
    assert np.unique(np.round(heights, 2)) == pytest.approx(want, abs=0.01)


def test_the_return_is_written_at_the_checked_height(house, house_plans, tmp_path):
    plan, report = house_plans[f"orbit {dict()}"]
    mavwp = pytest.importorskip("pymavlink.mavwp")
    georef = Georeference.from_scene_metadata(house.metadata)
    paths = export_plan(plan, "wpl", tmp_path / "o.waypoints", georef, plan.parameters["takeoff_m"])
    loader = mavwp.MAVWPLoader()
    items = [loader.wp(k) for k in range(loader.load(str(paths[0])))]
    home_leg = items[-2]  # level flight home at the return height, above the take-off point, then land
    assert home_leg.z == pytest.approx(report.paths[0].return_z_m - TERRAIN_TOP, abs=1e-3)
    lat, lon, _ = georef.to_geodetic(np.array([report.paths[0].takeoff_m]))
    assert (home_leg.x, home_leg.y) == pytest.approx((lat[0], lon[0]), abs=1e-7)


def test_a_take_off_by_the_wall_is_refused_naming_the_part(house, house_plans):
    plan, _ = house_plans[f"facade {dict()}"]
    # the pilot 3 m south of the south wall: the climb and the landing pass 3 m from it
    station = (6.0, -3.0, TERRAIN_TOP + 1.5)
    one = Plan.build(plan.camera_of(0), plan.R_world_camera[:4], plan.C_world[:4],
                     missions=(Mission("south", 0, 4, station),))
    report = check_plan(house, one, FlightSettings(safety_distance_m=SAFETY, position_error_m="none"))
    assert "mission 'south': the take-off climb passes 3.00 m from the model at the worst (safety distance 10 m); " \
           "take-off at 6.0,-3.0" in report.violations
    assert any("the landing passes 3.00 m" in v for v in report.violations)
    assert report.missions[0].safety_ok is False
    # a pilot inside the footprint: the climb goes through the first floor's slab and the roof
    inside = Plan.build(plan.camera_of(0), plan.R_world_camera[:4], plan.C_world[:4],
                        missions=(Mission("south", 0, 4, (6.0, 4.0, 1.5)),))
    report = check_plan(house, inside, FlightSettings(safety_distance_m=SAFETY, position_error_m="none"))
    assert any("the take-off climb passes 0.00 m" in v for v in report.violations)


def _wall() -> Scene:
    """A 20 m long, 10 m high wall of no thickness in the plane y = 0, from x = −10 to 10."""
    box = trimesh.creation.box((20.0, 1e-6, 10.0), trimesh.transformations.translation_matrix((0, 0, 5.0)))
    return Scene.from_arrays(box.vertices, box.faces, np.zeros(len(box.faces), np.int32), ElementTable.build(["wall"]))


@pytest.mark.parametrize(("offset", "ok"), [(1.0, False), (1.6, True)])
def test_position_error_inflates_the_safety_distance(offset, ok):
    wall = _wall()
    C = np.array([[0.0, -(SAFETY + offset), 5.0]])
    plan = Plan.build(P4P, R_from_gimbal([0.0], [0.0], 0.0), C, missions=(Mission("m", 0, 1, (0.0, -60.0, 1.5)),))
    settings = FlightSettings(safety_distance_m=SAFETY, position_error_m=(1.5, 0.5), aircraft=None, vlos_radius_m=None)
    report = check_plan(wall, plan, settings)
    assert report.safety.waypoint_worst_m[0] == pytest.approx(SAFETY + offset - 1.5, abs=1e-6)  # a plane: exact
    assert (not any("waypoint 0" in v for v in report.violations)) is ok
    # the same frame above the wall's top strays only the vertical 0.5 m toward it
    top = Plan.build(P4P, R_from_gimbal([0.0], [-90.0], 0.0), np.array([[0.0, 0.0, 10 + SAFETY + 0.6]]),
                     missions=(Mission("m", 0, 1, (0.0, -60.0, 1.5)),))
    assert check_plan(wall, top, settings).safety.waypoint_worst_m[0] == pytest.approx(SAFETY + 0.1, abs=1e-6)


def test_templates_place_frames_by_the_error_preset(house):
    rtk = FlightSettings(safety_distance_m=SAFETY, position_error_m="rtk")
    plan, report = plan_from_template("facade", house, P4P, {}, rtk)
    assert report.ok
    # a facade column stands the safety distance + √(0.1² + 0.1²) + 1 cm from its wall
    assert point_distances(without_terrain(house), plan.C_world).min() == pytest.approx(SAFETY + np.hypot(.1, .1) + .01,
                                                                                        abs=1e-6)


def test_lawnmower_defaults_clear_the_top_by_the_safety_distance(house, house_plans):
    plan, _ = house_plans[f"lawnmower {dict()}"]
    # the targets' top is the roof at 6.3 m; the grid flies the placement distance above it
    assert plan.C_world[:, 2] == pytest.approx(6.3 + SAFETY + np.hypot(1.5, 0.5) + 0.01)


def test_a_pilot_station_given_by_latitude_and_longitude(house, tmp_path):
    """A station typed from a phone's map: 25 m from the site's reference point at azimuth 126.87° (20 m east, 15 m
    south; WGS 84 geodesic, computed by pyproj.Geod, not by the georeference) lands there, 1.5 m above the terrain."""
    import json

    from pyproj import Geod

    from test_cli import assert_clean_error, run_cli

    lon, lat, _ = Geod(ellps="WGS84").fwd(5.87, 51.838, np.degrees(np.arctan2(20.0, -15.0)), 25.0)
    model = write_basement_house(tmp_path / "house.ifc")
    out = tmp_path / "facade.json"
    res = run_cli("plan", "facade", str(model), "--no-cache", "--split", "--ground-station", f"geo:{lat:.9f},{lon:.9f}",
                  "-o", str(out), cwd=tmp_path)
    assert res.returncode == 0, res.stdout + res.stderr
    report = tmp_path / "check.json"
    res = run_cli("check", str(out), str(model), "--no-cache", "--ground-station", f"{lat:.9f},{lon:.9f}",
                  "--json", str(report), cwd=tmp_path)
    d = json.loads(report.read_text())
    # one pilot south-east of the house cannot see its north side; nothing else fails, and nothing is an error
    assert d["violations"] and all("hidden from the ground station" in v for v in d["violations"])
    assert res.returncode == 1 and "error:" not in res.stderr
    stations = {tuple(m["ground_station"]) for m in d["missions"]}
    assert len(stations) == 1
    np.testing.assert_allclose(stations.pop(), [20.0, -15.0, TERRAIN_TOP + 1.5], atol=0.01)
    # the longitude first: 5.87° N, 51.838° E is thousands of km away; the error says what to give
    assert_clean_error(run_cli("check", str(out), str(model), "--no-cache", "--ground-station", f"{lon},{lat}",
                               cwd=tmp_path), "km from the model", "latitude first")
    assert_clean_error(run_cli("check", str(out), str(model), "--no-cache", "--ground-station", "1,2,x",
                               cwd=tmp_path), "x,y,z", "lat,lon")


def test_the_position_error_is_recorded_with_the_checks_the_export_repeats(house, tmp_path):
    from sightplan.plan.checks.gate import recorded_settings

    settings = FlightSettings(safety_distance_m=SAFETY, position_error_m="rtk")
    plan, _ = plan_from_template("orbit", house, P4P, {}, settings)
    assert recorded_settings(plan).error == (0.1, 0.1)
    # placed for ±0.1 m, the orbit passes its checks at ±0.1 m; checked at the default ±1.5 m it would not
    assert export_violations(plan, scene=house) == []
    checks = plan.parameters["checks"]
    gnss = {**checks, "settings": {**checks["settings"], "position_error_m": [1.5, 0.5]}}
    assert export_violations(replace(plan, parameters={**plan.parameters, "checks": gnss}), scene=house)


def test_facade_sides_are_named_by_the_true_bearing_they_face(tmp_path):
    """Model +Y at 310° true: the model's south side faces 130° true, so it is the south-east side."""
    import math

    a = math.radians(50.0)
    turned = load_model(str(write_basement_house(tmp_path / "turned.ifc", true_north=(math.sin(a), math.cos(a)))),
                        cache=False)[0]
    plan, _ = plan_from_template("facade", turned, P4P, {}, FlightSettings(safety_distance_m=SAFETY))
    assert [m.name.split(" (")[0] for m in plan.missions][:4] == ["facade south-east", "facade north-east",
                                                                  "facade north-west", "facade south-west"]
