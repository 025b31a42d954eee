"""DJI WPML export: a ``.kmz`` (zip) with ``wpmz/template.kml`` and ``wpmz/waylines.wpml``.

Both are KML 2.2 documents (namespace ``http://www.opengis.net/kml/2.2``) with DJI's elements in
``http://www.dji.com/wpmz/1.0.2`` (prefix ``wpml``), as DJI Pilot 2 and FlightHub 2 read them. Every
element that DJI's WPML reference (template.kml, waylines.wpml and common-element pages of the Cloud
API documentation) marks required is written:

- ``missionConfig`` (both files): ``flyToWaylineMode`` safely, ``finishAction`` goHome, ``exitOnRCLost``
  executeLostAction with ``executeRCLostAction`` goBack, ``takeOffSecurityHeight`` (the first
  waypoint's altitude, 2 to 1500 m), ``globalTransitionalSpeed`` (the flight speed), ``globalRTHHeight``
  (the highest waypoint's altitude + 10 m, 2 to 1500 m), ``droneInfo`` and ``payloadInfo`` of the
  aircraft (:data:`AIRCRAFT`). The template also carries ``takeOffRefPoint`` "lat,lon,h" with h the
  take-off point's WGS84 **ellipsoidal** height (the model's sea-level height + the EGM96 geoid
  undulation, :mod:`sightplan.geoid`) and ``takeOffRefPointAGLHeight`` 0 (it is on the ground).
- One ``Folder`` per mission (``templateId`` = ``waylineId`` = index from 0 within the file). Template:
  ``templateType`` waypoint, ``waylineCoordinateSysParam`` (WGS84, relativeToStartPoint),
  ``autoFlightSpeed``, ``payloadParam`` (``payloadPositionIndex`` 0, ``imageFormat`` of the camera),
  ``gimbalPitchMode`` usePointSetting, ``globalWaypointHeadingParam``, ``globalWaypointTurnMode``,
  ``globalUseStraightLine`` and ``globalHeight``. Waylines: ``executeHeightMode`` relativeToStartPoint.
- One ``Placemark`` per waypoint: ``Point`` "lon,lat", ``index`` from 0; template ``height`` and
  ``ellipsoidHeight`` both the altitude above the take-off point (DJI: equal in relative mode),
  waylines ``executeHeight`` the same; ``waypointSpeed``; ``waypointHeadingParam`` (smoothTransition to
  ``waypointHeadingAngle``, the first photo's exact true heading in −180..180);
  ``waypointTurnParam`` toPointAndStopWithDiscontinuityCurvature; the template's
  ``gimbalPitchAngle``; an ``actionGroup`` (trigger reachPoint) with per photo ``rotateYaw``
  (``aircraftHeading``, only when a photo's heading differs from the aircraft's), ``gimbalRotate``
  (absolute ``gimbalPitchRotateAngle``) and ``takePhoto`` (``fileSuffix`` = frame name,
  ``payloadLensIndex`` = the ``imageFormat``).

The aircraft is the one the plan's camera flies on (:func:`resolve_aircraft`), or the one chosen
(``aircraft=``, ``--aircraft``); a camera no DJI aircraft in :data:`AIRCRAFT` carries (e.g. a Phantom 4
Pro, which DJI Pilot 2 does not fly) is refused naming the choices. Speeds outside DJI's 1–15 m/s and
gimbal pitches outside the aircraft's range are refused too.
"""

from __future__ import annotations

import re
import time
import zipfile
from pathlib import Path
from xml.etree import ElementTree as ET

from ..camera.catalogue import list_cameras
from ..errors import PlanError
from ..formats.dji import AIRCRAFT, KML_NS, WPML_NS, DjiAircraft
from ..plan.types import Plan
from .common import Flight, Waypoint, number_text, same_angle, wrap180

HEIGHT_RANGE_M = (2.0, 1500.0)  # takeOffSecurityHeight (DJI: 1.2 with a remote controller) and globalRTHHeight
RTH_MARGIN_M = 10.0
HEADING_TOLERANCE_DEG = 0.001


