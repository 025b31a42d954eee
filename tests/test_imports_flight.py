"""Imports of flight-app missions: QGroundControl .plan, QGC WPL 110, DJI WPML (.kmz, or a bare template.kml or
waylines.wpml) and Litchi CSV.

Real QGroundControl and Mission Planner files (../shared/data/plans, skipped when absent) are
counted independently of the importer: with plain ``json`` (and geodesic distances from pyproj's
Geod for the distance-triggered survey), and with pymavlink for the WPL file. Exports of a known
plan read back to the same centres, headings and pitches; so do plans made on the bundled sample and
on the basement house, read back as ``check`` reads them, from the take-off point each file records.
"""

from __future__ import annotations

import csv
import json
import math
import zipfile
from pathlib import Path

import numpy as np
import pytest
from pyproj import Geod

from conftest import shared_file
from geoid_support import require_geoid
from sightplan.errors import PlanError
from sightplan.export import export_plan
from sightplan.geo import Georeference
from sightplan.geometry.poses import gimbal_from_R
from sightplan.plan.load import detect_format, load_plan
from test_exports import GEOREFS, TAKEOFF, angle_diff, facade_plan

GEOD = Geod(ellps="WGS84")


def plan_georef(plan) -> Georeference:
    return Georeference.from_dict(plan.parameters["georeference"])


def true_headings(plan) -> np.ndarray:
    h, _, _ = gimbal_from_R(plan.R_world_camera)
    return plan_georef(plan).true_heading(plan.C_world, h)


def pitches(plan) -> np.ndarray:
    return gimbal_from_R(plan.R_world_camera)[1]


# -- real QGroundControl files -----------------------------------------------------------------


def test_qgc_simple_items_real_file():
    path = shared_file("plans", "qgroundcontrol_sample.plan")
    doc = json.loads(path.read_text())
    items = doc["mission"]["items"]
    captures = [k for k, it in enumerate(items) if it["command"] == 2000]
    waypoints = [it for it in items if it["command"] == 16]
    plan = load_plan(path, camera="p4p")
    assert len(plan) == len(captures) == 1
    assert len(plan.waypoints) == len(waypoints) == 3
    # the photo is taken at the waypoint just before the capture command, 50 m above home
    wp = items[captures[0] - 1]
    home = doc["mission"]["plannedHomePosition"]
    georef = plan_georef(plan)
    assert georef.kind == "topocentric" and (georef.latitude_deg, georef.longitude_deg) == (home[0], home[1])
    np.testing.assert_allclose(plan.parameters["takeoff_m"], [0, 0, 0], atol=1e-6)
    np.testing.assert_allclose(plan.C_world[0], georef.from_geodetic(wp["params"][4], wp["params"][5],
                                                                     home[2] + wp["params"][6])[0], atol=0.01)
    # yaw null: the heading is along the flight, toward the next waypoint
    nxt = items[captures[0] + 1]
    azimuth = GEOD.inv(wp["params"][5], wp["params"][4], nxt["params"][5], nxt["params"][4])[0] % 360
    assert angle_diff(true_headings(plan)[0], azimuth) < 0.05
    assert pitches(plan)[0] == pytest.approx(-90.0)
    assert any("pitch -90° (nadir) assumed" in w for w in plan.parameters["warnings"])
    assert str(plan.camera_of(0).name).startswith("DJI Phantom 4 Pro")


def survey_frames_by_geodesics(items: list[dict]) -> tuple[int, list[float]]:
    """Photos of a survey's expanded items: one on each DO_SET_CAM_TRIGG_DIST with param3 = 1, then one every
    param1 metres of flight (geodesic) until param1 = 0. Returns the count and the distances between the photos."""
    count, trigger, travelled, next_at, prev = 0, None, 0.0, 0.0, None
    spots: list[float] = []
    for it in items:
        p = it["params"]
        if it["command"] == 16:
            if prev is not None and trigger:
                length = GEOD.inv(prev[1], prev[0], p[5], p[4])[2]
                while next_at <= travelled + length + 1e-6:
                    count += 1
                    spots.append(next_at)
                    next_at += trigger
                travelled += length
            prev = (p[4], p[5])
        elif it["command"] == 206:
            trigger = p[0] if p[0] > 0 else None
            travelled, next_at = 0.0, p[0]
            if trigger and p[2] == 1:
                count += 1
                spots.append(0.0)
    return count, spots


def test_qgc_survey_real_file():
    path = shared_file("plans", "qgroundcontrol_sample_with_survey.plan")
    doc = json.loads(path.read_text())
    survey = next(it for it in doc["mission"]["items"] if it.get("complexItemType") == "survey")
    tsi = survey["TransectStyleComplexItem"]
    items = tsi["Items"]
    expected, _ = survey_frames_by_geodesics(items)
    plan = load_plan(path, camera="p4p")
    assert len(plan) == expected == 7
    assert abs(len(plan) - tsi["CameraShots"]) <= 1  # QGroundControl's own estimate: ⌈distance / trigger distance⌉
    assert len(plan.waypoints) == sum(it["command"] == 16 for it in items) == len(tsi["VisualTransectPoints"])
    np.testing.assert_allclose(pitches(plan), -90.0)  # survey: nadir
    assert not plan.parameters["warnings"]
    # every photo on the flight path at the survey altitude; consecutive photos of one trigger run 25 m apart
    georef = plan_georef(plan)
    home_h = doc["mission"]["plannedHomePosition"][2]
    lat, lon, h = georef.to_geodetic(plan.C_world)
    np.testing.assert_allclose(h - home_h, 50.0, atol=0.01)
    first = items[0]["params"]
    assert GEOD.inv(first[5], first[4], lon[0], lat[0])[2] < 0.05  # the first photo at the first waypoint
    gap = GEOD.inv(lon[1], lat[1], lon[2], lat[2])[2]
    assert gap == pytest.approx(items[1]["params"][0], abs=0.05)  # 2nd → 3rd: one trigger distance on a straight leg
    # headings along the flight direction: the first transect flies west
    assert angle_diff(true_headings(plan)[0], 270.0) < 0.1


