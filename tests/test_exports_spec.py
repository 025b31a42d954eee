"""Exports against the formats' own specifications: DJI WPML's required elements, the datum of each
format's heights (with NGA's published EGM96 undulations), the DJI aircraft, speed and gimbal ranges, each
mission's own take-off point, and round trips through sightplan's WPML importer."""

from __future__ import annotations

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
from sightplan.export import EXTENSIONS, AircraftError, ExportedFile, export_plan
from sightplan.formats.wpml import read_wpml
from sightplan.geo import Georeference
from sightplan.geometry.poses import gimbal_from_R
from sightplan.plan import Mission, Plan, R_from_gimbal
from test_exports import GEOREFS, NS, TAKEOFF, angle_diff, facade_plan

# The elements DJI's WPML reference marks required ("必需元素"/"Yes" in the "Is it required" column), per file and
# parent element, for a waypoint template flown relative to the start point with exitOnRCLost executeLostAction,
# per-waypoint (not global) height, speed, heading and turn settings, smoothTransition headings and usePointSetting
# gimbal pitch. Pages: DJI Cloud API › DJI WPML › "template.kml", "waylines.wpml" and "Common Elements"
# (developer.dji.com/doc/cloud-api-tutorial/…/api-reference/dji-wpml/), element tables as of WPML 1.0.2.
MISSION_CONFIG = ["flyToWaylineMode", "finishAction", "exitOnRCLost", "executeRCLostAction", "takeOffSecurityHeight",
                  "globalTransitionalSpeed", "globalRTHHeight", "droneInfo", "payloadInfo"]
COMMON = {  # "Common Elements" page
    "droneInfo": ["droneEnumValue", "droneSubEnumValue"],
    "payloadInfo": ["payloadEnumValue", "payloadPositionIndex"],
    "payloadParam": ["payloadPositionIndex", "imageFormat"],
    "waypointHeadingParam": ["waypointHeadingMode", "waypointHeadingAngle", "waypointHeadingPathMode"],
    "globalWaypointHeadingParam": ["waypointHeadingMode", "waypointHeadingPathMode"],
    "waypointTurnParam": ["waypointTurnMode"],
    "actionGroup": ["actionGroupId", "actionGroupStartIndex", "actionGroupEndIndex", "actionGroupMode", "actionTrigger",
                    "action"],
    "actionTrigger": ["actionTriggerType"],
    "action": ["actionId", "actionActuatorFunc", "actionActuatorFuncParam"],
}
ACTION_PARAMS = {  # "Common Elements" page, actionActuatorFuncParam per action
    "takePhoto": ["payloadPositionIndex", "fileSuffix", "payloadLensIndex", "useGlobalPayloadLensIndex"],
    "gimbalRotate": ["payloadPositionIndex", "gimbalHeadingYawBase", "gimbalRotateMode", "gimbalPitchRotateEnable",
                     "gimbalPitchRotateAngle", "gimbalRollRotateEnable", "gimbalRollRotateAngle", "gimbalYawRotateEnable",
                     "gimbalYawRotateAngle", "gimbalRotateTimeEnable", "gimbalRotateTime"],
    "rotateYaw": ["aircraftHeading", "aircraftPathMode"],
}
REQUIRED = {
    "wpmz/template.kml": {  # "template.kml" page: mission, template-common, waypoint-template and Placemark tables
        "Document": ["missionConfig", "Folder"],
        "missionConfig": MISSION_CONFIG,
        "Folder": ["templateType", "templateId", "autoFlightSpeed", "waylineCoordinateSysParam", "payloadParam",
                   "globalWaypointTurnMode", "gimbalPitchMode", "globalHeight", "Placemark"],
        "waylineCoordinateSysParam": ["coordinateMode", "heightMode"],
        "Placemark": ["Point", "index", "useGlobalHeight", "ellipsoidHeight", "height", "useGlobalSpeed", "waypointSpeed",
                      "useGlobalHeadingParam", "waypointHeadingParam", "useGlobalTurnParam", "waypointTurnParam",
                      "gimbalPitchAngle"],
        **COMMON,
    },
    "wpmz/waylines.wpml": {  # "waylines.wpml" page: mission, wayline (Folder) and Placemark tables
        "Document": ["missionConfig", "Folder"],
        "missionConfig": MISSION_CONFIG,
        "Folder": ["templateId", "waylineId", "autoFlightSpeed", "executeHeightMode", "Placemark"],
        "Placemark": ["Point", "index", "executeHeight", "waypointSpeed", "waypointHeadingParam", "waypointTurnParam"],
        **COMMON,
    },
}
# NGA's EGM96 test points (readme of the EGM96 15' geoid height file: latitude, longitude east, undulation in m)
NGA_EGM96 = [(38.6281550, 269.7791550, -31.628), (-14.6212170, 305.0211140, -2.969), (46.8743190, 102.4487290, -43.575),
             (-23.6174460, 133.8747120, 15.871), (38.6254730, 359.9995000, 50.066), (-0.4667440, 0.0023000, 17.329)]
