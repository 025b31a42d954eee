"""Exports to flight apps and maps, read back with parsers that are not sightplan's.

QGroundControl .plan with ``json``, QGC WPL 110 with pymavlink, DJI WPML with ``zipfile`` and
``xml.etree``, Litchi with ``csv``, KML with ``xml.etree``, GeoJSON with ``json``. Each read-back
is compared photo by photo with numbers known without the exporter: the plan's centres (after
converting the file's latitude/longitude/height back with the georeference), the model headings
plus the georeference's north offset (+30° for the topocentric one, −30° for the projected one,
whose model +X is 30° left of grid east on the UTM central meridian) and the gimbal pitches.
WPML's take-off reference and GeoJSON's heights are WGS84 ellipsoidal: the EGM96 undulation is
subtracted before the georeference takes them back (tests/test_exports_spec.py checks it against
NGA's published values).
"""

from __future__ import annotations

import csv
import json
import math
import zipfile
from pathlib import Path
from xml.etree import ElementTree as ET

import numpy as np
import pytest

from geoid_support import require_geoid
from sightplan import geoid
from sightplan.camera import get_camera
from sightplan.errors import PlanError
from sightplan.export import EXPORT_FORMATS, export_plan
from sightplan.geo import Georeference
from sightplan.plan import Mission, Plan, R_from_gimbal

COS30, SIN30 = math.cos(math.radians(30)), math.sin(math.radians(30))
GEOREFS = {
    "topocentric": (Georeference.from_origin(52.0, 5.0, 3.0, north_deg=30.0), 30.0),
    "projected": (Georeference.from_map_conversion("EPSG:32631", 500000, 4982950.40, 10.0, COS30, SIN30), -30.0),
}
TAKEOFF = np.array([3.0, -20.0, 0.0])
# (heading, pitch) of the photos taken at every facade position, in order
SHOTS = [(0.0, 0.0), (25.0, -20.0), (335.0, 15.0)]


def facade_plan() -> Plan:
    """A facade along +X seen from y = −10: 6 positions × 3 photos, then a −60° and a nadir photo. Two missions."""
    C, h, p = [], [], []
    for x in (0.0, 6.0, 12.0):
        for z in (4.0, 9.0):
            for heading, pitch in SHOTS:
                C.append([x, -10.0, z])
                h.append(heading)
                p.append(pitch)
    C += [[6.0, -14.0, 12.0], [6.0, -18.0, 20.0]]
    h += [10.0, 90.0]
    p += [-60.0, -90.0]
    return Plan.build(get_camera("m3e"), R_from_gimbal(h, p), np.array(C),
                      missions=(Mission("west", 0, 12), Mission("east", 12, 20)))


def expected_photos(plan: Plan, offset: float) -> list[tuple[int, float, float]]:
    """(frame, true heading, pitch) of every frame, from the angles the plan was built with."""
    h = [heading for _ in range(6) for heading, _ in SHOTS] + [10.0, 90.0]
    p = [pitch for _ in range(6) for _, pitch in SHOTS] + [-60.0, -90.0]
    return [(i, (h[i] + offset) % 360.0, p[i]) for i in range(len(plan))]


def angle_diff(a: float, b: float) -> float:
    return abs((a - b + 180.0) % 360.0 - 180.0)


def check_photos(plan: Plan, georef: Georeference, offset: float, got: list[tuple[float, float, float, float, float]],
                 ellipsoidal: bool = False):
    """``got``: (lat, lon, height, heading, pitch) per photo in file order, compared with the plan's frames in order;
    ``ellipsoidal``: the heights are WGS84 ellipsoidal (the EGM96 undulation is taken off)."""
    want = expected_photos(plan, offset)
    assert len(got) == len(want)
    lat, lon, h = (np.array([g[k] for g in got], float) for k in range(3))
    if ellipsoidal:
        h = geoid.to_orthometric(lat, lon, h)
    xyz = georef.from_geodetic(lat, lon, h)
    np.testing.assert_allclose(xyz, plan.C_world, atol=0.1)
    for (i, heading, pitch), g in zip(want, got):
        assert angle_diff(g[3], heading) < 0.01, (plan.frame_names[i], g[3], heading)
        assert g[4] == pytest.approx(pitch, abs=0.01), plan.frame_names[i]