def test_qgc_structure_scan_real_file():
    path = shared_file("plans", "qgroundcontrol_sample_with_structured_scan.plan")
    doc = json.loads(path.read_text())
    scan = next(it for it in doc["mission"]["items"] if it.get("complexItemType") == "StructureScan")
    cc = scan["CameraCalc"]
    d, side, frontal = cc["DistanceToSurface"], cc["AdjustedFootprintSide"], cc["AdjustedFootprintFrontal"]
    # the polygon in a local east/north plane (equirectangular about its first vertex)
    lat0, lon0 = scan["polygon"][0]
    k = math.pi / 180 * 6371008.8
    xy = np.array([[(lon - lon0) * k * math.cos(math.radians(lat0)), (lat - lat0) * k] for lat, lon in scan["polygon"]])
    edges = np.roll(xy, -1, axis=0) - xy
    perimeter = np.linalg.norm(edges, axis=1).sum()
    prev = np.roll(edges, 1, axis=0)
    turns = np.arctan2(prev[:, 0] * edges[:, 1] - prev[:, 1] * edges[:, 0], np.einsum("ij,ij->i", prev, edges))
    assert np.all(turns < 0)  # convex and clockwise, as QGroundControl flies it
    # offsetting a convex polygon outward by d with mitred corners adds 2·d·tan(turn/2) per corner
    offset_perimeter = perimeter + 2 * d * np.tan(np.abs(turns) / 2).sum()
    per_layer = 1 + math.floor(offset_perimeter / side)  # one photo on starting, then one every `side` metres
    assert 0.05 < offset_perimeter / side % 1 < 0.95  # not at a rounding edge
    plan = load_plan(path, camera="p4p")
    assert len(plan) == scan["Layers"] * per_layer == 50
    georef = plan_georef(plan)
    home_h = doc["mission"]["plannedHomePosition"][2]
    heights = georef.to_geodetic(plan.C_world)[2] - home_h
    top = scan["StructureHeight"] - frontal / 2
    np.testing.assert_allclose(heights[:per_layer], top, atol=0.01)
    np.testing.assert_allclose(heights[per_layer:], top - frontal, atol=0.01)
    np.testing.assert_allclose(pitches(plan), scan["GimbalPitch"], atol=1e-9)
    # every photo looks at the structure from at least the distance to the surface
    poly = georef.from_geodetic([p[0] for p in scan["polygon"]], [p[1] for p in scan["polygon"]], [home_h] * 4)[:, :2]
    centroid = poly.mean(axis=0)
    forward = plan.R_world_camera[:, :2, 2]
    assert np.all(np.einsum("ij,ij->i", forward, centroid - plan.C_world[:, :2]) > 0)
    a, b = poly, np.roll(poly, -1, axis=0)
    for c in plan.C_world[:, :2]:
        t = np.clip(np.einsum("ij,ij->i", c - a, b - a) / np.einsum("ij,ij->i", b - a, b - a), 0, 1)
        assert np.linalg.norm(a + t[:, None] * (b - a) - c, axis=1).min() > d - 0.1


def test_qgc_digicam_without_waypoints_real_file():
    path = shared_file("plans", "qgroundcontrol_sample_with_digicam_control.plan")
    items = json.loads(path.read_text())["mission"]["items"]
    assert [it["command"] for it in items] == [203]  # a photo and no position at all
    with pytest.raises(PlanError, match="has no waypoint"):
        load_plan(path, camera="p4p")


def test_wpl_real_file_with_pymavlink():
    mavwp = pytest.importorskip("pymavlink.mavwp")
    path = shared_file("plans", "mission_planner_sample.txt")
    assert detect_format(path) == "wpl"
    loader = mavwp.MAVWPLoader()
    n = loader.load(str(path))
    wps = [loader.wp(k) for k in range(n)]
    nav = [w for w in wps[1:] if w.command == 16]
    plan = load_plan(path, camera="p4p")
    assert len(plan) == len(nav) == 2  # no photo command: every waypoint is a frame
    assert any("no photo command" in w for w in plan.parameters["warnings"])
    georef = plan_georef(plan)
    assert (georef.latitude_deg, georef.longitude_deg, georef.height_m) == (wps[0].x, wps[0].y, wps[0].z)
    assert all(w.frame == 5 for w in nav)  # MAV_FRAME_GLOBAL_INT: heights above sea level
    np.testing.assert_allclose(plan.C_world, georef.from_geodetic([w.x for w in nav], [w.y for w in nav],
                                                                  [w.z for w in nav]), atol=0.01)


# -- export → import ---------------------------------------------------------------------------


@pytest.mark.parametrize("fmt, ext", [("qgc", "plan"), ("wpml", "kmz"), ("wpl", "waypoints")])
@pytest.mark.parametrize("kind", GEOREFS)
def test_export_import_round_trip(tmp_path, fmt, ext, kind):
    if fmt == "wpml":
        require_geoid()  # DJI's take-off reference height is ellipsoidal
    georef, _ = GEOREFS[kind]
    plan = facade_plan()
    paths = export_plan(plan, fmt, tmp_path / f"facade.{ext}", georef, TAKEOFF)
    back = [load_plan(p, georef=georef, camera="m3e") for p in paths]
    C = np.vstack([b.C_world for b in back])
    np.testing.assert_allclose(C, plan.C_world, atol=0.1)
    h0, p0, _ = gimbal_from_R(plan.R_world_camera)
    h1, p1, r1 = (np.concatenate(v) for v in zip(*(gimbal_from_R(b.R_world_camera) for b in back)))
    assert max(angle_diff(a, b) for a, b in zip(h0, h1)) < 0.01
    np.testing.assert_allclose(p1, p0, atol=0.01)
    np.testing.assert_allclose(r1, 0.0, atol=1e-9)
    missions = [m.name for b in back for m in b.missions]
    assert len(missions) == 2
    for b in back:
        np.testing.assert_allclose(b.parameters["takeoff_m"], TAKEOFF, atol=0.01)
    if fmt != "wpl":  # QGroundControl keeps sightplan's names; WPML the takePhoto file suffixes
        assert [n for b in back for n in b.frame_names] == plan.frame_names.tolist()


def test_wpml_import_without_georeference_uses_the_take_off_point(tmp_path):
    require_geoid()
    georef, _ = GEOREFS["projected"]
    plan = facade_plan()
    paths = export_plan(plan, "wpml", tmp_path / "facade.kmz", georef, TAKEOFF)  # a .kmz per mission
    h0, _, _ = gimbal_from_R(plan.R_world_camera)
    start = 0
    for path in paths:
        back = load_plan(path)  # camera from the payload (Mavic 3E), frame: topocentric at the take-off point
        assert back.camera_of(0) == plan.camera_of(0)
        own = plan_georef(back)
        assert own.kind == "topocentric" and own.north_deg == 0.0
        np.testing.assert_allclose(back.parameters["takeoff_m"], 0.0, atol=1e-6)
        part = slice(start, start + len(back))
        start += len(back)
        lat, lon, h = georef.to_geodetic(plan.C_world[part])
        np.testing.assert_allclose(back.C_world, own.from_geodetic(lat, lon, h), atol=0.1)
        # the same true headings in both frames
        want = georef.true_heading(plan.C_world[part], h0[part])
        assert max(angle_diff(a, b) for a, b in zip(true_headings(back), want)) < 0.01
    assert start == len(plan)