class AircraftError(PlanError):
    """A DJI aircraft that cannot fly the plan as asked: unknown, a camera it does not carry, a speed or pitch out of
    its range."""


def aircraft_choices() -> str:
    return ", ".join(f"{a.key} ({a.name})" for a in AIRCRAFT.values())


def _catalogue_id(camera) -> str | None:
    name = str(getattr(camera, "name", "") or "")
    for entry in list_cameras():
        if name == entry.name or name.startswith(entry.name + " ("):
            return entry.id
    return None


def resolve_aircraft(plan: Plan, aircraft: str | None = None) -> tuple[DjiAircraft, str | None]:
    """(the DJI aircraft to write, a note when it does not carry the plan's camera).

    aircraft: a key of :data:`AIRCRAFT` (chosen by the user); None: the first aircraft that carries the plan's
    camera. Raises :class:`AircraftError` naming the choices for an unknown key or a camera no aircraft carries."""
    cams = [c for c in plan.cameras.values()]
    ids = [_catalogue_id(c) for c in cams]
    names = ", ".join(dict.fromkeys(str(getattr(c, "name", "") or "unnamed camera") for c in cams))
    if aircraft is not None:
        key = str(aircraft).strip().lower()
        if key not in AIRCRAFT:
            raise AircraftError(f"unknown DJI aircraft {aircraft!r}; choose one of: {aircraft_choices()}")
        chosen = AIRCRAFT[key]
        note = None if all(i in chosen.cameras for i in ids) else (
            f"chosen for a plan made with {names}: the {chosen.name} flies the positions and angles with its own camera")
        return chosen, note
    for a in AIRCRAFT.values():
        if ids and all(i in a.cameras for i in ids):
            return a, None
    raise AircraftError(f"the plan's camera ({names}) is on no aircraft that DJI Pilot 2 flies from a WPML file; "
                        f"choose the aircraft with --aircraft (aircraft=): {aircraft_choices()}")


def check_speed(aircraft: DjiAircraft, speed_m_s: float) -> None:
    lo, hi = aircraft.speed_range
    if not lo <= float(speed_m_s) <= hi:
        raise AircraftError(f"a flight speed of {float(speed_m_s):g} m/s is outside the {aircraft.name}'s waypoint speed "
                            f"range in DJI WPML, {lo:g} to {hi:g} m/s: set --speed (speed=) within it")


def _el(parent: ET.Element, tag: str, text: str | float | int | None = None) -> ET.Element:
    ns, _, name = tag.partition(":") if ":" in tag else ("kml", "", tag)
    el = ET.SubElement(parent, f"{{{WPML_NS if ns == 'wpml' else KML_NS}}}{name}")
    if text is not None:
        el.text = text if isinstance(text, str) else number_text(text)
    return el


def _suffix(name: str) -> str:
    return re.sub(r"[^A-Za-z0-9_-]", "_", name)[:64] or "photo"


def _clip(v: float, lo_hi: tuple[float, float]) -> float:
    return min(max(float(v), lo_hi[0]), lo_hi[1])


def _mission_config(parent: ET.Element, flight: Flight, aircraft: DjiAircraft, template: bool) -> None:
    from ..geoid import to_ellipsoidal

    altitudes = [w.altitude_m for w in flight.waypoints]
    cfg = _el(parent, "wpml:missionConfig")
    _el(cfg, "wpml:flyToWaylineMode", "safely")
    _el(cfg, "wpml:finishAction", "goHome")
    _el(cfg, "wpml:exitOnRCLost", "executeLostAction")
    _el(cfg, "wpml:executeRCLostAction", "goBack")
    _el(cfg, "wpml:takeOffSecurityHeight", _clip(altitudes[0], HEIGHT_RANGE_M))
    if template:
        lat, lon, h = flight.takeoff_latitude_deg, flight.takeoff_longitude_deg, flight.takeoff_height_m
        ellipsoidal = float(to_ellipsoidal(lat, lon, h)[0])
        _el(cfg, "wpml:takeOffRefPoint", f"{lat:.9f},{lon:.9f},{ellipsoidal:.4f}")
        _el(cfg, "wpml:takeOffRefPointAGLHeight", 0)  # the take-off point is on the ground
    _el(cfg, "wpml:globalTransitionalSpeed", flight.speed_m_s)
    _el(cfg, "wpml:globalRTHHeight", number_text(_clip(max(altitudes) + RTH_MARGIN_M, HEIGHT_RANGE_M), 4))
    info = _el(cfg, "wpml:droneInfo")
    _el(info, "wpml:droneEnumValue", aircraft.drone)
    _el(info, "wpml:droneSubEnumValue", aircraft.sub)
    pay = _el(cfg, "wpml:payloadInfo")
    _el(pay, "wpml:payloadEnumValue", aircraft.payload)
    _el(pay, "wpml:payloadPositionIndex", 0)