def takeoff_height(georef: Georeference) -> float:
    return float(georef.to_geodetic(TAKEOFF)[2][0])


# -- QGroundControl .plan ----------------------------------------------------------------------


def qgc_photos(doc: dict) -> list[tuple[float, float, float, float, float]]:
    """(lat, lon, height, heading, pitch) per photo, flying the items: a NAV_WAYPOINT's yaw (param4) or the last
    CONDITION_YAW's absolute heading, the last DO_MOUNT_CONTROL's pitch."""
    items = doc["mission"]["items"]
    home_h = doc["mission"]["plannedHomePosition"][2]
    assert [it["doJumpId"] for it in items] == list(range(1, len(items) + 1))
    assert items[0]["command"] == 22 and items[-1]["command"] == 20
    photos, wp, heading, pitch = [], None, None, None
    for it in items[1:-1]:
        assert it["type"] == "SimpleItem" and len(it["params"]) == 7
        p = it["params"]
        if it["command"] == 16:
            assert it["frame"] == 3
            wp, heading = (p[4], p[5], home_h + p[6]), p[3]
            continue
        assert it["frame"] == 2  # MAV_FRAME_MISSION
        if it["command"] == 115:
            assert p[3] == 0  # absolute heading
            heading = p[0]
        elif it["command"] == 205:
            assert p[6] == 2  # MAV_MOUNT_MODE_MAVLINK_TARGETING
            pitch = p[0]
        elif it["command"] == 2000:
            assert p[2] == 1  # one image
            photos.append((*wp, heading, pitch))
        elif it["command"] in (93, 112):  # NAV_DELAY (PX4), CONDITION_DELAY (ArduPilot): the gimbal's wait
            assert p[0] > 0
        else:
            raise AssertionError(f"unexpected command {it['command']}")
    return photos


@pytest.mark.parametrize("autopilot, firmware", [("px4", 12), ("ardupilot", 3)])
@pytest.mark.parametrize("kind", GEOREFS)
def test_qgc_plan_read_with_json(tmp_path, kind, autopilot, firmware):
    georef, offset = GEOREFS[kind]
    plan = facade_plan()
    paths = export_plan(plan, "qgc", tmp_path / "facade.plan", georef, TAKEOFF, autopilot=autopilot)
    assert [p.name for p in paths] == ["facade_m01.plan", "facade_m02.plan"]
    photos, positions = [], set()
    for path in paths:
        doc = json.loads(path.read_text())
        assert doc["fileType"] == "Plan" and doc["version"] == 1 and doc["mission"]["version"] == 2
        assert doc["mission"]["firmwareType"] == firmware and doc["sightplan"]["autopilot"] == autopilot
        home = doc["mission"]["plannedHomePosition"]
        np.testing.assert_allclose(georef.from_geodetic(*home)[0], TAKEOFF, atol=0.01)
        assert doc["mission"]["items"][0]["params"][4:6] == home[:2]
        photos += qgc_photos(doc)
        positions |= {tuple(it["params"][4:7]) for it in doc["mission"]["items"] if it["command"] == 16}
    assert len(positions) == 8  # 6 facade positions + 2 single photos
    check_photos(plan, georef, offset, photos)


def test_qgc_single_mission_and_the_heading_commands_of_each_autopilot(tmp_path):
    georef, _ = GEOREFS["topocentric"]
    plan = facade_plan()
    # mission "east": 2 facade positions × 3 photos at 3 headings, then 2 positions with one photo: 8 stops
    (path,) = export_plan(plan, "qgc", tmp_path / "east.plan", georef, TAKEOFF, mission=1)  # index of "east"
    assert path.name == "east.plan"
    items = json.loads(path.read_text())["mission"]["items"]
    assert sum(it["command"] == 2000 for it in items) == 8
    # PX4 (the default for .plan): no CONDITION_YAW; one waypoint per heading, in the same place for a facade position
    assert sum(it["command"] == 115 for it in items) == 0
    assert sum(it["command"] == 16 for it in items) == 8
    (path,) = export_plan(plan, "qgc", tmp_path / "east_ap.plan", georef, TAKEOFF, mission=1, autopilot="ardupilot")
    items = json.loads(path.read_text())["mission"]["items"]
    # ArduPilot: a CONDITION_YAW per heading, each stop ended by a waypoint holding in place: 4 arrivals + 8 holds,
    # long enough for the turn, the gimbal and the shot (the replay in tests/test_flight_replay.py flies them)
    assert sum(it["command"] == 115 for it in items) == 8
    wps = [it for it in items if it["command"] == 16]
    assert len(wps) == 4 + 8 and sum(it["params"][0] == 0 for it in wps) == 4
    assert min(it["params"][0] for it in wps if it["params"][0] > 0) >= 1.5  # margin + the yaw's settle
    with pytest.raises(PlanError, match="mission index 2 asked for"):
        export_plan(plan, "qgc", tmp_path / "x.plan", georef, TAKEOFF, mission=2)
    with pytest.raises(PlanError, match="unknown autopilot 'apm'"):
        export_plan(plan, "qgc", tmp_path / "x.plan", georef, TAKEOFF, autopilot="apm")