KARLSRUHE = (49.0069, 8.4037, 48.0)  # about 48 m (EGM96) at Karlsruhe


def local(tag: str) -> str:
    return tag.rsplit("}", 1)[-1]


def kmz_docs(path: Path) -> dict[str, ET.Element]:
    with zipfile.ZipFile(path) as z:
        return {name: ET.fromstring(z.read(name)) for name in ("wpmz/template.kml", "wpmz/waylines.wpml")}


def missing_required(root: ET.Element, required: dict[str, list[str]]) -> list[str]:
    """'parent/child' for every required child missing under any element of the document."""
    out = []
    for el in root.iter():
        name = local(el.tag)
        kids = {local(c.tag) for c in el}
        for need in required.get(name, []):
            if need not in kids:
                out.append(f"{name}/{need}")
        if name == "action":
            func = el.findtext("wpml:actionActuatorFunc", namespaces=NS)
            params = {local(c.tag) for c in el.find("wpml:actionActuatorFuncParam", NS)}
            out += [f"{func}/{p}" for p in ACTION_PARAMS.get(func, []) if p not in params]
    return out


def exported(tmp_path, plan, fmt, georef=None, name="x", **kw) -> tuple[list[Path], list[ExportedFile]]:
    report: list[ExportedFile] = []
    paths = export_plan(plan, fmt, tmp_path / f"{name}{EXTENSIONS[fmt]}", georef or GEOREFS["topocentric"][0],
                        kw.pop("takeoff", TAKEOFF), report=report, **kw)
    return paths, report


# -- the EGM96 geoid ---------------------------------------------------------------------------


def test_geoid_matches_ngas_published_undulations():
    require_geoid()
    for lat, lon, n in NGA_EGM96 + [KARLSRUHE]:
        assert float(geoid.undulation(lat, lon)[0]) == pytest.approx(n, abs=0.5), (lat, lon)
    h = geoid.to_ellipsoidal(46.874319, 102.448729, 1000.0)
    assert float(geoid.to_orthometric(46.874319, 102.448729, h)[0]) == pytest.approx(1000.0, abs=1e-9)


def test_a_missing_geoid_grid_is_one_clear_error(tmp_path, monkeypatch):
    monkeypatch.setenv("SIGHTPLAN_GEOID_GRID", str(tmp_path / "none.tif"))
    assert not geoid.available()
    with pytest.raises(geoid.GeoidError, match="apt-get install proj-data"):
        export_plan(facade_plan(), "geojson", tmp_path / "x.geojson", GEOREFS["topocentric"][0], TAKEOFF)


@pytest.mark.parametrize("lat, lon, n", [(NGA_EGM96[0][0], NGA_EGM96[0][1] - 360.0, NGA_EGM96[0][2]), KARLSRUHE])
def test_take_off_reference_and_geojson_are_ellipsoidal(tmp_path, lat, lon, n):
    """The take-off point's height above sea level (the model's datum) + the published undulation there."""
    require_geoid()
    sea_level = 115.0
    georef = Georeference.from_origin(lat, lon, sea_level, north_deg=0.0)
    plan = Plan.build(get_camera("m3e"), R_from_gimbal([0.0, 90.0], [-30.0, -45.0]), [[0, 10, 20], [5, 10, 25]])
    (kmz,), _ = exported(tmp_path, plan, "wpml", georef, takeoff=[0, 0, 0])
    cfg = kmz_docs(kmz)["wpmz/template.kml"].find("kml:Document/wpml:missionConfig", NS)
    t_lat, t_lon, t_h = map(float, cfg.findtext("wpml:takeOffRefPoint", namespaces=NS).split(","))
    assert (t_lat, t_lon) == pytest.approx((lat, lon), abs=1e-9)
    assert t_h == pytest.approx(sea_level + n, abs=0.5)
    (path,), _ = exported(tmp_path, plan, "geojson", georef, takeoff=[0, 0, 0])
    features = json.loads(path.read_text())["features"]
    route = next(f for f in features if f["properties"]["kind"] == "path")
    assert route["properties"]["takeoff"][2] == pytest.approx(sea_level + n, abs=0.5)
    first = next(f for f in features if f["properties"]["kind"] == "waypoint")
    assert first["geometry"]["coordinates"][2] == pytest.approx(sea_level + 20.0 + n, abs=0.5)
    assert first["properties"]["height_m"] == pytest.approx(sea_level + 20.0, abs=0.01)
    # KML's absolute altitudes are above the EGM96 geoid: the sea-level heights as they are
    (path,), _ = exported(tmp_path, plan, "kml", georef, takeoff=[0, 0, 0])
    point = ET.parse(path).getroot().find(".//kml:Point/kml:coordinates", NS).text
    assert float(point.split(",")[2]) == pytest.approx(sea_level + 20.0, abs=0.01)