def test_wpml_template_only(tmp_path):
    require_geoid()
    georef, _ = GEOREFS["projected"]
    plan = facade_plan()
    (path,) = export_plan(plan, "wpml", tmp_path / "facade.kmz", georef, TAKEOFF, mission=1)  # one .kmz: "east"
    plan = plan.subset(np.arange(plan.missions[1].start, plan.missions[1].stop))
    only = tmp_path / "template_only.kmz"
    with zipfile.ZipFile(path) as z, zipfile.ZipFile(only, "w") as out:
        out.writestr("wpmz/template.kml", z.read("wpmz/template.kml"))
    back = load_plan(only, georef=georef)
    np.testing.assert_allclose(back.C_world, plan.C_world, atol=0.1)
    h0, p0, _ = gimbal_from_R(plan.R_world_camera)
    h1, p1, _ = gimbal_from_R(back.R_world_camera)
    assert max(angle_diff(a, b) for a, b in zip(h0, h1)) < 0.01
    np.testing.assert_allclose(p1, p0, atol=0.01)


def test_wpml_distance_trigger_follow_wayline_and_relative_gimbal_yaw(tmp_path):
    georef = Georeference.from_origin(47.0, 8.0, 500.0)  # model +Y north
    lat, lon, _ = (v.tolist() for v in georef.to_geodetic([[0, 0, 0], [0, 30, 0], [40, 30, 0]]))
    wpml = "http://www.dji.com/wpmz/1.0.6"  # another WPML version than the exporter's

    def mark(k: int, actions: str) -> str:
        return (f"<Placemark><Point><coordinates>{lon[k]!r},{lat[k]!r}</coordinates></Point><wpml:index>{k}</wpml:index>"
                f"<wpml:executeHeight>20</wpml:executeHeight><wpml:waypointHeadingParam><wpml:waypointHeadingMode>"
                f"followWayline</wpml:waypointHeadingMode></wpml:waypointHeadingParam>{actions}</Placemark>")

    photo = "<wpml:action><wpml:actionActuatorFunc>takePhoto</wpml:actionActuatorFunc></wpml:action>"
    gimbal = ("<wpml:action><wpml:actionActuatorFunc>gimbalRotate</wpml:actionActuatorFunc><wpml:actionActuatorFuncParam>"
              "<wpml:gimbalRotateMode>relativeAngle</wpml:gimbalRotateMode><wpml:gimbalPitchRotateEnable>1"
              "</wpml:gimbalPitchRotateEnable><wpml:gimbalPitchRotateAngle>-35</wpml:gimbalPitchRotateAngle>"
              "<wpml:gimbalYawRotateEnable>1</wpml:gimbalYawRotateEnable><wpml:gimbalYawRotateAngle>-90"
              "</wpml:gimbalYawRotateAngle></wpml:actionActuatorFuncParam></wpml:action>")
    every_10m = ("<wpml:actionGroup><wpml:actionGroupStartIndex>0</wpml:actionGroupStartIndex><wpml:actionGroupEndIndex>1"
                 "</wpml:actionGroupEndIndex><wpml:actionTrigger><wpml:actionTriggerType>multipleDistance"
                 "</wpml:actionTriggerType><wpml:actionTriggerParam>10</wpml:actionTriggerParam></wpml:actionTrigger>"
                 f"{photo}</wpml:actionGroup>")
    at_2 = ("<wpml:actionGroup><wpml:actionGroupStartIndex>2</wpml:actionGroupStartIndex><wpml:actionGroupEndIndex>2"
            f"</wpml:actionGroupEndIndex><wpml:actionTrigger><wpml:actionTriggerType>reachPoint</wpml:actionTriggerType>"
            f"</wpml:actionTrigger>{gimbal}{photo}</wpml:actionGroup>")
    doc = (f"<kml xmlns='http://www.opengis.net/kml/2.2' xmlns:wpml='{wpml}'><Document><wpml:missionConfig>"
           f"<wpml:takeOffRefPoint>{lat[0]!r},{lon[0]!r},500</wpml:takeOffRefPoint></wpml:missionConfig><Folder>"
           f"<wpml:executeHeightMode>relativeToStartPoint</wpml:executeHeightMode><wpml:waylineId>0</wpml:waylineId>"
           f"{mark(0, every_10m)}{mark(1, '')}{mark(2, at_2)}</Folder></Document></kml>")
    path = tmp_path / "hand.kmz"
    with zipfile.ZipFile(path, "w") as z:
        z.writestr("wpmz/waylines.wpml", doc)
    plan = load_plan(path, camera="m3e")
    np.testing.assert_allclose(plan.C_world, [[0, 0, 20], [0, 10, 20], [0, 20, 20], [0, 30, 20], [40, 30, 20]], atol=0.01)
    h, p, _ = gimbal_from_R(plan.R_world_camera)
    for got, want in zip(h, [0, 0, 0, 0, 90 - 90]):  # along the flight north; at the last point east, gimbal −90
        assert angle_diff(got, want) < 0.01
    np.testing.assert_allclose(p, [-90, -90, -90, -90, -35], atol=1e-9)  # no pitch before the gimbalRotate: nadir
    assert any("nadir" in w for w in plan.parameters["warnings"])


def test_qgc_commands_set_heading_pitch_and_region_of_interest(tmp_path):
    georef = Georeference.from_origin(47.0, 8.0, 100.0)  # model +Y north, z 0 at the home height
    lat, lon, _ = georef.to_geodetic([[0, 10, 20], [20, 10, 20], [20, 30, 0]])

    def item(command, params, frame=2):
        return {"type": "SimpleItem", "command": command, "frame": frame, "params": params, "autoContinue": True}

    items = [
        item(22, [0, 0, 0, None, lat[0], lon[0], 20], 3),
        item(16, [0, 0, 0, None, lat[0], lon[0], 20], 3),
        item(205, [-30, 0, 0, 0, 0, 0, 2]), item(2000, [0, 0, 1, 0, 0, 0, 0]),      # along the flight: east
        item(115, [200, 0, 0, 0, 0, 0, 0]), item(2000, [0, 0, 1, 0, 0, 0, 0]),      # absolute yaw 200
        item(1000, [-45, 10, 0, 0, 0, 0, 0]), item(2000, [0, 0, 1, 0, 0, 0, 0]),    # gimbal yaw +10 relative
        item(1000, [-45, 0, 0, 0, 0, 0, 0]),
        item(16, [0, 0, 0, 45, lat[1], lon[1], 20], 3),
        item(203, [0, 0, 0, 0, 1, 0, 0]),                                           # yaw 45 at the waypoint
        item(203, [0, 0, 0, 0, 0, 0, 0]),                                           # no shoot command: ignored
        item(201, [3, 0, 0, 0, lat[2], lon[2], 0], 3), item(2000, [0, 0, 1, 0, 0, 0, 0]),  # look at (20, 30, 0)
        item(20, [0] * 7),
    ]
    doc = {"fileType": "Plan", "version": 1, "mission": {"version": 2, "items": items, "plannedHomePosition": [47.0, 8.0, 100.0],
                                                          "hoverSpeed": 5}}
    path = tmp_path / "commands.plan"
    path.write_text(json.dumps(doc))
    plan = load_plan(path, camera="m3e")
    assert len(plan) == 5
    np.testing.assert_allclose(plan.C_world, [[0, 10, 20]] * 3 + [[20, 10, 20]] * 2, atol=0.01)
    h, p, _ = gimbal_from_R(plan.R_world_camera)
    look = math.degrees(math.atan2(-20, 20))
    for got, want in zip(h, [90, 200, 210, 45, 0]):
        assert angle_diff(got, want) < 0.01
    np.testing.assert_allclose(p, [-30, -30, -45, -45, look], atol=0.01)
    assert any("DO_DIGICAM_CONTROL" in w for w in plan.parameters["warnings"])