# -- QGC WPL 110 via pymavlink -----------------------------------------------------------------


@pytest.mark.parametrize("autopilot", ["ardupilot", "px4"])
@pytest.mark.parametrize("kind", GEOREFS)
def test_wpl_read_with_pymavlink(tmp_path, kind, autopilot):
    mavwp = pytest.importorskip("pymavlink.mavwp")
    georef, offset = GEOREFS[kind]
    plan = facade_plan()
    paths = export_plan(plan, "wpl", tmp_path / "facade.waypoints", georef, TAKEOFF, autopilot=autopilot)
    assert len(paths) == 2
    photos = []
    for path in paths:
        assert path.read_text().splitlines()[0] == "QGC WPL 110"
        loader = mavwp.MAVWPLoader()
        n = loader.load(str(path))
        items = [loader.wp(k) for k in range(n)]
        home = items[0]
        assert (home.seq, home.current, home.frame) == (0, 1, 0)
        assert georef.from_geodetic(home.x, home.y, home.z)[0] == pytest.approx(TAKEOFF, abs=0.01)
        # positional items above home (frame 3), every other one in MAV_FRAME_MISSION (2)
        assert all(w.frame == (3 if w.command in (16, 22) else 2) for w in items[1:])
        assert all(w.current == 0 and w.autocontinue == 1 for w in items[1:])
        assert [w.seq for w in items] == list(range(n))
        assert items[1].command == 22 and items[-1].command == 20
        assert (115 in {w.command for w in items}) == (autopilot == "ardupilot")
        wp = heading = pitch = None
        for w in items[2:-1]:
            if w.command == 16:
                wp, heading = (w.x, w.y, home.z + w.z), w.param4
            elif w.command == 115:
                heading = w.param1
            elif w.command == 205:
                pitch = w.param1
            elif w.command == 2000:
                photos.append((*wp, heading, pitch))
    check_photos(plan, georef, offset, photos)


# -- DJI WPML ----------------------------------------------------------------------------------

NS = {"kml": "http://www.opengis.net/kml/2.2", "wpml": "http://www.dji.com/wpmz/1.0.2"}


@pytest.mark.parametrize("kind", GEOREFS)
def test_wpml_read_with_zipfile_and_elementtree(tmp_path, kind):
    require_geoid()
    georef, offset = GEOREFS[kind]
    plan = facade_plan()
    paths = export_plan(plan, "wpml", tmp_path / "facade.kmz", georef, TAKEOFF, speed_m_s=3.0)
    assert [p.name for p in paths] == ["facade_m01.kmz", "facade_m02.kmz"]  # a file per mission
    photos, suffixes = [], []
    for path in paths:
        photos_of, suffixes_of = wpml_photos(path, georef)
        photos += photos_of
        suffixes += suffixes_of
    check_photos(plan, georef, offset, photos)
    assert suffixes == plan.frame_names.tolist()


