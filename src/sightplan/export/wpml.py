"""DJI WPML export: a ``.kmz`` (zip) with ``wpmz/template.kml`` and ``wpmz/waylines.wpml``.

Both are KML 2.2 documents (namespace ``http://www.opengis.net/kml/2.2``) with DJI's elements in
``http://www.dji.com/wpmz/1.0.2`` (prefix ``wpml``), as DJI Pilot 2 and FlightHub 2 read them:

- ``missionConfig``: ``flyToWaylineMode`` safely, ``finishAction`` goHome, ``exitOnRCLost``
  executeLostAction with ``executeRCLostAction`` goBack, ``takeOffSecurityHeight`` (the first
  waypoint's altitude, 2 to 1500 m), ``globalTransitionalSpeed`` (≤ 15 m/s), ``droneInfo`` and
  ``payloadInfo`` (from the plan's camera where the catalogue knows its aircraft: Mavic 3 Enterprise;
  Zenmuse H20 and P1 on a Matrice 350 RTK; otherwise a Mavic 3 Enterprise). The template also carries
  ``takeOffRefPoint`` "lat,lon,height" (height in the georeference's datum).
- One ``Folder`` per mission (``templateId`` = ``waylineId`` = mission number − 1) with
  ``executeHeightMode`` relativeToStartPoint; one ``Placemark`` per waypoint: ``Point`` coordinates
  "lon,lat", ``index`` from 0, ``executeHeight`` (metres above take-off), ``waypointSpeed``,
  ``waypointHeadingParam`` (smoothTransition to ``waypointHeadingAngle``, the whole degree nearest the
  first photo's true heading, in −180..180), ``waypointTurnParam``
  toPointAndStopWithDiscontinuityCurvature, and an ``actionGroup`` (trigger reachPoint) with per
  photo ``rotateYaw`` (``aircraftHeading``, exact, when it differs from the aircraft's heading),
  ``gimbalRotate`` (absolute ``gimbalPitchRotateAngle``) and ``takePhoto`` (``fileSuffix`` = frame name).
"""

from __future__ import annotations

import re
import time
import zipfile
from pathlib import Path
from xml.etree import ElementTree as ET

from ..camera.catalogue import list_cameras
from .common import Flight, Waypoint, number_text, same_angle, wrap180

KML_NS = "http://www.opengis.net/kml/2.2"
WPML_NS = "http://www.dji.com/wpmz/1.0.2"
MAX_TRANSITIONAL_SPEED = 15.0
# catalogue id → (droneEnumValue, droneSubEnumValue, payloadEnumValue)
DRONES = {"m3e": (77, 0, 66), "h20-wide": (89, 0, 42), "p1-35": (89, 0, 50)}
DEFAULT_DRONE = DRONES["m3e"]
HEADING_TOLERANCE_DEG = 0.001


def _drone(flight: Flight) -> tuple[int, int, int]:
    by_name = {e.name: e.id for e in list_cameras()}
    for cam in flight.plan.cameras.values():
        key = by_name.get(getattr(cam, "name", ""))
        if key in DRONES:
            return DRONES[key]
    return DEFAULT_DRONE


def _el(parent: ET.Element, tag: str, text: str | float | int | None = None) -> ET.Element:
    ns, _, name = tag.partition(":") if ":" in tag else ("kml", "", tag)
    el = ET.SubElement(parent, f"{{{WPML_NS if ns == 'wpml' else KML_NS}}}{name}")
    if text is not None:
        el.text = text if isinstance(text, str) else number_text(text)
    return el


def _suffix(name: str) -> str:
    return re.sub(r"[^A-Za-z0-9_-]", "_", name)[:64] or "photo"


def _mission_config(parent: ET.Element, flight: Flight, first_altitude: float, template: bool) -> None:
    cfg = _el(parent, "wpml:missionConfig")
    _el(cfg, "wpml:flyToWaylineMode", "safely")
    _el(cfg, "wpml:finishAction", "goHome")
    _el(cfg, "wpml:exitOnRCLost", "executeLostAction")
    _el(cfg, "wpml:executeRCLostAction", "goBack")
    _el(cfg, "wpml:takeOffSecurityHeight", min(max(first_altitude, 2.0), 1500.0))
    if template:
        _el(cfg, "wpml:takeOffRefPoint", f"{flight.takeoff_latitude_deg:.9f},{flight.takeoff_longitude_deg:.9f},"
                                         f"{flight.takeoff_height_m:.4f}")
        _el(cfg, "wpml:takeOffRefPointAGLHeight", 0)
    _el(cfg, "wpml:globalTransitionalSpeed", min(flight.speed_m_s, MAX_TRANSITIONAL_SPEED))
    drone, sub, payload = _drone(flight)
    info = _el(cfg, "wpml:droneInfo")
    _el(info, "wpml:droneEnumValue", drone)
    _el(info, "wpml:droneSubEnumValue", sub)
    pay = _el(cfg, "wpml:payloadInfo")
    _el(pay, "wpml:payloadEnumValue", payload)
    _el(pay, "wpml:payloadPositionIndex", 0)


def _action(group: ET.Element, action_id: int, func: str, params: list[tuple[str, str | float | int]]) -> None:
    action = _el(group, "wpml:action")
    _el(action, "wpml:actionId", action_id)
    _el(action, "wpml:actionActuatorFunc", func)
    p = _el(action, "wpml:actionActuatorFuncParam")
    for key, value in params:
        _el(p, f"wpml:{key}", value)