# -- bad input ---------------------------------------------------------------------------------


def qgc_doc(lat) -> dict:
    return {"fileType": "Plan", "version": 1, "mission": {"version": 2, "plannedHomePosition": [47.0, 8.0, 400.0], "items": [
        {"type": "SimpleItem", "command": 16, "frame": 3, "doJumpId": 1, "params": [0, 0, 0, None, lat, 8.0, 20]},
        {"type": "SimpleItem", "command": 2000, "frame": 2, "doJumpId": 2, "params": [0, 0, 1, 0, 0, 0, 0]}]}}


@pytest.mark.parametrize("lat", [None, float("nan")])
def test_qgc_nan_latitude(tmp_path, lat):
    path = tmp_path / "nan.plan"
    path.write_text(json.dumps(qgc_doc(lat)))  # NaN is written as the (non-standard) literal NaN
    with pytest.raises(PlanError, match=r"nan.plan, mission item 1: NAV_WAYPOINT latitude is not a finite number"):
        load_plan(path, camera="m3e")


@pytest.mark.parametrize("text, message", [
    ("{\"fileType\": \"Plan\",", "not JSON"),
    ("{\"fileType\": \"Mission\"}", "not a QGroundControl plan"),
    ("{\"fileType\": \"Plan\", \"mission\": {\"items\": []}}", "plannedHomePosition"),
    ("{\"fileType\": \"Plan\", \"mission\": {\"plannedHomePosition\": [47, 8, 0], \"items\": [{\"type\": \"SimpleItem\"}]}}",
     "mission item 1: the SimpleItem lacks 'command'"),
    ("{\"fileType\": \"Plan\", \"mission\": {\"plannedHomePosition\": [47, 8, 0], \"items\": "
     "[{\"type\": \"ComplexItem\", \"complexItemType\": \"survey\"}]}}", "no expanded 'Items'"),
])
def test_qgc_corrupt_files(tmp_path, text, message):
    path = tmp_path / "bad.plan"
    path.write_text(text)
    with pytest.raises(PlanError, match=message):
        load_plan(path, camera="m3e")


def test_qgc_without_camera_asks_for_one(tmp_path):
    path = tmp_path / "ok.plan"
    path.write_text(json.dumps(qgc_doc(47.0001)))
    with pytest.raises(PlanError, match="--camera"):
        load_plan(path)
    assert len(load_plan(path, camera="m3e")) == 1


def test_wpl_corrupt_lines(tmp_path):
    path = tmp_path / "bad.waypoints"
    path.write_text("QGC WPL 110\n0\t1\t0\t16\t0\t0\t0\t0\t47\t8\t400\t1\n1\t0\t3\t16\t0\t0\t0\t0\t47.1\t8\n")
    with pytest.raises(PlanError, match="bad.waypoints, line 3: expected 12 values"):
        load_plan(path, camera="m3e")
    path.write_text("QGC WPL 110\n0\t1\t0\t16\t0\t0\t0\t0\t47\t8\t400\t1\n1\t0\t3\t16\t0\t0\t0\t0\tnan\t8\t20\t1\n")
    with pytest.raises(PlanError, match="line 3: NAV_WAYPOINT latitude is not a finite number"):
        load_plan(path, camera="m3e")
    path.write_text("QGC WPL 100\n")
    with pytest.raises(PlanError, match="not a QGC WPL 110"):
        load_plan(path, fmt="wpl", camera="m3e")


def test_corrupt_kmz(tmp_path):
    not_zip = tmp_path / "a.kmz"
    not_zip.write_text("hello")
    with pytest.raises(PlanError, match="a.kmz is not a KMZ"):
        load_plan(not_zip, camera="m3e")
    no_wpmz = tmp_path / "b.kmz"
    with zipfile.ZipFile(no_wpmz, "w") as z:
        z.writestr("doc.kml", "<kml/>")
    with pytest.raises(PlanError, match="b.kmz: no wpmz/waylines.wpml or wpmz/template.kml"):
        load_plan(no_wpmz, camera="m3e")
    bad_xml = tmp_path / "c.kmz"
    with zipfile.ZipFile(bad_xml, "w") as z:
        z.writestr("wpmz/waylines.wpml", "<kml><Document><Folder>")
    with pytest.raises(PlanError, match="c.kmz, wpmz/waylines.wpml: not valid XML"):
        load_plan(bad_xml, camera="m3e")
    no_height = tmp_path / "d.kmz"
    with zipfile.ZipFile(no_height, "w") as z:
        z.writestr("wpmz/waylines.wpml", "<kml xmlns='http://www.opengis.net/kml/2.2'><Document><Folder><Placemark>"
                                         "<Point><coordinates>8,47</coordinates></Point></Placemark></Folder></Document></kml>")
    with pytest.raises(PlanError, match="Placemark 1: no height"):
        load_plan(no_height, camera="m3e")


def lying_zip(path: Path, name: str, megabytes: int, declared: int = 1000) -> Path:
    """A zip whose entry ``name`` inflates to ``megabytes`` MB of zeros while its headers declare ``declared`` bytes."""
    import struct

    with zipfile.ZipFile(path, "w", zipfile.ZIP_DEFLATED) as z, z.open(name, "w") as fh:
        for _ in range(megabytes):
            fh.write(bytes(1 << 20))
    raw = bytearray(path.read_bytes())
    struct.pack_into("<I", raw, raw.find(b"PK\x03\x04") + 22, declared)  # the local header's size
    struct.pack_into("<I", raw, raw.find(b"PK\x01\x02") + 24, declared)  # the central directory's
    path.write_bytes(raw)
    return path