def _action(group: ET.Element, action_id: int, func: str, params: list[tuple[str, str | float | int]]) -> None:
    action = _el(group, "wpml:action")
    _el(action, "wpml:actionId", action_id)
    _el(action, "wpml:actionActuatorFunc", func)
    p = _el(action, "wpml:actionActuatorFuncParam")
    for key, value in params:
        _el(p, f"wpml:{key}", value)


def _heading_param(parent: ET.Element, tag: str, heading: float | None) -> None:
    hp = _el(parent, tag)
    if heading is None:
        _el(hp, "wpml:waypointHeadingMode", "followWayline")
    else:
        _el(hp, "wpml:waypointHeadingMode", "smoothTransition")
        _el(hp, "wpml:waypointHeadingAngle", number_text(heading, 6))
        _el(hp, "wpml:waypointPoiPoint", "0.000000,0.000000,0.000000")
        _el(hp, "wpml:waypointHeadingAngleEnable", 1)
    _el(hp, "wpml:waypointHeadingPathMode", "followBadArc")


def _placemark(folder: ET.Element, flight: Flight, aircraft: DjiAircraft, wp: Waypoint, index: int, group_id: int,
               template: bool) -> None:
    pm = _el(folder, "Placemark")
    _el(_el(pm, "Point"), "coordinates", f"{wp.longitude_deg:.9f},{wp.latitude_deg:.9f}")
    _el(pm, "wpml:index", index)
    altitude = number_text(wp.altitude_m, 4)
    if template:
        _el(pm, "wpml:ellipsoidHeight", altitude)  # relativeToStartPoint: DJI takes both as the height above take-off
        _el(pm, "wpml:height", altitude)
        _el(pm, "wpml:useGlobalHeight", 0)
        _el(pm, "wpml:useGlobalSpeed", 0)
    else:
        _el(pm, "wpml:executeHeight", altitude)
    _el(pm, "wpml:waypointSpeed", flight.speed_m_s)
    heading = wrap180(wp.photos[0].heading_deg)
    if template:
        _el(pm, "wpml:useGlobalHeadingParam", 0)
    _heading_param(pm, "wpml:waypointHeadingParam", heading)
    if template:
        _el(pm, "wpml:useGlobalTurnParam", 0)
    tp = _el(pm, "wpml:waypointTurnParam")
    _el(tp, "wpml:waypointTurnMode", "toPointAndStopWithDiscontinuityCurvature")
    _el(tp, "wpml:waypointTurnDampingDist", 0)
    _el(pm, "wpml:useStraightLine", 1)
    if template:
        _el(pm, "wpml:gimbalPitchAngle", number_text(wp.photos[0].pitch_deg, 6))
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
            heading = wrap180(photo.heading_deg)
            _action(group, action_id, "rotateYaw", [("aircraftHeading", number_text(heading, 6)),
                                                    ("aircraftPathMode", "clockwise" if turn >= 0 else "counterClockwise")])
            action_id += 1
        _action(group, action_id, "gimbalRotate", [
            ("gimbalHeadingYawBase", "north"), ("gimbalRotateMode", "absoluteAngle"), ("gimbalPitchRotateEnable", 1),
            ("gimbalPitchRotateAngle", number_text(photo.pitch_deg, 6)), ("gimbalRollRotateEnable", 0),
            ("gimbalRollRotateAngle", 0), ("gimbalYawRotateEnable", 0), ("gimbalYawRotateAngle", 0),
            ("gimbalRotateTimeEnable", 0), ("gimbalRotateTime", 0), ("payloadPositionIndex", 0)])
        _action(group, action_id + 1, "takePhoto", [("payloadPositionIndex", 0), ("fileSuffix", _suffix(photo.name)),
                                                    ("payloadLensIndex", aircraft.image_format),
                                                    ("useGlobalPayloadLensIndex", 0)])
        action_id += 2