def _placemark(folder: ET.Element, flight: Flight, wp: Waypoint, index: int, group_id: int, template: bool) -> None:
    pm = _el(folder, "Placemark")
    _el(_el(pm, "Point"), "coordinates", f"{wp.longitude_deg:.9f},{wp.latitude_deg:.9f}")
    _el(pm, "wpml:index", index)
    if template:
        _el(pm, "wpml:useGlobalHeight", 0)
        _el(pm, "wpml:height", wp.altitude_m)
        _el(pm, "wpml:ellipsoidHeight", wp.height_m)
        _el(pm, "wpml:useGlobalSpeed", 0)
        _el(pm, "wpml:useGlobalHeadingParam", 0)
        _el(pm, "wpml:useGlobalTurnParam", 0)
    else:
        _el(pm, "wpml:executeHeight", number_text(wp.altitude_m, 4))
    _el(pm, "wpml:waypointSpeed", flight.speed_m_s)
    heading = float(round(wrap180(wp.photos[0].heading_deg)))
    hp = _el(pm, "wpml:waypointHeadingParam")
    _el(hp, "wpml:waypointHeadingMode", "smoothTransition")
    _el(hp, "wpml:waypointHeadingAngle", str(int(heading)))
    _el(hp, "wpml:waypointPoiPoint", "0.000000,0.000000,0.000000")
    _el(hp, "wpml:waypointHeadingAngleEnable", 1)
    _el(hp, "wpml:waypointHeadingPathMode", "followBadArc")
    tp = _el(pm, "wpml:waypointTurnParam")
    _el(tp, "wpml:waypointTurnMode", "toPointAndStopWithDiscontinuityCurvature")
    _el(tp, "wpml:waypointTurnDampingDist", 0)
    _el(pm, "wpml:useStraightLine", 1)
    if template:
        _el(pm, "wpml:gimbalPitchAngle", wp.photos[0].pitch_deg)
    group = _el(pm, "wpml:actionGroup")
    _el(group, "wpml:actionGroupId", group_id)
    _el(group, "wpml:actionGroupStartIndex", index)
    _el(group, "wpml:actionGroupEndIndex", index)
    _el(group, "wpml:actionGroupMode", "sequence")
    _el(_el(group, "wpml:actionTrigger"), "wpml:actionTriggerType", "reachPoint")
    action_id = 0
    for photo in wp.photos:
        if not same_angle(photo.heading_deg, heading, HEADING_TOLERANCE_DEG):
            turn = wrap180(photo.heading_deg - heading)
            heading = photo.heading_deg
            _action(group, action_id, "rotateYaw", [("aircraftHeading", number_text(wrap180(heading), 6)),
                                                    ("aircraftPathMode", "clockwise" if turn >= 0 else "counterClockwise")])
            action_id += 1
        _action(group, action_id, "gimbalRotate", [
            ("gimbalHeadingYawBase", "north"), ("gimbalRotateMode", "absoluteAngle"), ("gimbalPitchRotateEnable", 1),
            ("gimbalPitchRotateAngle", number_text(photo.pitch_deg, 6)), ("gimbalRollRotateEnable", 0),
            ("gimbalRollRotateAngle", 0), ("gimbalYawRotateEnable", 0), ("gimbalYawRotateAngle", 0),
            ("gimbalRotateTimeEnable", 0), ("gimbalRotateTime", 0), ("payloadPositionIndex", 0)])
        _action(group, action_id + 1, "takePhoto", [("payloadPositionIndex", 0), ("fileSuffix", _suffix(photo.name)),
                                                    ("useGlobalPayloadLensIndex", 1)])
        action_id += 2


def _document(flight: Flight, template: bool) -> bytes:
    ET.register_namespace("", KML_NS)
    ET.register_namespace("wpml", WPML_NS)
    root = ET.Element(f"{{{KML_NS}}}kml")
    doc = _el(root, "Document")
    groups = flight.by_mission()
    if template:
        now = str(int(time.time() * 1000))
        _el(doc, "wpml:author", "sightplan")
        _el(doc, "wpml:createTime", now)
        _el(doc, "wpml:updateTime", now)
    _mission_config(doc, flight, groups[0][1][0].altitude_m, template)
    group_id = 0
    for number, wps in groups:
        folder = _el(doc, "Folder")
        if template:
            _el(folder, "wpml:templateType", "waypoint")
        _el(folder, "wpml:templateId", number - 1)
        if template:
            cs = _el(folder, "wpml:waylineCoordinateSysParam")
            _el(cs, "wpml:coordinateMode", "WGS84")
            _el(cs, "wpml:heightMode", "relativeToStartPoint")
            _el(folder, "wpml:autoFlightSpeed", flight.speed_m_s)
            _el(folder, "wpml:gimbalPitchMode", "usePointSetting")
        else:
            _el(folder, "wpml:executeHeightMode", "relativeToStartPoint")
            _el(folder, "wpml:waylineId", number - 1)
            _el(folder, "wpml:autoFlightSpeed", flight.speed_m_s)
        for index, wp in enumerate(wps):
            _placemark(folder, flight, wp, index, group_id, template)
            group_id += 1
    ET.indent(root, space="  ")
    return ET.tostring(root, encoding="utf-8", xml_declaration=True)


def write_wpml(flight: Flight, path: Path) -> list[Path]:
    with zipfile.ZipFile(path, "w", compression=zipfile.ZIP_DEFLATED) as z:
        z.writestr("wpmz/template.kml", _document(flight, template=True))
        z.writestr("wpmz/waylines.wpml", _document(flight, template=False))
    return [path]