def test_a_kmz_whose_entry_lies_about_its_size_is_counted_not_trusted(tmp_path):
    """80 MB of zeros declared as 1 kB: read a block at a time, never all at once, and refused as a broken archive
    (the old reader inflated it whole, then failed with a BadZipFile)."""
    import tracemalloc

    kmz = lying_zip(tmp_path / "liar.kmz", "wpmz/waylines.wpml", 80)
    assert kmz.stat().st_size < 1 << 20
    tracemalloc.start()
    try:
        with pytest.raises(PlanError, match="liar.kmz, wpmz/waylines.wpml: the archive is broken"):
            load_plan(kmz, camera="m3e")
        peak = tracemalloc.get_traced_memory()[1]
    finally:
        tracemalloc.stop()
    assert peak < 16 << 20, f"{peak / 2**20:.0f} MB"
    big = lying_zip(tmp_path / "big.kmz", "wpmz/waylines.wpml", 70, declared=70 << 20)  # honest, over the limit
    with pytest.raises(PlanError, match="73 MB unpacked, too large for a mission file"):
        load_plan(big, camera="m3e")


def test_detect_format_by_name_and_first_line(tmp_path):
    wpl = tmp_path / "mission.txt"
    wpl.write_text("QGC WPL 110\n")
    colmap = tmp_path / "images.txt"
    colmap.write_text("# Image list with two lines of data per image:\n")
    assert detect_format(wpl) == "wpl" and detect_format(colmap) == "colmap"
    assert detect_format(tmp_path / "m.plan") == "qgc" and detect_format(tmp_path / "m.kmz") == "wpml"
    assert detect_format(tmp_path / "m.waypoints") == "wpl"


def test_relative_heights_take_off_from_the_models_ground(tmp_path):
    """An app's home altitude (488 m here) against a model at a nominal elevation of 0 is not in the model's datum:
    with ground_z, heights above home start there, and a warning says why."""

    def item(cmd, params, frame=3):
        return {"type": "SimpleItem", "command": cmd, "frame": frame, "params": params, "autoContinue": True}

    mission = {"fileType": "Plan", "version": 1, "groundStation": "QGroundControl",
               "mission": {"version": 2, "plannedHomePosition": [41.8744, -87.6394, 488.0], "items": [
                   item(22, [0, 0, 0, None, 41.8744, -87.6394, 30]),
                   item(16, [0, 0, 0, 90.0, 41.8745, -87.6394, 30]),
                   item(205, [-45, 0, 0, 0, 0, 0, 2], frame=2),
                   item(2000, [0, 0, 1, 0, 0, 0, 0], frame=2)]}}
    path = tmp_path / "m.plan"
    path.write_text(json.dumps(mission))
    geo = Georeference.from_origin(41.8744, -87.6394, 0.0)  # a model whose site elevation is nominal
    plan = load_plan(path, camera="p4p", georef=geo, ground_z=-1.0)
    # 0.0001° of latitude north of the origin is 11.1 m; 30 m above a take-off on the ground at z = −1
    np.testing.assert_allclose(plan.C_world[0], [0.0, 11.1, 29.0], atol=0.05)
    assert plan.parameters["home"]["from"] == "ground"
    assert any("489.0 m above the model's ground (z -1.00 m): not in the model's vertical datum" in w
               for w in plan.parameters["warnings"])
    plain = load_plan(path, camera="p4p", georef=geo)
    assert plain.C_world[0, 2] == pytest.approx(518.0, abs=0.05)  # the app's home altitude taken literally


# -- the take-off reference a file carries ---------------------------------------------------------------------

SITE = Georeference.from_origin(47.0, 8.0, 400.0)  # a model whose height 0 is 400 m above sea level


def reference_plan(tmp_path, home, name: str = "home.plan"):
    """A QGroundControl plan with ``home`` as its plannedHomePosition and one photo 20 m above it, 11.1 m north."""
    def item(cmd, params, frame=3):
        return {"type": "SimpleItem", "command": cmd, "frame": frame, "params": params, "autoContinue": True}

    doc = {"fileType": "Plan", "version": 1, "mission": {"version": 2, "plannedHomePosition": home, "items": [
        item(16, [0, 0, 0, 0.0, 47.0001, 8.0, 20]), item(205, [-30, 0, 0, 0, 0, 0, 2], frame=2),
        item(2000, [0, 0, 1, 0, 0, 0, 0], frame=2)]}}
    path = tmp_path / name
    path.write_text(json.dumps(doc))
    return path


@pytest.mark.parametrize("height, z0, source, warning", [
    (401.2, 1.2, "file", None),  # a take-off 1.2 m above the site's ground: the file's, as it gives it
    (430.0, 30.0, "file", "30.0 m above the model's ground (z 0.00 m): used as the file gives it"),
    (888.0, 0.0, "ground", "488.0 m above the model's ground (z 0.00 m): not in the model's vertical datum"),
    (None, 0.0, "ground", "planned home position has no height"),
])
def test_the_files_home_is_the_take_off_unless_unusable(tmp_path, height, z0, source, warning):
    path = reference_plan(tmp_path, [47.0, 8.0, height])
    plan = load_plan(path, camera="m3e", georef=SITE, ground_z=0.0)
    np.testing.assert_allclose(plan.C_world[0], [0.0, 11.12, z0 + 20.0], atol=0.01)
    np.testing.assert_allclose(plan.parameters["takeoff_m"], [0.0, 0.0, z0], atol=0.01)
    assert plan.parameters["home"]["from"] == source
    said = [w for w in plan.parameters["warnings"] if "home" in w]
    assert (said == []) if warning is None else any(warning in w for w in said), said


def test_a_home_kilometres_away_and_a_take_off_height_given(tmp_path):
    far = reference_plan(tmp_path, [47.05, 8.0, 401.2], "far.plan")  # 5.6 km north of the model
    plan = load_plan(far, camera="m3e", georef=SITE, ground_z=-0.5)
    assert any("lies 5.6 km from the model's origin: not the site's take-off point" in w
               for w in plan.parameters["warnings"])
    assert plan.parameters["home"]["from"] == "ground"
    assert plan.parameters["takeoff_m"][2] == pytest.approx(-0.5, abs=0.01)
    without_ground = load_plan(far, camera="m3e", georef=SITE)  # nothing to put in its place: kept, with a warning
    assert without_ground.parameters["home"]["from"] == "file"
    assert any("check the file and the model's georeference" in w for w in without_ground.parameters["warnings"])
    given = load_plan(reference_plan(tmp_path, [47.0, 8.0, 401.2]), camera="m3e", georef=SITE, ground_z=0.0,
                      takeoff_z=3.0)  # the user's take-off height replaces the file's
    np.testing.assert_allclose(given.C_world[0, 2], 23.0, atol=0.01)
    assert given.parameters["home"]["from"] == "given"
    assert any("replaces the QGroundControl planned home position's, +1.80 m from it" in w
               for w in given.parameters["warnings"])