# -- DJI WPML ----------------------------------------------------------------------------------


@pytest.mark.parametrize("kind", GEOREFS)
def test_wpml_has_every_required_element(tmp_path, kind):
    require_geoid()
    georef, _ = GEOREFS[kind]
    paths, _ = exported(tmp_path, facade_plan(), "wpml", georef)
    assert len(paths) == 2
    rotations = 0
    for path in paths:
        for name, root in kmz_docs(path).items():
            assert missing_required(root, REQUIRED[name]) == [], (path.name, name)
            rotations += len(root.findall(".//wpml:actionActuatorFunc[.='rotateYaw']", NS))
        template = kmz_docs(path)["wpmz/template.kml"]
        folder = template.find("kml:Document/kml:Folder", NS)
        assert folder.findtext("wpml:globalWaypointTurnMode", namespaces=NS) == "toPointAndStopWithDiscontinuityCurvature"
        assert folder.findtext("wpml:payloadParam/wpml:imageFormat", namespaces=NS) == "wide"
    assert rotations > 0  # the facade positions take three headings each: the check saw rotateYaw too


def test_wpml_ellipsoid_height_equals_height_relative_to_the_start_point(tmp_path):
    require_geoid()
    paths, _ = exported(tmp_path, facade_plan(), "wpml")
    for path in paths:
        docs = kmz_docs(path)
        folder = docs["wpmz/template.kml"].find("kml:Document/kml:Folder", NS)
        assert folder.findtext("wpml:waylineCoordinateSysParam/wpml:heightMode", namespaces=NS) == "relativeToStartPoint"
        marks = folder.findall("kml:Placemark", NS)
        executed = docs["wpmz/waylines.wpml"].findall(".//kml:Placemark", NS)
        assert len(marks) == len(executed) > 0
        for m, e in zip(marks, executed):
            height = m.findtext("wpml:height", namespaces=NS)
            assert m.findtext("wpml:ellipsoidHeight", namespaces=NS) == height
            assert e.findtext("wpml:executeHeight", namespaces=NS) == height


def test_wpml_headings_are_exact_floats_without_extra_turns(tmp_path):
    require_geoid()
    georef, offset = GEOREFS["topocentric"]
    plan = Plan.build(get_camera("m3e"), R_from_gimbal([12.345, 200.5], [-30.0, -10.0]), [[0, -5, 6], [4, -5, 6]])
    (path,), _ = exported(tmp_path, plan, "wpml", georef)
    root = kmz_docs(path)["wpmz/waylines.wpml"]
    angles = [float(e.text) for e in root.iterfind(".//wpml:waypointHeadingAngle", NS)]
    assert angle_diff(angles[0], 12.345 + offset) < 1e-4 and angle_diff(angles[1], 200.5 + offset) < 1e-4
    assert all(-180 <= a <= 180 for a in angles)
    assert root.findall(".//wpml:actionActuatorFunc[.='rotateYaw']", NS) == []