def wpml_photos(path: Path, georef: Georeference) -> tuple[list[tuple], list[str]]:
    """(lat, lon, height in the georeference's datum, heading, pitch) and file suffix of every photo of one .kmz."""
    with zipfile.ZipFile(path) as z:
        assert set(z.namelist()) == {"wpmz/template.kml", "wpmz/waylines.wpml"}
        waylines = ET.fromstring(z.read("wpmz/waylines.wpml"))
        template = ET.fromstring(z.read("wpmz/template.kml"))
    cfg = waylines.find("kml:Document/wpml:missionConfig", NS)
    assert cfg.findtext("wpml:flyToWaylineMode", namespaces=NS) == "safely"
    assert cfg.findtext("wpml:finishAction", namespaces=NS) == "goHome"
    assert cfg.findtext("wpml:exitOnRCLost", namespaces=NS) == "executeLostAction"
    assert cfg.findtext("wpml:executeRCLostAction", namespaces=NS) == "goBack"
    assert cfg.findtext("wpml:droneInfo/wpml:droneEnumValue", namespaces=NS) == "77"  # the M3E camera's aircraft
    ref = template.findtext("kml:Document/wpml:missionConfig/wpml:takeOffRefPoint", namespaces=NS)
    lat0, lon0, h0 = map(float, ref.split(","))
    h0 = float(geoid.to_orthometric(lat0, lon0, h0)[0])  # DJI's take-off reference height is ellipsoidal
    assert georef.from_geodetic(lat0, lon0, h0)[0] == pytest.approx(TAKEOFF, abs=0.01)
    folders = waylines.findall("kml:Document/kml:Folder", NS)
    assert [f.findtext("wpml:waylineId", namespaces=NS) for f in folders] == ["0"]
    photos, suffixes = [], []
    for folder in folders:
        assert folder.findtext("wpml:executeHeightMode", namespaces=NS) == "relativeToStartPoint"
        marks = folder.findall("kml:Placemark", NS)
        assert [int(m.findtext("wpml:index", namespaces=NS)) for m in marks] == list(range(len(marks)))
        for m in marks:
            lon, lat = map(float, m.findtext("kml:Point/kml:coordinates", namespaces=NS).split(","))
            height = h0 + float(m.findtext("wpml:executeHeight", namespaces=NS))
            assert float(m.findtext("wpml:waypointSpeed", namespaces=NS)) == 3.0
            hp = m.find("wpml:waypointHeadingParam", NS)
            assert hp.findtext("wpml:waypointHeadingMode", namespaces=NS) == "smoothTransition"
            heading = float(hp.findtext("wpml:waypointHeadingAngle", namespaces=NS))
            assert -180 <= heading <= 180
            assert m.findtext("wpml:waypointTurnParam/wpml:waypointTurnMode", namespaces=NS) == \
                "toPointAndStopWithDiscontinuityCurvature"
            pitch = None
            for action in m.findall("wpml:actionGroup/wpml:action", NS):
                func = action.findtext("wpml:actionActuatorFunc", namespaces=NS)
                param = action.find("wpml:actionActuatorFuncParam", NS)
                if func == "rotateYaw":
                    heading = float(param.findtext("wpml:aircraftHeading", namespaces=NS))
                    assert -180 <= heading <= 180
                elif func == "gimbalRotate":
                    pitch = float(param.findtext("wpml:gimbalPitchRotateAngle", namespaces=NS))
                elif func == "takePhoto":
                    photos.append((lat, lon, height, heading, pitch))
                    suffixes.append(param.findtext("wpml:fileSuffix", namespaces=NS))
    return photos, suffixes


# -- Litchi CSV --------------------------------------------------------------------------------

LITCHI_HEADER = ("latitude,longitude,altitude(m),heading(deg),curvesize(m),rotationdir,gimbalmode,gimbalpitchangle,"
                 + ",".join(f"actiontype{k},actionparam{k}" for k in range(1, 16))
                 + ",altitudemode,speed(m/s),poi_latitude,poi_longitude,poi_altitude(m),poi_altitudemode,"
                   "photo_timeinterval,photo_distinterval").split(",")


def litchi_photos(path: Path, h0: float) -> tuple[list[tuple], list[dict]]:
    with path.open(newline="") as f:
        rows = list(csv.DictReader(f))
    with path.open(newline="") as f:
        assert next(csv.reader(f)) == LITCHI_HEADER
    photos = []
    for row in rows:
        assert row["altitudemode"] == "0" and row["gimbalmode"] == "2"
        heading, pitch = float(row["heading(deg)"]), float(row["gimbalpitchangle"])
        assert 0 <= heading < 360
        at = (float(row["latitude"]), float(row["longitude"]), h0 + float(row["altitude(m)"]))
        for k in range(1, 16):
            kind, param = int(row[f"actiontype{k}"]), float(row[f"actionparam{k}"])
            if kind == 4:
                heading = param
            elif kind == 5:
                pitch = param
            elif kind == 1:
                photos.append((*at, heading, pitch))
            elif kind == 0:  # "stay for" (ms): the gimbal settles after a change of pitch
                assert param == 500
            else:
                assert kind == -1
    return photos, rows