@pytest.mark.parametrize("home, message", [
    ([95.0, 8.0, 400.0], r"home.plan: 'plannedHomePosition': latitude 95.0 / longitude 8.0 out of range"),
    ([None, 8.0, 400.0], r"home.plan: 'plannedHomePosition': its latitude and longitude are not finite numbers"),
])
def test_a_home_out_of_range_is_one_clear_error(tmp_path, home, message):
    with pytest.raises(PlanError, match=message) as info:
        load_plan(reference_plan(tmp_path, home), camera="m3e", georef=SITE, ground_z=0.0)
    assert "\n" not in str(info.value)


def test_wpl_home_line_is_the_take_off(tmp_path):
    path = tmp_path / "m.waypoints"
    lines = ["QGC WPL 110", "0\t1\t0\t16\t0\t0\t0\t0\t47.0\t8.0\t{h}\t1", "1\t0\t3\t16\t0\t0\t0\t0\t47.0001\t8.0\t20\t1"]
    path.write_text("\n".join(lines).format(h="402.5") + "\n")
    plan = load_plan(path, camera="m3e", georef=SITE, ground_z=0.0)  # no photo command: a frame at the waypoint
    np.testing.assert_allclose(plan.C_world[0], [0.0, 11.12, 22.5], atol=0.01)
    assert plan.parameters["home"]["from"] == "file"
    path.write_text("\n".join(lines).format(h="nan") + "\n")
    plan = load_plan(path, camera="m3e", georef=SITE, ground_z=0.0)
    np.testing.assert_allclose(plan.C_world[0], [0.0, 11.12, 20.0], atol=0.01)
    assert any("home position (line 0) has no height" in w for w in plan.parameters["warnings"])


# -- DJI Pilot 2 waypoint missions without photo actions, and bare template.kml / waylines.wpml ---------------------

PILOT2 = Path(__file__).parent / "fixtures" / "dji_pilot2_waypoints"
# the fixture's waypoints: longitude, latitude, height above take-off, heading, gimbal pitch (as DJI Pilot 2 wrote them)
PILOT2_WAYPOINTS = [(5.8698, 51.8379, 20, -30, -30), (5.8702, 51.8379, 25, 60, -45), (5.8702, 51.83815, 25, 150, -60),
                    (5.8698, 51.83815, 30, -120, -90)]
HOUSE_SITE = Georeference.from_origin(51.838, 5.87, 10.0)  # the basement house's IfcSite (site_fixture)


def pilot2_kmz(tmp_path) -> Path:
    path = tmp_path / "pilot2.kmz"
    with zipfile.ZipFile(path, "w") as z:
        for name in ("template.kml", "waylines.wpml"):
            z.write(PILOT2 / "wpmz" / name, f"wpmz/{name}")
    return path


def test_dji_pilot2_mission_without_photo_actions_has_a_frame_per_waypoint(tmp_path):
    """Four waypoints with a heading and a gimbal pitch each and no action group: a frame at each, with its heading and
    pitch; heights above the take-off reference point, whose ellipsoidal height becomes the model's datum."""
    require_geoid()
    from sightplan.geoid import to_orthometric

    plan = load_plan(pilot2_kmz(tmp_path), georef=HOUSE_SITE, ground_z=-0.15)
    assert len(plan) == 4 and plan.camera_of(0).name.startswith("DJI Mavic 3 Enterprise")  # payload 66
    assert any("no photo action" in w and "a frame is made at every waypoint" in w for w in plan.parameters["warnings"])
    ref_h = float(to_orthometric(51.8378, 5.8697, 54.011)[0])  # takeOffRefPoint 51.8378,5.8697,54.011 (ellipsoidal)
    lon, lat, rel, heading, pitch = (np.array(v, float) for v in zip(*PILOT2_WAYPOINTS))
    np.testing.assert_allclose(plan.C_world, HOUSE_SITE.from_geodetic(lat, lon, ref_h + rel), atol=0.01)
    assert plan.parameters["home"]["from"] == "file"
    assert plan.parameters["takeoff_m"][2] == pytest.approx(ref_h - 10.0, abs=0.01)  # 0.2 m above the terrain
    assert max(angle_diff(a, b % 360) for a, b in zip(true_headings(plan), heading)) < 0.01
    np.testing.assert_allclose(pitches(plan), pitch, atol=0.01)
    assert not any("nadir" in w for w in plan.parameters["warnings"])


def test_dji_pilot2_files_read_bare(tmp_path):
    """The template.kml and the waylines.wpml, each alone: the same frames (the waylines file has no take-off
    reference, so its heights start from the model's ground)."""
    require_geoid()
    whole = load_plan(pilot2_kmz(tmp_path), georef=HOUSE_SITE, ground_z=-0.15)
    assert detect_format(PILOT2 / "wpmz" / "template.kml") == detect_format(PILOT2 / "wpmz" / "waylines.wpml") == "wpml"
    template = load_plan(PILOT2 / "wpmz" / "template.kml", georef=HOUSE_SITE, ground_z=-0.15)
    np.testing.assert_allclose(template.C_world, whole.C_world, atol=1e-6)
    np.testing.assert_allclose(template.R_world_camera, whole.R_world_camera, atol=1e-9)
    waylines = load_plan(PILOT2 / "wpmz" / "waylines.wpml", georef=HOUSE_SITE, ground_z=-0.15)
    assert waylines.parameters["home"]["from"] == "ground"
    assert any("no take-off reference point" in w for w in waylines.parameters["warnings"])
    np.testing.assert_allclose(waylines.C_world[:, 2] - waylines.parameters["takeoff_m"][2],
                               [w[2] for w in PILOT2_WAYPOINTS], atol=0.01)
    np.testing.assert_allclose(pitches(waylines), [w[4] for w in PILOT2_WAYPOINTS], atol=0.01)


def test_dji_gimbal_pitch_mode_manual_leaves_the_pitch_unknown(tmp_path):
    text = (PILOT2 / "wpmz" / "template.kml").read_text().replace("usePointSetting", "manual")
    path = tmp_path / "template.kml"
    path.write_text(text)
    plan = load_plan(path, georef=HOUSE_SITE, ground_z=-0.15, camera="m3e")
    np.testing.assert_allclose(pitches(plan), -90.0)
    assert any("no gimbal pitch before 4 photo(s): -90° (nadir) assumed" in w for w in plan.parameters["warnings"])


def test_a_bare_waypoint_template_exported_by_sightplan_reads_back(tmp_path):
    require_geoid()
    georef, _ = GEOREFS["projected"]
    plan = facade_plan()
    (path,) = export_plan(plan, "wpml", tmp_path / "facade.kmz", georef, TAKEOFF, mission=1)
    plan = plan.subset(np.arange(plan.missions[1].start, plan.missions[1].stop))
    bare = tmp_path / "template.kml"
    with zipfile.ZipFile(path) as z:
        bare.write_bytes(z.read("wpmz/template.kml"))
    back = load_plan(bare, georef=georef, ground_z=5.0)  # the file's take-off reference wins over the ground
    np.testing.assert_allclose(back.C_world, plan.C_world, atol=0.01)
    np.testing.assert_allclose(back.parameters["takeoff_m"], TAKEOFF, atol=0.01)