def test_wpml_aircraft_from_the_camera_or_chosen(tmp_path):
    require_geoid()
    georef, _ = GEOREFS["topocentric"]

    def enums(path: Path) -> tuple[str, str, str]:
        cfg = kmz_docs(path)["wpmz/waylines.wpml"].find("kml:Document/wpml:missionConfig", NS)
        return tuple(cfg.findtext(f"wpml:{k}", namespaces=NS) for k in (
            "droneInfo/wpml:droneEnumValue", "droneInfo/wpml:droneSubEnumValue", "payloadInfo/wpml:payloadEnumValue"))

    def one(camera: str) -> Plan:
        return Plan.build(get_camera(camera), R_from_gimbal([0.0], [-45.0]), [[0, -5, 6]])

    for camera, want in (("m3e", ("77", "0", "66")), ("h20", ("89", "0", "42")), ("p1", ("89", "0", "50"))):
        (path,), report = exported(tmp_path, one(camera), "wpml", georef, name=camera)
        assert enums(path) == want, camera
        assert "DJI WPML for DJI M" in report[0].summary()
    # a Phantom 4 Pro flies on no aircraft DJI Pilot 2 takes: refused, naming the choices (no file is written)
    with pytest.raises(AircraftError, match=r"Phantom 4 Pro.*--aircraft.*m3e \(DJI Mavic 3 Enterprise\).*m350-h20"):
        exported(tmp_path, one("p4p"), "wpml", georef, name="p4p")
    assert not (tmp_path / "p4p.kmz").exists()
    (path,), report = exported(tmp_path, one("p4p"), "wpml", georef, name="p4p", aircraft="m3e")
    assert enums(path) == ("77", "0", "66")
    line = report[0].summary()
    assert "for DJI Mavic 3 Enterprise" in line and "Phantom 4 Pro" in line  # said, not silent
    (path,), _ = exported(tmp_path, one("m3e"), "wpml", georef, name="m300", aircraft="M300-P1")
    assert enums(path) == ("60", "0", "50")
    with pytest.raises(AircraftError, match="unknown DJI aircraft 'mavic'.*m3e"):
        exported(tmp_path, one("m3e"), "wpml", georef, aircraft="mavic")


def test_wpml_speed_and_gimbal_pitch_within_the_aircrafts_ranges(tmp_path):
    require_geoid()
    georef, _ = GEOREFS["topocentric"]
    plan = Plan.build(get_camera("m3e"), R_from_gimbal([0.0, 0.0], [-10.0, 33.0]), [[0, -5, 6], [1, -5, 6]],
                      frame_names=["level", "up33"])
    for speed in (0.5, 20.0):
        with pytest.raises(AircraftError, match=rf"{speed:g} m/s is outside the DJI Mavic 3 Enterprise's .* 1 to 15 m/s"):
            exported(tmp_path, plan, "wpml", georef, speed_m_s=speed)
    (path,), _ = exported(tmp_path, plan, "wpml", georef, speed_m_s=15.0)  # the M3E's gimbal tilts up to +35°
    root = kmz_docs(path)["wpmz/waylines.wpml"]
    assert {float(e.text) for e in root.iterfind(".//wpml:waypointSpeed", NS)} == {15.0}
    assert float(root.findtext(".//wpml:globalTransitionalSpeed", namespaces=NS)) == 15.0
    with pytest.raises(PlanError, match=r"up33 have a gimbal pitch of \+33\.0°, outside .*-90° to \+30°"):
        exported(tmp_path, plan, "wpml", georef, aircraft="m350-h20")


@pytest.mark.parametrize("kind", GEOREFS)
def test_wpml_round_trip_through_sightplans_importer(tmp_path, kind):
    require_geoid()
    georef, _ = GEOREFS[kind]
    plan = facade_plan()
    paths, _ = exported(tmp_path, plan, "wpml", georef)
    back = [read_wpml(p, georef=georef) for p in paths]
    np.testing.assert_allclose(np.vstack([b.C_world for b in back]), plan.C_world, atol=0.01)
    h0, p0, _ = gimbal_from_R(plan.R_world_camera)
    h1, p1, _ = (np.concatenate(v) for v in zip(*(gimbal_from_R(b.R_world_camera) for b in back)))
    assert max(angle_diff(a, b) for a, b in zip(h0, h1)) < 0.01
    np.testing.assert_allclose(p1, p0, atol=0.01)
    for b in back:
        np.testing.assert_allclose(b.parameters["takeoff_m"], TAKEOFF, atol=0.01)
        assert not [w for w in b.parameters["warnings"] if "geoid" in w]


# -- each mission from its own ground station ---------------------------------------------------

STATIONS = [(-10.0, -20.0, 1.5), (20.0, -25.0, 2.5)]  # the second stands 1 m higher: its ground is 1 m higher