@pytest.mark.parametrize("kind", GEOREFS)
def test_litchi_read_with_csv(tmp_path, kind):
    georef, offset = GEOREFS[kind]
    plan = facade_plan()
    paths = export_plan(plan, "litchi", tmp_path / "facade.csv", georef, TAKEOFF)
    assert [p.name for p in paths] == ["facade_m01.csv", "facade_m02.csv"]
    photos = []
    for path in paths:
        photos += litchi_photos(path, takeoff_height(georef))[0]
    check_photos(plan, georef, offset, photos)


def test_litchi_splits_missions_over_99_waypoints(tmp_path):
    georef, offset = GEOREFS["topocentric"]
    n = 250
    x = np.arange(n) * 2.0
    C = np.stack([x, np.full(n, -10.0), np.full(n, 6.0)], axis=1)
    plan = Plan.build(get_camera("m3e"), R_from_gimbal(np.zeros(n), np.full(n, -30.0)), C)
    paths = export_plan(plan, "litchi", tmp_path / "long.csv", georef, TAKEOFF)
    assert len(paths) == math.ceil(n / 99) == 3
    assert [p.name for p in paths] == ["long_p1.csv", "long_p2.csv", "long_p3.csv"]
    photos, counts = [], []
    for path in paths:
        got, rows = litchi_photos(path, takeoff_height(georef))
        photos += got
        counts.append(len(rows))
    assert counts == [99, 99, 52]
    xyz = georef.from_geodetic([p[0] for p in photos], [p[1] for p in photos], [p[2] for p in photos])
    np.testing.assert_allclose(xyz, C, atol=0.1)
    assert all(angle_diff(p[3], offset) < 0.01 and p[4] == pytest.approx(-30.0) for p in photos)


def test_litchi_keeps_15_actions_per_row(tmp_path):
    georef, offset = GEOREFS["topocentric"]
    n = 20  # each photo after the first of a row turns and tilts: 3 actions
    h = np.arange(n) * 17.0 % 360
    p = -np.arange(n) * 4.0
    plan = Plan.build(get_camera("m3e"), R_from_gimbal(h, p), np.tile([1.0, -8.0, 5.0], (n, 1)))
    (path,) = export_plan(plan, "litchi", tmp_path / "many.csv", georef, TAKEOFF)
    photos, rows = litchi_photos(path, takeoff_height(georef))
    assert len(rows) > 1
    assert all(sum(row[f"actiontype{k}"] != "-1" for k in range(1, 16)) <= 15 for row in rows)
    assert len({(row["latitude"], row["longitude"], row["altitude(m)"]) for row in rows}) == 1
    assert len(photos) == n
    for (_, _, _, heading, pitch), hi, pi in zip(photos, h, p):
        assert angle_diff(heading, hi + offset) < 0.01 and pitch == pytest.approx(pi)


# -- KML and GeoJSON ---------------------------------------------------------------------------

KML = {"k": "http://www.opengis.net/kml/2.2"}


def nadir_footprint_check(georef: Georeference, plan: Plan, ring_lonlat: list, ellipsoidal: bool = False) -> None:
    """The nadir frame's footprint on the take-off plane: a W·H/f by Himg·H/f rectangle centred under the camera."""
    cam = plan.camera_of(19)
    height = plan.C_world[19, 2] - TAKEOFF[2]
    ring = np.array(ring_lonlat, float)
    if ellipsoidal:
        ring[:, 2] = geoid.to_orthometric(ring[:, 1], ring[:, 0], ring[:, 2])
    xyz = georef.from_geodetic(ring[:, 1], ring[:, 0], ring[:, 2])
    assert xyz[0] == pytest.approx(xyz[-1])
    np.testing.assert_allclose(xyz[:, 2], TAKEOFF[2], atol=0.01)
    x, y = xyz[:-1, 0], xyz[:-1, 1]
    area = 0.5 * abs(np.sum(x * np.roll(y, -1) - np.roll(x, -1) * y))
    assert area == pytest.approx((cam.width * height / cam.fx) * (cam.height * height / cam.fy), rel=1e-3)
    np.testing.assert_allclose(xyz[:-1, :2].mean(axis=0), plan.C_world[19, :2], atol=0.05)