def test_a_kml_that_is_not_dji_is_refused_by_name(tmp_path):
    georef, _ = GEOREFS["topocentric"]
    (path,) = export_plan(facade_plan(), "kml", tmp_path / "map.kml", georef, TAKEOFF)  # sightplan's own map
    assert detect_format(path) == "wpml"
    with pytest.raises(PlanError, match=r"^map.kml: a KML document without DJI WPML elements \(wpml:…\): not a DJI "
                                        r"mission"):
        load_plan(path, camera="m3e")


# -- Litchi mission CSV --------------------------------------------------------------------------------------------


def litchi_csv(path: Path, rows: list[dict]) -> Path:
    """A Litchi mission CSV with Litchi's full header; each row's cells default to "no action", altitude mode 0."""
    from test_exports import LITCHI_HEADER

    defaults = {k: "0" for k in LITCHI_HEADER} | {f"actiontype{k}": "-1" for k in range(1, 16)} | {
        "photo_timeinterval": "-1", "photo_distinterval": "-1"}
    with path.open("w", newline="") as f:
        w = csv.DictWriter(f, fieldnames=LITCHI_HEADER, lineterminator="\n")
        w.writeheader()
        for row in rows:
            w.writerow(defaults | {k: str(v) for k, v in row.items()})
    return path


def test_litchi_mission_read_above_the_models_ground(tmp_path):
    """Photos where the actions take them (rotate 4 and tilt 5 before photo 1), every 5 m of a distance interval, and
    toward a point of interest; altitudes above the model's ground, as Litchi has no take-off point."""
    poi = {"gimbalmode": 1, "poi_latitude": 47.00005, "poi_longitude": 8.0, "poi_altitude(m)": 0}
    path = litchi_csv(tmp_path / "mission.csv", [
        {"latitude": 47.0, "longitude": 8.0, "altitude(m)": 20, "heading(deg)": 90, "gimbalmode": 2,
         "gimbalpitchangle": -30, "actiontype1": 1, "actiontype2": 4, "actionparam2": 180, "actiontype3": 5,
         "actionparam3": -60, "actiontype4": 1},
        {"latitude": 47.0001, "longitude": 8.0, "altitude(m)": 25, "heading(deg)": 0, "photo_distinterval": 5},
        {"latitude": 47.0001, "longitude": 8.00015, "altitude(m)": 25, "heading(deg)": 270, "actiontype1": 1, **poi},
    ])
    assert detect_format(path) == "litchi"
    plan = load_plan(path, camera="m3e", georef=SITE, ground_z=0.5)
    assert plan.parameters["source"]["format"] == "litchi" and plan.parameters["home"]["from"] == "ground"
    assert any("has no take-off point: its altitudes are read above the model's ground (z 0.50 m)" in w
               for w in plan.parameters["warnings"])
    wp = SITE.from_geodetic([47.0, 47.0001, 47.0001], [8.0, 8.0, 8.00015], [400.5 + 20, 400.5 + 25, 400.5 + 25])
    leg = wp[2] - wp[1]
    at = [wp[0], wp[0], wp[1] + 5 / np.linalg.norm(leg) * leg, wp[1] + 10 / np.linalg.norm(leg) * leg, wp[2]]  # 11.4 m
    np.testing.assert_allclose(plan.C_world, at, atol=0.01)
    np.testing.assert_allclose(plan.waypoints, wp, atol=0.01)
    q = SITE.from_geodetic(47.00005, 8.0, 400.5)[0]
    toward = math.degrees(math.atan2(q[2] - wp[2][2], math.hypot(*(q[:2] - wp[2][:2]))))
    np.testing.assert_allclose(pitches(plan), [-30, -60, -60, -60, toward], atol=0.01)
    assert max(angle_diff(a, b) for a, b in zip(true_headings(plan), [90, 180, 0, 0, 270])) < 0.01
    assert len(set(plan.frame_names)) == len(plan)


def test_litchi_mission_without_photos_and_its_errors(tmp_path):
    rows = [{"latitude": 47.0, "longitude": 8.0, "altitude(m)": 20, "heading(deg)": 45},
            {"latitude": 47.0001, "longitude": 8.0, "altitude(m)": 30, "heading(deg)": 135}]
    path = litchi_csv(tmp_path / "bare.csv", rows)
    plan = load_plan(path, camera="m3e", georef=SITE)  # no ground given: above the model's height 0, with a warning
    np.testing.assert_allclose(plan.C_world[:, 2], [20.0, 30.0], atol=0.01)
    np.testing.assert_allclose(pitches(plan), -90.0)  # gimbalmode 0 throughout: the pitch is not known
    warnings = plan.parameters["warnings"]
    assert any("no photo action (actiontype 1) nor photo interval: a frame is made at every waypoint" in w
               for w in warnings)
    assert any("above the model's height 0" in w for w in warnings) and any("nadir" in w for w in warnings)
    with pytest.raises(PlanError, match="bare.csv: a Litchi mission names no camera"):
        load_plan(path)
    litchi_csv(path, [rows[0] | {"latitude": 91}])
    with pytest.raises(PlanError, match=r"bare.csv, line 2: latitude 91.0 / longitude 8.0 out of range"):
        load_plan(path, camera="m3e")
    poses = tmp_path / "poses.csv"
    poses.write_text("name,x,y,z,heading_deg,pitch_deg\na,0,0,1,0,0\n")
    assert detect_format(poses) == "csv"


# -- round trips through every flight app, as `check` and `evaluate` read them back -------------------------------

ROUND_TRIP_FORMATS = [("qgc", {"autopilot": "px4"}, ".plan"), ("qgc", {"autopilot": "ardupilot"}, ".plan"),
                      ("wpl", {}, ".waypoints"), ("wpml", {"aircraft": "m3e"}, ".kmz"), ("litchi", {}, ".csv")]


@pytest.fixture(scope="module")
def site_plans(tmp_path_factory):
    """For the bundled sample and the basement house (terrain top −0.15, basement −3.3, georeferenced): the model
    argument, the scene and a plan per template (facade, orbit, lawnmower), as `sightplan plan` makes them."""
    from sightplan.camera.catalogue import get_camera
    from sightplan.cli.flight import default_flight_settings
    from sightplan.model.load import load_model
    from sightplan.plan.templates.registry import TEMPLATES, plan_from_template
    from site_fixture import write_basement_house

    house = write_basement_house(tmp_path_factory.mktemp("site") / "house.ifc")
    out = {}
    for model in ("sample", str(house)):
        scene, _ = load_model(model)
        settings = default_flight_settings(False, None, None, None, None, 120.0, drone_safety_m=5.0, min_height=None,
                                           position_error=None, scene=scene)
        plans = {name: plan_from_template(name, scene, get_camera("m3e"), TEMPLATES[name].make({}), settings)[0]
                 for name in ("facade", "orbit", "lawnmower")}
        out["sample" if model == "sample" else "house"] = (model, scene, plans)
    return out