def _template_folder(doc: ET.Element, flight: Flight, aircraft: DjiAircraft, template_id: int, wps: list[Waypoint]) -> ET.Element:
    folder = _el(doc, "Folder")
    _el(folder, "wpml:templateType", "waypoint")
    _el(folder, "wpml:templateId", template_id)
    cs = _el(folder, "wpml:waylineCoordinateSysParam")
    _el(cs, "wpml:coordinateMode", "WGS84")
    _el(cs, "wpml:heightMode", "relativeToStartPoint")
    _el(cs, "wpml:positioningType", "GPS")
    _el(folder, "wpml:autoFlightSpeed", flight.speed_m_s)
    pp = _el(folder, "wpml:payloadParam")
    _el(pp, "wpml:payloadPositionIndex", 0)
    _el(pp, "wpml:imageFormat", aircraft.image_format)
    _el(folder, "wpml:gimbalPitchMode", "usePointSetting")
    _heading_param(folder, "wpml:globalWaypointHeadingParam", None)
    _el(folder, "wpml:globalWaypointTurnMode", "toPointAndStopWithDiscontinuityCurvature")
    _el(folder, "wpml:globalUseStraightLine", 1)
    _el(folder, "wpml:globalHeight", number_text(wps[0].altitude_m, 4))
    return folder


def _document(flight: Flight, aircraft: DjiAircraft, template: bool) -> bytes:
    ET.register_namespace("", KML_NS)
    ET.register_namespace("wpml", WPML_NS)
    root = ET.Element(f"{{{KML_NS}}}kml")
    doc = _el(root, "Document")
    if template:
        now = str(int(time.time() * 1000))
        _el(doc, "wpml:author", "sightplan")
        _el(doc, "wpml:createTime", now)
        _el(doc, "wpml:updateTime", now)
    _mission_config(doc, flight, aircraft, template)
    group_id = 0
    for k, (_, wps) in enumerate(flight.by_mission()):
        if template:
            folder = _template_folder(doc, flight, aircraft, k, wps)
        else:
            folder = _el(doc, "Folder")
            _el(folder, "wpml:templateId", k)
            _el(folder, "wpml:executeHeightMode", "relativeToStartPoint")
            _el(folder, "wpml:waylineId", k)
            _el(folder, "wpml:autoFlightSpeed", flight.speed_m_s)
        for index, wp in enumerate(wps):
            _placemark(folder, flight, aircraft, wp, index, group_id, template)
            group_id += 1
    ET.indent(root, space="  ")
    return ET.tostring(root, encoding="utf-8", xml_declaration=True)


def write_wpml(flight: Flight, path: Path, aircraft: DjiAircraft | str | None = None) -> list[Path]:
    """Write ``flight`` (every mission a wayline; :func:`~sightplan.export.export_plan` gives each mission its own file)
    for ``aircraft`` (a :class:`DjiAircraft`, a key of :data:`AIRCRAFT`, or None: the plan camera's)."""
    if not isinstance(aircraft, DjiAircraft):
        aircraft = resolve_aircraft(flight.plan, aircraft)[0]
    check_speed(aircraft, flight.speed_m_s)
    template = _document(flight, aircraft, template=True)
    waylines = _document(flight, aircraft, template=False)
    with zipfile.ZipFile(path, "w", compression=zipfile.ZIP_DEFLATED) as z:
        z.writestr("wpmz/template.kml", template)
        z.writestr("wpmz/waylines.wpml", waylines)
    return [path]