def kml_data(pm: ET.Element) -> dict[str, str]:
    return {d.get("name"): d.findtext("k:value", namespaces=KML) for d in pm.findall("k:ExtendedData/k:Data", KML)}


@pytest.mark.parametrize("kind", GEOREFS)
def test_kml_read_with_elementtree(tmp_path, kind):
    georef, offset = GEOREFS[kind]
    plan = facade_plan()
    (path,) = export_plan(plan, "kml", tmp_path / "facade.kml", georef, TAKEOFF)
    doc = ET.parse(path).getroot().find("k:Document", KML)
    folders = doc.findall("k:Folder", KML)
    assert [f.findtext("k:name", namespaces=KML) for f in folders] == ["west", "east"]
    photos, footprints, skipped = [], {}, []
    for folder in folders:
        line = folder.find("k:Placemark/k:LineString", KML)
        assert line.findtext("k:altitudeMode", namespaces=KML) == "absolute"
        path_points = [tuple(map(float, c.split(","))) for c in line.findtext("k:coordinates", namespaces=KML).split()]
        points = []
        for pm in folder.findall("k:Placemark", KML):
            point = pm.find("k:Point", KML)
            if point is None:
                continue
            lon, lat, h = map(float, point.findtext("k:coordinates", namespaces=KML).split(","))
            points.append((lon, lat, h))
            data = kml_data(pm)
            assert data["mission"] == folder.findtext("k:name", namespaces=KML)
            frames = data["frames"].split(";")
            for heading, pitch in zip(data["heading_deg"].split(";"), data["pitch_deg"].split(";")):
                photos.append((lat, lon, h, float(heading), float(pitch)))
            if "footprint_skipped" in data:
                skipped += data["footprint_skipped"].split(";")
                assert "take-off plane" in data["footprint_note"]
            assert len(frames) == len(data["heading_deg"].split(";"))
        assert path_points == points
        for fp in folder.findall("k:Folder/k:Placemark", KML):
            coords = fp.findtext("k:Polygon/k:outerBoundaryIs/k:LinearRing/k:coordinates", namespaces=KML)
            footprints[fp.findtext("k:name", namespaces=KML)] = [tuple(map(float, c.split(","))) for c in coords.split()]
    check_photos(plan, georef, offset, photos)
    # the −60° and nadir frames see the take-off plane; every facade frame has a corner ray at or above the horizon
    assert sorted(footprints) == ["frame_00018", "frame_00019"]
    assert sorted(skipped) == [f"frame_{i:05d}" for i in range(18)]
    nadir_footprint_check(georef, plan, footprints["frame_00019"])


@pytest.mark.parametrize("kind", GEOREFS)
def test_geojson_read_with_json(tmp_path, kind):
    require_geoid()
    georef, offset = GEOREFS[kind]
    plan = facade_plan()
    (path,) = export_plan(plan, "geojson", tmp_path / "facade.geojson", georef, TAKEOFF)
    doc = json.loads(path.read_text())
    assert doc["type"] == "FeatureCollection"
    by_kind: dict[str, list] = {}
    for f in doc["features"]:
        assert f["type"] == "Feature"
        by_kind.setdefault(f["properties"]["kind"], []).append(f)
    assert [f["properties"]["mission"] for f in by_kind["path"]] == ["west", "east"]
    photos = []
    for f in by_kind["waypoint"]:
        lon, lat, h = f["geometry"]["coordinates"]  # RFC 7946: longitude first, the height ellipsoidal
        props = f["properties"]
        assert len(props["frames"]) == len(props["heading_deg"]) == len(props["pitch_deg"])
        photos += [(lat, lon, h, hd, p) for hd, p in zip(props["heading_deg"], props["pitch_deg"])]
    check_photos(plan, georef, offset, photos, ellipsoidal=True)
    path_coords = [c for f in by_kind["path"] for c in f["geometry"]["coordinates"]]
    assert path_coords == [f["geometry"]["coordinates"] for f in by_kind["waypoint"]]
    prints = {f["properties"]["frame"]: f for f in by_kind["footprint"]}
    assert sorted(prints) == ["frame_00018", "frame_00019"]
    ring = prints["frame_00019"]["geometry"]["coordinates"][0]
    x, y = np.array(ring)[:-1, 0], np.array(ring)[:-1, 1]
    assert np.sum(x * np.roll(y, -1) - np.roll(x, -1) * y) > 0  # counter-clockwise exterior ring
    nadir_footprint_check(georef, plan, ring, ellipsoidal=True)