def read_back(paths, scene) -> list:
    """The files read as `check` and `evaluate` read them: placed with the model's georeference and its ground."""
    from sightplan.plan.load import scene_placement

    return [load_plan(p, camera="m3e", **scene_placement(scene)) for p in paths]


@pytest.mark.parametrize("site", [pytest.param("sample", marks=pytest.mark.bench), "house"])
def test_exports_read_back_where_they_were_planned(tmp_path, site_plans, site):
    """Every frame of an export comes back where the plan has it, heights included (to 1 cm), headings and pitches
    too, from the take-off point each file records (QGroundControl, WPL, DJI WPML); a Litchi CSV, which has none,
    from the model's ground under its first waypoint, which is where these plans take off."""
    from sightplan.plan.ground import ground_of

    require_geoid()  # DJI's take-off reference height is ellipsoidal
    model, scene, plans = site_plans[site]
    georef = Georeference.from_scene_metadata(scene.metadata)
    ground = ground_of(scene).level_m
    for name, plan in plans.items():
        takeoff = np.asarray(plan.parameters["takeoff_m"], float)
        assert takeoff[2] == pytest.approx(ground, abs=1e-6)  # these sites' take-off: on the ground
        h0, p0, _ = gimbal_from_R(plan.R_world_camera)
        for fmt, kw, suffix in ROUND_TRIP_FORMATS:
            paths = export_plan(plan, fmt, tmp_path / f"{site}_{name}_{fmt}{kw.get('autopilot', '')}{suffix}", georef,
                                takeoff, **kw)
            back = read_back(paths, scene)
            C = np.vstack([b.C_world for b in back])
            assert C.shape == plan.C_world.shape, (name, fmt)
            worst = np.abs(C - plan.C_world).max()
            assert worst < 0.01, (name, fmt, kw, worst)
            h1, p1, _ = (np.concatenate(v) for v in zip(*(gimbal_from_R(b.R_world_camera) for b in back)))
            assert max(angle_diff(a, b) for a, b in zip(h0, h1)) < 0.01, (name, fmt)
            np.testing.assert_allclose(p1, p0, atol=0.01)
            for b in back:
                start = b.parameters["takeoff_m"]
                assert start[2] == pytest.approx(takeoff[2], abs=0.01), (name, fmt)
                assert b.parameters["home"]["from"] == ("ground" if fmt == "litchi" else "file")


def test_a_raised_take_off_comes_back_from_the_file_not_the_ground(tmp_path, site_plans):
    """A take-off 1.6 m above the site's ground (a pilot on a platform): the files that carry their take-off point
    come back exactly; a Litchi CSV, which carries none, comes back 1.6 m lower, from the site's ground."""
    require_geoid()
    _, scene, plans = site_plans["house"]
    georef = Georeference.from_scene_metadata(scene.metadata)
    plan = plans["facade"]
    takeoff = np.asarray(plan.parameters["takeoff_m"], float) + [0.0, 0.0, 1.6]
    for fmt, kw, suffix in ROUND_TRIP_FORMATS:
        paths = export_plan(plan, fmt, tmp_path / f"raised_{fmt}{kw.get('autopilot', '')}{suffix}", georef, takeoff,
                            per_mission_takeoff=False, **kw)
        back = read_back(paths, scene)
        C = np.vstack([b.C_world for b in back])
        drop = 1.6 if fmt == "litchi" else 0.0
        np.testing.assert_allclose(C, plan.C_world - [0.0, 0.0, drop], atol=0.01, err_msg=fmt)
        if fmt != "litchi":
            np.testing.assert_allclose(back[0].parameters["takeoff_m"], takeoff, atol=0.01)


@pytest.mark.parametrize("site", [pytest.param("sample", marks=pytest.mark.bench), "house"])
def test_check_of_an_export_finds_no_height_violation(tmp_path, site_plans, site):
    """`sightplan check EXPORT MODEL` on each app's file of a facade plan (the lowest waypoints, 0.5 m above the
    minimum height at the worst of the vertical error): no waypoint, leg, flight out or home too low."""
    from test_cli import run_cli

    require_geoid()
    model, scene, plans = site_plans[site]
    georef = Georeference.from_scene_metadata(scene.metadata)
    plan = plans["facade"]
    for fmt, kw, suffix in ROUND_TRIP_FORMATS:
        first = export_plan(plan, fmt, tmp_path / f"{fmt}{kw.get('autopilot', '')}{suffix}", georef,
                            plan.parameters["takeoff_m"], **kw)[0]
        report = tmp_path / f"{first.stem}.json"
        res = run_cli("check", str(first), model, "--camera", "m3e", "--json", str(report), cwd=tmp_path)
        assert "Traceback" not in res.stdout + res.stderr
        data = json.loads(report.read_text())
        assert all(m["height_ok"] is not False for m in data["missions"]), (fmt, data["violations"])
        assert not [v for v in data["violations"] if "above the ground" in v], fmt
    # taking off 1.6 m above the ground: read from the ground, the lowest waypoints would come 1.6 m too low
    raised = np.asarray(plan.parameters["takeoff_m"], float) + [0.0, 0.0, 1.6]
    first = export_plan(plan, "qgc", tmp_path / "raised.plan", georef, raised, per_mission_takeoff=False)[0]
    res = run_cli("check", str(first), model, "--camera", "m3e", "--json", str(tmp_path / "raised.json"), cwd=tmp_path)
    data = json.loads((tmp_path / "raised.json").read_text())
    assert not [v for v in data["violations"] if "above the ground" in v], data["violations"]
    assert min(w["height_above_ground_m"] for w in data["waypoints"]) > 2.0


def test_an_imported_missions_pilot_stands_at_its_take_off(tmp_path):
    """A flight-app mission's line of sight is measured from where the file takes off (1.5 m up), not from a corner
    of the region: a mission exported from its own ground station reads back with that station."""
    georef, _ = GEOREFS["projected"]
    plan = facade_plan()
    for fmt, suffix in (("wpl", ".waypoints"), ("litchi", ".csv")):
        (path, *_) = export_plan(plan, fmt, tmp_path / f"f{suffix}", georef, TAKEOFF)
        back = load_plan(path, camera="p4p", georef=georef, ground_z=float(TAKEOFF[2]))
        takeoff = np.asarray(back.parameters["takeoff_m"], float)
        assert all(m.ground_station == pytest.approx(tuple(takeoff + [0, 0, 1.5])) for m in back.missions), fmt