def two_station_plan() -> Plan:
    C = np.array([[0, -10, 6], [4, -10, 6], [8, -10, 9], [12, -10, 9]], float)
    return Plan.build(get_camera("m3e"), R_from_gimbal([0, 0, 10, 10], [-20, -20, -30, -30]), C,
                      missions=(Mission("a", 0, 2, STATIONS[0]), Mission("b", 2, 4, STATIONS[1])))


def takeoffs_expected() -> list[np.ndarray]:
    ground = TAKEOFF_A[2]
    return [np.array([x, y, ground + z - STATIONS[0][2]]) for x, y, z in STATIONS]


TAKEOFF_A = np.array([-10.0, -20.0, 0.0])  # the plan's take-off point: on the ground under the first station


@pytest.mark.parametrize("fmt", ["qgc", "wpl", "wpml", "litchi"])
def test_each_mission_takes_off_from_its_own_ground_station(tmp_path, fmt):
    if fmt == "wpml":
        require_geoid()
    georef, _ = GEOREFS["projected"]
    plan = two_station_plan()
    paths, report = exported(tmp_path, plan, fmt, georef, takeoff=TAKEOFF_A)
    assert len(paths) == len(report) == 2
    for start, f, first_z in zip(takeoffs_expected(), report, (6.0, 9.0)):
        got = georef.from_geodetic(f.takeoff.latitude_deg, f.takeoff.longitude_deg, f.takeoff.height_m)[0]
        np.testing.assert_allclose(got, start, atol=0.01)
        assert f.lowest_altitude_m == pytest.approx(first_z - start[2], abs=0.01)
        assert f"lowest waypoint {first_z - start[2]:+.1f} m above take-off" in f.summary()
    if fmt == "qgc":
        homes = [json.loads(p.read_text())["mission"]["plannedHomePosition"] for p in paths]
        for home, start in zip(homes, takeoffs_expected()):
            np.testing.assert_allclose(georef.from_geodetic(*home)[0], start, atol=0.01)
    if fmt == "wpml":
        for path, start in zip(paths, takeoffs_expected()):
            ref = kmz_docs(path)["wpmz/template.kml"].findtext(".//wpml:takeOffRefPoint", namespaces=NS)
            lat, lon, h = map(float, ref.split(","))
            np.testing.assert_allclose(georef.from_geodetic(lat, lon, geoid.to_orthometric(lat, lon, h))[0], start,
                                       atol=0.01)
    if fmt == "litchi":
        assert all("Heading Mode = Custom" in f.summary() and "DJI Mavic 3 Enterprise" in f.summary() for f in report)
    # a take-off point given for all (--takeoff): every mission from there
    paths, report = exported(tmp_path, plan, fmt, georef, name="all", takeoff=TAKEOFF_A, per_mission_takeoff=False)
    for f in report:
        got = georef.from_geodetic(f.takeoff.latitude_deg, f.takeoff.longitude_deg, f.takeoff.height_m)[0]
        np.testing.assert_allclose(got, TAKEOFF_A, atol=0.01)


def test_maps_record_each_missions_take_off(tmp_path):
    require_geoid()
    georef, _ = GEOREFS["topocentric"]
    (path,), _ = exported(tmp_path, two_station_plan(), "geojson", georef, takeoff=TAKEOFF_A)
    features = json.loads(path.read_text())["features"]
    routes = [f for f in features if f["properties"]["kind"] == "path"]
    for route, start in zip(routes, takeoffs_expected()):
        lon, lat, h = route["properties"]["takeoff"]
        np.testing.assert_allclose(georef.from_geodetic(lat, lon, geoid.to_orthometric(lat, lon, h))[0], start, atol=0.01)
    altitudes = [f["properties"]["altitude_m"] for f in features if f["properties"]["kind"] == "waypoint"]
    assert altitudes == pytest.approx([6.0, 6.0, 8.0, 8.0], abs=0.01)  # mission b above its own, 1 m higher, ground
    (path,), _ = exported(tmp_path, two_station_plan(), "kml", georef, takeoff=TAKEOFF_A)
    takeoffs = [d.findtext("kml:value", namespaces=NS) for d in ET.parse(path).getroot().iterfind(".//kml:Data", NS)
                if d.get("name") == "takeoff"]
    assert len(takeoffs) == 2
    lon, lat, h = map(float, takeoffs[1].split(","))
    np.testing.assert_allclose(georef.from_geodetic(lat, lon, h)[0], takeoffs_expected()[1], atol=0.01)
    assert math.isfinite(h)