# -- refusals ----------------------------------------------------------------------------------


def test_pitch_out_of_range_names_the_frame(tmp_path):
    georef, _ = GEOREFS["topocentric"]
    plan = Plan.build(get_camera("m3e"), R_from_gimbal([0.0, 0.0], [-10.0, 45.0]), [[0, -5, 3], [1, -5, 3]],
                      frame_names=["low", "up45"])
    for fmt, top in (("wpml", 35), ("litchi", 30)):  # DJI WPML: the Mavic 3 Enterprise's gimbal, up to +35°
        with pytest.raises(PlanError, match=rf"up45 have a gimbal pitch of \+45\.0°, outside .*-90° to \+{top}°"):
            export_plan(plan, fmt, tmp_path / f"x.{fmt}", georef, TAKEOFF)
    assert export_plan(plan, "qgc", tmp_path / "ok.plan", georef, TAKEOFF)  # QGroundControl: −90..+90
    items = json.loads((tmp_path / "ok.plan").read_text())["mission"]["items"]
    assert [it["params"][0] for it in items if it["command"] == 205] == pytest.approx([-10.0, 45.0])
    assert not (tmp_path / "x.wpml").exists()


def test_rolled_camera_is_refused_but_mapped(tmp_path):
    require_geoid()  # GeoJSON's heights are ellipsoidal
    georef, _ = GEOREFS["topocentric"]
    plan = Plan.build(get_camera("m3e"), R_from_gimbal([0.0, 0.0], [-10.0, -10.0], [0.0, 5.0]), [[0, -5, 3], [1, -5, 3]],
                      frame_names=["level", "tilted"])
    with pytest.raises(PlanError, match="tilted have a camera roll of \\+5.0°"):
        export_plan(plan, "qgc", tmp_path / "x.plan", georef, TAKEOFF)
    assert export_plan(plan, "geojson", tmp_path / "x.geojson", georef, TAKEOFF)
    features = json.loads((tmp_path / "x.geojson").read_text())["features"]
    assert [f["properties"]["frames"] for f in features if f["properties"]["kind"] == "waypoint"] == [["level"], ["tilted"]]


def test_360_camera_exports_heading_only(tmp_path):
    require_geoid()
    georef, offset = GEOREFS["topocentric"]
    plan = Plan.build(get_camera("theta-z1"), R_from_gimbal([40.0], [35.0]), [[0, -5, 3]])
    # a 360° camera on a DJI aircraft: the aircraft is named (no DJI aircraft carries it)
    (path,) = export_plan(plan, "wpml", tmp_path / "pano.kmz", georef, TAKEOFF, aircraft="m3e")
    with zipfile.ZipFile(path) as z:
        root = ET.fromstring(z.read("wpmz/waylines.wpml"))
    pitch = root.findtext(".//wpml:gimbalPitchRotateAngle", namespaces=NS)
    headings = [float(e.text) for e in root.iterfind(".//wpml:waypointHeadingAngle", NS)]
    headings += [float(e.text) for e in root.iterfind(".//wpml:aircraftHeading", NS)]
    assert float(pitch) == 0.0 and angle_diff(headings[-1], 40.0 + offset) < 0.01


def test_bad_arguments(tmp_path):
    georef, _ = GEOREFS["topocentric"]
    plan = facade_plan()
    with pytest.raises(PlanError, match="unknown export format 'dxf'"):
        export_plan(plan, "dxf", tmp_path / "x.dxf", georef, TAKEOFF)
    with pytest.raises(PlanError, match="take-off point must be three finite numbers"):
        export_plan(plan, "qgc", tmp_path / "x.plan", georef, [0, np.nan, 0])
    with pytest.raises(PlanError, match="folder .* does not exist"):
        export_plan(plan, "kml", tmp_path / "missing" / "x.kml", georef, TAKEOFF)
    assert {"qgc", "wpl", "wpml", "litchi", "kml", "geojson"} <= set(EXPORT_FORMATS)  # and any format module added
