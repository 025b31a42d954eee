"""DJI WPML missions, a ``.kmz`` (zip) holding ``wpmz/template.kml`` and ``wpmz/waylines.wpml`` (or either file
bare): read and written, with DJI's namespaces and the aircraft and payloads sightplan writes for and reads
(:data:`AIRCRAFT`).

Reading: ``wpmz/waylines.wpml`` (else ``wpmz/template.kml``) of a ``.kmz``, or a bare ``template.kml``
(``.kml``) or ``waylines.wpml`` (``.wpml``; a KML document is a waylines file when it has ``waylineId`` or
``executeHeight``). Both are KML documents with DJI's ``wpml`` elements (any ``http://www.dji.com/wpmz/…``
version); a KML without them is refused. Each ``Folder`` (wayline) becomes one
:class:`~sightplan.plan.types.Mission`; its ``Placemark`` waypoints, in ``index`` order, are flown as follows:

- position: ``Point`` coordinates "lon,lat"; height ``executeHeight`` (waylines; the Folder's
  ``executeHeightMode``: relativeToStartPoint, or WGS84 ellipsoidal heights) or
  ``height``/``globalHeight`` (template, ``waylineCoordinateSysParam/heightMode``: relativeToStartPoint,
  or EGM96 heights above sea level). Heights relative to the start point are added to the take-off
  point's height: the ``takeOffRefPoint`` ("lat,lon,height", the height WGS84 ellipsoidal) placed with
  the georeference (:func:`~.reading.place_takeoff`), else the model's ground ``ground_z`` under the
  first waypoint (else its height 0; with a warning). Ellipsoidal heights become heights above sea
  level, the georeference's datum, by subtracting the EGM96 geoid undulation (:mod:`sightplan.geoid`;
  without the geoid grid the reference height gives way to ``ground_z``, and other heights are read
  as they are, with a warning).
- aircraft heading on arrival: ``waypointHeadingParam`` (or the Folder's global one):
  ``waypointHeadingAngle`` (smoothTransition, fixed, manually), toward the next waypoint
  (followWayline) or toward ``waypointPoiPoint`` (towardPOI).
- gimbal pitch on arrival: the waypoint's ``waypointGimbalHeadingParam/waypointGimbalPitchAngle``
  (waylines) or ``gimbalPitchAngle`` (template) where the wayline's ``gimbalPitchMode`` (its own, else its
  template Folder's) is usePointSetting, or no mode is given and the mission has no photo action;
  otherwise the first such value is only the pitch to start with, and in manual mode none is used.
- actions (``actionGroup`` with trigger reachPoint, in order): ``rotateYaw`` sets the heading
  (``aircraftHeading``); ``gimbalRotate`` the pitch (``gimbalPitchRotateAngle``) and a gimbal yaw
  (absolute from north, or relative to the aircraft); each ``takePhoto`` makes one frame, as do
  ``orientedShoot``/``accurateShoot`` with their own heading and pitch. Groups triggered by
  multipleDistance/multipleTiming take a photo every param metres (or seconds at the wayline's
  ``autoFlightSpeed``) from their first to their last waypoint, in flight order. The gimbal pitch is
  kept from one waypoint to the next; before any is set, −90° (with a warning).
- a mission without any photo action (a DJI Pilot 2 waypoint mission of headings and gimbal pitches
  only) has a frame at every waypoint, after its actions, with the heading and pitch there (and says so
  in ``plan.parameters["warnings"]``).

DJI's area templates (``templateType`` mapping2d, mapping3d — the oblique, five-wayline survey —
and mappingStrip) hold in ``template.kml`` the survey polygon (or strip line) and its overlaps, not
waypoints: DJI Pilot 2 generates the flight into ``waylines.wpml``. With ``waylines.wpml`` in the
``.kmz`` those generated waylines are read as above (the template type is kept in
``plan.parameters["source"]["template_type"]``); a template alone, zipped or bare, is refused with a
message naming its type. A bare template of type waypoint is read as its waypoints.

A frame's name is its ``takePhoto`` ``fileSuffix`` when the file gives one. The take-off point is
``plan.parameters["takeoff_m"]``. Without a georeference the model frame is topocentric at the take-off point
(model +Y north), stored in ``plan.parameters["georeference"]``. The camera is the
payload's (``payloadEnumValue`` 66 Mavic 3E, 42 H20, 50 P1) when the catalogue has it, else ``camera``.

Writing: both files, KML 2.2 documents (namespace ``http://www.opengis.net/kml/2.2``) with DJI's elements in
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

Enumeration values: DJI Cloud API "Product Support" page (aircraft type/sub_type; camera type-subtype-gimbalindex).
Pitch ranges: the manufacturers' gimbal specs (controllable tilt), cut at −90° (sightplan's nadir).
"""

from __future__ import annotations

import math
import re
import time
import zipfile
from dataclasses import dataclass
from pathlib import Path
from xml.etree import ElementTree as ET

import numpy as np
from numpy.typing import NDArray

from ..archive import open_zip, read_entry
from ..camera.catalogue import get_camera, list_cameras
from ..camera.models import Camera
from ..errors import PlanError
from ..geo import Georeference, GeoreferenceError
from ..geometry.poses import R_from_gimbal
from ..plan import domain
from ..plan.types import Mission, Plan
from .base import FlightFormat, ReadOptions, Source, Target
from .flight import Flight, Waypoint, number_text, same_angle, wrap180
from .kml import KML_NS
from .reading import (
    DEFAULT_PITCH_DEG,
    DEFAULT_SPEED_M_S,
    bearing,
    differs,
    given_camera,
    number_cell,
    place_takeoff,
)

WPML_NS = "http://www.dji.com/wpmz/1.0.2"
SPEED_RANGE_M_S = (1.0, 15.0)  # autoFlightSpeed, waypointSpeed and globalTransitionalSpeed


@dataclass(frozen=True)
class DjiAircraft:
    """A DJI aircraft and payload for WPML: DJI's enumeration values (``droneEnumValue``, ``droneSubEnumValue``,
    ``payloadEnumValue``), the catalogue cameras it carries, the gimbal's controllable pitch range (degrees) and the
    photo lens (``imageFormat``)."""

    key: str
    name: str
    drone: int
    sub: int
    payload: int
    cameras: tuple[str, ...]
    pitch_range: tuple[float, float]
    image_format: str = "wide"
    speed_range: tuple[float, float] = SPEED_RANGE_M_S


AIRCRAFT: dict[str, DjiAircraft] = {a.key: a for a in (
    DjiAircraft("m3e", "DJI Mavic 3 Enterprise", 77, 0, 66, ("m3e",), (-90.0, 35.0)),
    DjiAircraft("m350-h20", "DJI Matrice 350 RTK with Zenmuse H20", 89, 0, 42, ("h20-wide",), (-90.0, 30.0)),
    DjiAircraft("m350-p1", "DJI Matrice 350 RTK with Zenmuse P1", 89, 0, 50, ("p1-35",), (-90.0, 40.0)),
    DjiAircraft("m300-h20", "DJI Matrice 300 RTK with Zenmuse H20", 60, 0, 42, ("h20-wide",), (-90.0, 30.0)),
    DjiAircraft("m300-p1", "DJI Matrice 300 RTK with Zenmuse P1", 60, 0, 50, ("p1-35",), (-90.0, 40.0)),
)}

#: A mission's payload → the catalogue camera it takes photos with.
PAYLOAD_CAMERAS: dict[int, str] = {a.payload: a.cameras[0] for a in AIRCRAFT.values()}
#: An aircraft whose camera is built in (no payload element needed) → its catalogue camera.
BUILT_IN_CAMERAS: dict[tuple[int, int], str] = {(a.drone, a.sub): a.cameras[0] for a in AIRCRAFT.values()
                                                if a.key == a.cameras[0]}

# ---- reading -----------------------------------------------------------------------------------

AREA_TEMPLATES = {"mapping": "area", "mapping2d": "area", "mapping3d": "area", "mappingStrip": "strip"}
ABSOLUTE_HEIGHT_MODES = {"WGS84", "EGM96"}


def _local(tag: str) -> str:
    return tag.rsplit("}", 1)[-1]


def _kids(el: ET.Element | None, name: str) -> list[ET.Element]:
    return [] if el is None else [c for c in el if _local(c.tag) == name]


def _kid(el: ET.Element | None, name: str) -> ET.Element | None:
    found = _kids(el, name)
    return found[0] if found else None


def _text(el: ET.Element | None, name: str) -> str | None:
    child = _kid(el, name)
    return child.text.strip() if child is not None and child.text is not None else None


def _num(el: ET.Element | None, name: str, where: str, default: float | None = None) -> float | None:
    return number_cell(_text(el, name), name, where, default)


def _numbers(text: str | None, n: int, what: str, where: str) -> list[float] | None:
    if not text:
        return None
    try:
        values = [float(v) for v in text.replace(" ", "").split(",")]
    except ValueError:
        raise PlanError(f"{where}: {what} {text!r} is not comma-separated numbers") from None
    if len(values) < n or not all(math.isfinite(v) for v in values[:n]):
        raise PlanError(f"{where}: {what} {text!r} needs {n} finite numbers")
    return values


@dataclass
class _Waypoint:
    index: int
    lat: float
    lon: float
    height: float
    relative: bool
    pm: ET.Element
    where: str
    ellipsoidal: bool = False  # an absolute WGS84 height (executeHeightMode WGS84)


@dataclass
class _Photo:
    wayline: int
    position: NDArray
    heading_true: float | None  # None: along the flight direction
    heading_model: float | None
    pitch: float
    name: str


MAX_ENTRY_BYTES = 64 * 1024 * 1024  # a mission's KML/WPML is kilobytes; more is not a mission file


def _kml_document(data: bytes, where: str) -> ET.Element:
    """The ``Document`` of a KML/WPML file's bytes; a PlanError starting with ``where`` when it is not one."""
    try:
        root = ET.fromstring(data)
    except ET.ParseError as exc:
        raise PlanError(f"{where}: not valid XML ({exc})") from None
    doc = _kid(root, "Document") if _local(root.tag) == "kml" else None
    if doc is None:
        raise PlanError(f"{where}: not a KML document (<kml><Document>…)")
    return doc


def _parse(z: zipfile.ZipFile, name: str, path: Path) -> ET.Element:
    where = f"{path.name}, {name}"
    data = read_entry(z, name, MAX_ENTRY_BYTES, PlanError, where, lambda size: (
        f"{where}: {'more than ' if size is None else ''}{(size or MAX_ENTRY_BYTES) / 1e6:.0f} MB unpacked, too large "
        "for a mission file"))
    return _kml_document(data, where)


def _is_dji(doc: ET.Element) -> bool:
    """Whether a KML document has DJI's ``wpml`` elements (any ``http://www.dji.com/wpmz/…`` version)."""
    return any(el.tag.startswith("{http://www.dji.com/wpmz") for el in doc.iter())


def _is_waylines(doc: ET.Element) -> bool:
    """Whether a DJI document is a ``waylines.wpml`` (waylines to execute), not a ``template.kml``."""
    return any(_local(el.tag) in ("waylineId", "executeHeightMode", "executeHeight") for el in doc.iter())


def _sources(path: Path) -> tuple[ET.Element | None, ET.Element | None, str, str]:
    """(template.kml's Document, waylines.wpml's Document, each one's name in messages) of a ``.kmz``, or of a bare
    ``template.kml`` or ``waylines.wpml`` (any DJI KML document: a template unless it holds waylines)."""
    if path.suffix.lower() == ".kmz" or zipfile.is_zipfile(path):
        z = open_zip(path, PlanError, "KMZ")
        with z:
            names = z.namelist()
            waylines = next((n for n in names if n.lower().endswith("wpmz/waylines.wpml")), None)
            template = next((n for n in names if n.lower().endswith("wpmz/template.kml")), None)
            if waylines is None and template is None:
                raise PlanError(f"{path.name}: no wpmz/waylines.wpml or wpmz/template.kml inside: not a DJI WPML mission")
            return (_parse(z, template, path) if template else None, _parse(z, waylines, path) if waylines else None,
                    f"{path.name}, {template}", f"{path.name}, {waylines}")
    try:
        size = path.stat().st_size
        if size > MAX_ENTRY_BYTES:
            raise PlanError(f"{path.name}: {size / 1e6:.0f} MB, too large for a mission file")
        doc = _kml_document(path.read_bytes(), path.name)
    except OSError as exc:
        raise PlanError(f"cannot read {path}: {exc.strerror or exc}") from None
    if not _is_dji(doc):
        raise PlanError(f"{path.name}: a KML document without DJI WPML elements (wpml:…): not a DJI mission; sightplan "
                        "reads a .kml or .wpml only as DJI's template.kml or waylines.wpml")
    if _is_waylines(doc):
        return None, doc, path.name, path.name
    return doc, None, path.name, path.name


def _template_type(doc: ET.Element | None) -> str | None:
    """The template type of a template.kml (``waypoint``, ``mapping2d``, …): its first ``templateType`` (a
    Folder's), else ``"polygon"``/``"line"`` when a Placemark holds an area instead of a Point."""
    folders = _kids(doc, "Folder")
    for el in ([] if doc is None else doc.iter()):
        if _local(el.tag) == "templateType" and el.text and el.text.strip():
            return el.text.strip()
    for folder in folders:
        for pm in _kids(folder, "Placemark"):
            if _kid(pm, "Point") is None:
                if _kid(pm, "Polygon") is not None:
                    return "polygon"
                if _kid(pm, "LineString") is not None:
                    return "line"
    return None


def _refuse_area_template(kind: str, where: str) -> None:
    """A template.kml without waylines that describes an area (or strip), not waypoints: one clear error."""
    if kind in AREA_TEMPLATES:
        what = f"a DJI {kind} ({AREA_TEMPLATES[kind]}) template"
    elif kind in ("polygon", "line"):
        what = f"a DJI area template (a {'Polygon' if kind == 'polygon' else 'LineString'} instead of waypoints)"
    else:
        return
    how = "export the waylines from DJI Pilot 2 (a .kmz with wpmz/waylines.wpml)"
    if kind != "mappingStrip" and kind != "line":
        how += ", or plan it with `sightplan plan lawnmower`" + (" (--oblique-pitch for the oblique passes)"
                                                                  if kind == "mapping3d" else "")
    raise PlanError(f"{where}: {what}: it holds the survey area, not the flight; {how}")


def _undulation(lat: list[float], lon: list[float], warnings: list[str]) -> NDArray:
    """EGM96 geoid undulations at the points (ellipsoidal − sea-level height); zeros, with a warning, without the
    geoid grid."""
    from ..geoid import INSTALL_HINT, GeoidError, undulation

    try:
        return undulation(lat, lon)
    except GeoidError:
        note = f"WGS84 ellipsoidal heights read as heights above sea level, without the geoid: {INSTALL_HINT}"
        if note not in warnings:
            warnings.append(note)
        return np.zeros(len(lat))


def _camera(config: ET.Element | None, camera, where: str, warnings: list[str]) -> Camera:
    payload = _text(_kid(config, "payloadInfo"), "payloadEnumValue")
    drone = _kid(config, "droneInfo")
    key = None
    try:
        key = PAYLOAD_CAMERAS.get(int(payload)) if payload else None
        if key is None and drone is not None:
            key = BUILT_IN_CAMERAS.get((int(_text(drone, "droneEnumValue") or -1), int(_text(drone, "droneSubEnumValue") or 0)))
    except ValueError:
        key = None
    if key is not None:
        cam = get_camera(key)
        if differs(camera, cam):
            warnings.append(f"the mission's payload is the catalogue camera {key!r}: it is used, not the camera given")
        return cam
    if camera is not None:
        return given_camera(camera, where)
    raise PlanError(f"{where}: the mission's payload (payloadEnumValue {payload or 'none'}) is not a camera sightplan "
                    "knows: say which camera took the photos with --camera (camera=, e.g. 'm3e')")


def _waypoints(folder: ET.Element, template: bool, where: str) -> list[_Waypoint]:
    if template:
        mode = _text(_kid(folder, "waylineCoordinateSysParam"), "heightMode") or "relativeToStartPoint"
        global_height = _num(folder, "globalHeight", where)
    else:
        mode = _text(folder, "executeHeightMode") or "relativeToStartPoint"
        global_height = None
    relative = mode not in ABSOLUTE_HEIGHT_MODES
    out = []
    for k, pm in enumerate(_kids(folder, "Placemark")):
        w = f"{where}, Placemark {k + 1}"
        coords = _numbers(_text(_kid(pm, "Point"), "coordinates"), 2, "Point coordinates", w)
        if coords is None:
            raise PlanError(f"{w}: no Point coordinates")
        lon, lat = coords[0], coords[1]
        if not (-90 <= lat <= 90 and -180 <= lon <= 180):
            raise PlanError(f"{w}: latitude {lat} / longitude {lon} out of range (coordinates are 'longitude,latitude')")
        index = _num(pm, "index", w, float(k))
        if template:
            use_global = _text(pm, "useGlobalHeight") == "1"
            height = global_height if use_global else _num(pm, "height", w, global_height)
        else:
            height = _num(pm, "executeHeight", w)
        if height is None:
            raise PlanError(f"{w}: no height ({'height' if template else 'executeHeight'})")
        domain.height(f"{w}: {'height' if template else 'executeHeight'}", height)
        out.append(_Waypoint(int(index), lat, lon, height, relative, pm, w, mode == "WGS84"))
    out.sort(key=lambda wp: wp.index)
    return out


def _heading_param(pm: ET.Element, folder: ET.Element) -> ET.Element | None:
    hp = _kid(pm, "waypointHeadingParam")
    if hp is None or _text(pm, "useGlobalHeadingParam") == "1":
        glob = _kid(folder, "globalWaypointHeadingParam")
        hp = glob if glob is not None else hp
    return hp


def _groups(folder: ET.Element) -> list[ET.Element]:
    groups = [g for pm in _kids(folder, "Placemark") for g in _kids(pm, "actionGroup")]
    return groups + _kids(folder, "actionGroup")


def _flag(el: ET.Element | None, name: str, default: bool = True) -> bool:
    text = _text(el, name)
    return default if text is None else text == "1"


@dataclass
class _Gimbal:
    """The gimbal pitch carried from waypoint to waypoint (None until set) and how often −90° was assumed."""

    pitch: float | None = None
    assumed: int = 0

    def current(self) -> float:
        if self.pitch is None:
            self.assumed += 1
            return DEFAULT_PITCH_DEG
        return self.pitch


def _along(P: NDArray, n: int) -> float | None:
    """Model heading toward the next waypoint (else from the previous one)."""
    if n + 1 < len(P):
        b = bearing(P[n], P[n + 1])
        if b is not None:
            return b
    return bearing(P[n - 1], P[n]) if n > 0 else None


def _arrival_heading(wp: _Waypoint, folder: ET.Element, P: NDArray, n: int, georef: Georeference) -> tuple[
        float | None, float | None]:
    """(true heading, model heading) of the aircraft on reaching waypoint ``n``; one of them is None."""
    hp = _heading_param(wp.pm, folder)
    mode = _text(hp, "waypointHeadingMode") or "followWayline"
    angle = _num(hp, "waypointHeadingAngle", wp.where)
    if mode in ("smoothTransition", "fixed", "manually") and angle is not None:
        return angle % 360.0, None
    if mode == "towardPOI":
        poi = _numbers(_text(hp, "waypointPoiPoint"), 2, "waypointPoiPoint", wp.where)
        if poi is not None and (poi[0] or poi[1]):
            q = georef.from_geodetic(poi[0], poi[1], georef.to_geodetic(P[n])[2])[0]
            b = bearing(P[n], q)
            if b is not None:
                return None, b
    return None, _along(P, n) or 0.0


PHOTO_ACTIONS = ("takePhoto", "orientedShoot", "accurateShoot")


def _takes_photos(folders: list[ET.Element]) -> bool:
    """Whether any action group of the waylines takes a photo."""
    return any(_text(a, "actionActuatorFunc") in PHOTO_ACTIONS for f in folders for g in _groups(f)
               for a in _kids(g, "action"))


def _pitch_mode(template_doc: ET.Element | None, folder: ET.Element, template_id: float | None) -> str | None:
    """The ``gimbalPitchMode`` of a wayline: its own, else its template Folder's (same ``templateId``, else the
    first), else None."""
    mode = _text(folder, "gimbalPitchMode")
    if mode:
        return mode
    folders = _kids(template_doc, "Folder")
    same = [f for f in folders if template_id is not None and _text(f, "templateId") == number_text(template_id)]
    for f in same + folders:
        if _text(f, "gimbalPitchMode"):
            return _text(f, "gimbalPitchMode")
    return None


def _fly_wayline(wayline: int, folder: ET.Element, wps: list[_Waypoint], P: NDArray, georef: Georeference,
                 gimbal: _Gimbal, is_template: bool, where: str, *, shooting: bool = True,
                 pitch_mode: str | None = None) -> list[_Photo]:
    """The photos one wayline takes (see the module docstring); ``shooting``: whether the mission has a photo
    action (without one, a photo at every waypoint); ``pitch_mode``: the wayline's ``gimbalPitchMode``."""
    speed = _num(folder, "autoFlightSpeed", where) or DEFAULT_SPEED_M_S
    reach: dict[int, list[ET.Element]] = {}
    spans: list[dict] = []
    for g in _groups(folder):
        gw = f"{where}, actionGroup {_text(g, 'actionGroupId')}"
        s, e = int(_num(g, "actionGroupStartIndex", gw, 0.0)), int(_num(g, "actionGroupEndIndex", gw, 0.0))
        trig = _kid(g, "actionTrigger")
        kind = _text(trig, "actionTriggerType") or "reachPoint"
        actions = _kids(g, "action")
        if kind == "reachPoint":  # the waypoints the group spans: those the wayline has, whatever its indices say
            for i in sorted({wp.index for wp in wps if s <= wp.index <= max(s, e)}):
                reach.setdefault(i, []).extend(actions)
        elif kind in ("multipleDistance", "multipleTiming"):
            step = _num(trig, "actionTriggerParam", gw)
            if step is None or step <= 0:
                raise PlanError(f"{gw}: a {kind} trigger needs a positive actionTriggerParam")
            if any(_text(a, "actionActuatorFunc") == "takePhoto" for a in actions):
                spans.append({"start": s, "end": e, "step": step * (speed if kind == "multipleTiming" else 1.0),
                              "travelled": 0.0, "next": 0.0})
    photos: list[_Photo] = []
    for n, wp in enumerate(wps):
        heading_true, heading_model = _arrival_heading(wp, folder, P, n, georef)
        gp = _num(_kid(wp.pm, "waypointGimbalHeadingParam"), "waypointGimbalPitchAngle", wp.where)
        if gp is None and is_template:
            gp = _num(wp.pm, "gimbalPitchAngle", wp.where)
        per_point = pitch_mode == "usePointSetting" or (pitch_mode is None and not shooting)
        if gp is not None and pitch_mode != "manual" and (per_point or gimbal.pitch is None):
            gimbal.pitch = gp  # the waypoint's own pitch (usePointSetting), else the first as the one to start with
        gimbal_abs: float | None = None
        gimbal_rel = 0.0
        count = 0
        for action in reach.get(wp.index, []):
            func = _text(action, "actionActuatorFunc")
            prm = _kid(action, "actionActuatorFuncParam")
            aw = f"{wp.where}, action {_text(action, 'actionId')} ({func})"
            if func == "rotateYaw":
                h = _num(prm, "aircraftHeading", aw)
                if h is not None:
                    heading_true, heading_model = h % 360.0, None
            elif func == "gimbalRotate":
                if _flag(prm, "gimbalPitchRotateEnable"):
                    p = _num(prm, "gimbalPitchRotateAngle", aw)
                    gimbal.pitch = p if p is not None else gimbal.pitch
                if _flag(prm, "gimbalYawRotateEnable", False):
                    y = _num(prm, "gimbalYawRotateAngle", aw, 0.0) or 0.0
                    if (_text(prm, "gimbalRotateMode") or "absoluteAngle") == "absoluteAngle":
                        gimbal_abs = y % 360.0
                    else:
                        gimbal_rel = y
            elif func in ("takePhoto", "orientedShoot", "accurateShoot"):
                count += 1
                if func == "takePhoto":
                    h_true = gimbal_abs if gimbal_abs is not None else (
                        None if heading_true is None else (heading_true + gimbal_rel) % 360.0)
                    p = gimbal.current()
                else:
                    h = _num(prm, "aircraftHeading", aw)
                    h_true = (h % 360.0) if h is not None else heading_true
                    p = _num(prm, "gimbalPitchRotateAngle", aw)
                    p = gimbal.current() if p is None else p
                h_model = None if h_true is not None else ((heading_model or 0.0) + gimbal_rel) % 360.0
                suffix = _text(prm, "fileSuffix")
                photos.append(_Photo(wayline, P[n], h_true, h_model, float(np.clip(p, -90, 90)),
                                     suffix or f"w{wayline}_wp{wp.index:03d}_{count}"))
        if not shooting:  # no photo action in the mission: a photo at every waypoint, as it arrives and turns
            h_true = gimbal_abs if gimbal_abs is not None else (
                None if heading_true is None else (heading_true + gimbal_rel) % 360.0)
            h_model = None if h_true is not None else ((heading_model or 0.0) + gimbal_rel) % 360.0
            photos.append(_Photo(wayline, P[n], h_true, h_model, float(np.clip(gimbal.current(), -90, 90)),
                                 f"w{wayline}_wp{wp.index:03d}"))
        if n + 1 < len(wps):  # the leg to the next waypoint: photos of the distance or time triggers over it
            leg = P[n + 1] - P[n]
            length = float(np.linalg.norm(leg))
            for span in spans:
                if not (span["start"] <= wp.index and wps[n + 1].index <= span["end"]) or length == 0:
                    continue
                ahead = ((span["travelled"] + length + 1e-3 - span["next"]) / span["step"] + 1 if span["step"] > 0
                         else math.inf)
                domain.check_work(len(photos) + max(ahead, 0.0), domain.MAX_MISSION_PHOTOS,
                                  f"{where}: a photo every {span['step']:g} m", "the actionTriggerParam", "photos")
                while span["next"] <= span["travelled"] + length + 1e-3:  # within 1 mm of the leg's end: at its end
                    s_leg = span["next"] - span["travelled"]
                    photos.append(_Photo(wayline, P[n] + s_leg / length * leg, None, bearing(P[n], P[n + 1]) or 0.0,
                                         gimbal.current(), f"w{wayline}_wp{wp.index:03d}_d{len(photos) + 1}"))
                    span["next"] += span["step"]
                span["travelled"] += length
    return photos


def _reference(ref_text: str | None, where: str, warnings: list[str], ground_z: float | None
               ) -> tuple[float, float, float | None] | None:
    """The take-off reference point ``takeOffRefPoint`` "lat,lon,h" as (latitude, longitude, height above sea level
    or None), or None where the file gives none (or "0,0"). DJI's height is WGS84 ellipsoidal: it becomes a
    sea-level height with the EGM96 geoid; without the geoid grid, the height is dropped for the model's ground
    ``ground_z`` when there is one, else read as it is (each with a warning)."""
    from ..geoid import INSTALL_HINT, GeoidError, undulation

    ref = _numbers(ref_text, 2, "takeOffRefPoint", where)
    if ref is None or (ref[0] == 0 and ref[1] == 0):
        return None
    lat, lon = ref[0], ref[1]
    if not (-90 <= lat <= 90 and -180 <= lon <= 180):
        raise PlanError(f"{where}: takeOffRefPoint latitude {lat} / longitude {lon} out of range (it is 'latitude,"
                        "longitude,height')")
    h = ref[2] if len(ref) > 2 and math.isfinite(ref[2]) else None
    if h is None:
        warnings.append("the take-off reference point (takeOffRefPoint) has no height")
        return lat, lon, None
    try:
        return lat, lon, float(h - undulation([lat], [lon])[0])
    except GeoidError:
        if ground_z is not None:
            warnings.append("the take-off reference height (takeOffRefPoint) is WGS84 ellipsoidal and the geoid is "
                            f"missing: heights above take-off start from the model's ground; {INSTALL_HINT}")
            return lat, lon, None
        warnings.append(f"WGS84 ellipsoidal heights read as heights above sea level, without the geoid: {INSTALL_HINT}")
        return lat, lon, float(h)


def read_wpml(path: str | Path, georef: Georeference | None = None, camera: Camera | str | dict | None = None,
              ground_z: float | None = None, takeoff_z: float | None = None) -> Plan:
    """A plan from a DJI WPML mission: a ``.kmz``, or a bare ``template.kml`` or ``waylines.wpml``; see the module
    docstring (``ground_z``, ``takeoff_z``: see :func:`~sightplan.plan.load.load_plan`)."""
    path = Path(path)
    template_doc, waylines_doc, template_name, waylines_name = _sources(path)
    is_template = waylines_doc is None
    doc = template_doc if is_template else waylines_doc
    assert doc is not None
    template_type = _template_type(template_doc)
    if is_template and template_type is not None:
        _refuse_area_template(template_type, template_name)
    where = template_name if is_template else waylines_name
    warnings: list[str] = []
    config = _kid(doc, "missionConfig")
    ref_text = _text(config, "takeOffRefPoint") or _text(_kid(template_doc, "missionConfig"), "takeOffRefPoint")
    folders = [(f, _waypoints(f, is_template, f"{where}, Folder {k + 1}")) for k, f in enumerate(_kids(doc, "Folder"))]
    folders = [(f, wps) for f, wps in folders if wps]
    if not folders:
        raise PlanError(f"{where}: no wayline (Folder) with waypoints (Placemark)")
    first = folders[0][1][0]
    any_relative = any(wp.relative for _, wps in folders for wp in wps)
    ref = _reference(ref_text, where, warnings, ground_z if any_relative else None)
    if ref is None:
        t_lat, t_lon, t_h = first.lat, first.lon, None
        if any_relative and takeoff_z is None:
            warnings.append("the mission has no take-off reference point (takeOffRefPoint): heights above the start "
                            f"point start from {'the model ground' if ground_z is not None else 'height 0'} under the "
                            "first waypoint")
    else:
        t_lat, t_lon, t_h = ref
    model = georef is not None
    try:
        if georef is None:
            georef = Georeference.from_origin(t_lat, t_lon, t_h or 0.0, 0.0, source=f"take-off point of {path.name}")
        takeoff = place_takeoff(georef, t_lat, t_lon, t_h, model=model, ground_z=ground_z, takeoff_z=takeoff_z,
                                what="take-off reference point (takeOffRefPoint)", warnings=warnings)
        t_h = takeoff.height_m
        all_wps = [wp for _, wps in folders for wp in wps]
        absolute = np.array([w.height for w in all_wps], float)
        ell = np.array([w.ellipsoidal for w in all_wps])
        if ell.any():
            absolute[ell] -= _undulation([w.lat for w in all_wps if w.ellipsoidal],
                                         [w.lon for w in all_wps if w.ellipsoidal], warnings)
        xyz_all = georef.from_geodetic([w.lat for w in all_wps], [w.lon for w in all_wps],
                                       [t_h + w.height if w.relative else a for w, a in zip(all_wps, absolute)])
    except GeoreferenceError as exc:
        raise PlanError(f"{where}: {exc}") from None
    cam = _camera(config if config is not None else _kid(template_doc, "missionConfig"), camera, where, warnings)

    photos: list[_Photo] = []
    missions: list[tuple[str, int, int]] = []
    waypoints_xyz: list[NDArray] = []
    gimbal = _Gimbal()
    shooting = _takes_photos([f for f, _ in folders])
    if not shooting:
        warnings.append("the mission has no photo action (takePhoto, orientedShoot, accurateShoot): a frame is made "
                        "at every waypoint, with its heading and gimbal pitch")
    n_wp = 0
    for k, (folder, wps) in enumerate(folders):
        wayline = int(_num(folder, "waylineId", where, _num(folder, "templateId", where, float(k))) or 0)
        P = xyz_all[n_wp:n_wp + len(wps)]
        n_wp += len(wps)
        waypoints_xyz.extend(P)
        start = len(photos)
        mode = _pitch_mode(template_doc, folder, _num(folder, "templateId", where))
        photos.extend(_fly_wayline(wayline, folder, wps, P, georef, gimbal, is_template, where, shooting=shooting,
                                   pitch_mode=mode))
        if len(photos) > start:
            missions.append((f"wayline {wayline}", start, len(photos)))
    if not photos:
        raise PlanError(f"{where}: the mission takes no photo (no takePhoto action)")
    if gimbal.assumed:
        warnings.append(f"no gimbal pitch before {gimbal.assumed} photo(s): {DEFAULT_PITCH_DEG:g}° (nadir) assumed")
    C = np.array([p.position for p in photos])
    heading = np.array([p.heading_model if p.heading_true is None else np.nan for p in photos], float)
    fixed = np.flatnonzero(np.isnan(heading))
    if len(fixed):
        heading[fixed] = georef.model_heading(C[fixed], [photos[i].heading_true for i in fixed])
    names = [p.name for p in photos]
    seen: dict[str, int] = {}
    for i, name in enumerate(names):
        seen[name] = seen.get(name, 0) + 1
        if seen[name] > 1:
            names[i] = f"{name}_{seen[name]}"
    R = R_from_gimbal(heading, [p.pitch for p in photos], 0.0)
    cid = cam.name or "camera"
    source = {"format": "wpml", "path": str(path)}
    if template_type is not None:
        source["template_type"] = template_type
    params = {"source": source, "georeference": georef.to_dict(), "takeoff_m": [float(v) for v in takeoff.xyz],
              "home": takeoff.to_dict(), "warnings": warnings}
    return Plan.build({cid: cam}, R, C, frame_names=[re.sub(r"\s+", "_", n) for n in names],
                      missions=tuple(Mission(*m) for m in missions), waypoints=np.array(waypoints_xyz).reshape(-1, 3),
                      parameters=params)


def _read(source: Source, options: ReadOptions) -> Plan:
    return read_wpml(source.path, georef=options.georef, camera=options.camera, ground_z=options.ground_z,
                     takeoff_z=options.takeoff_z)


# ---- writing -----------------------------------------------------------------------------------

HEIGHT_RANGE_M = (2.0, 1500.0)  # takeOffSecurityHeight (DJI: 1.2 with a remote controller) and globalRTHHeight
RTH_MARGIN_M = 10.0
HEADING_TOLERANCE_DEG = 0.001
GIMBAL_SETTLE_S = 0.5  # a hover action between a gimbal turn and its photo (the replay's Gimbal.settle_s)


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
    path = flight.path_of(flight.waypoints[0].mission)
    _el(cfg, "wpml:takeOffSecurityHeight", number_text(_clip(max(altitudes[0], path[0] if path else -np.inf),
                                                              HEIGHT_RANGE_M), 4))
    if template:
        lat, lon, h = flight.takeoff_latitude_deg, flight.takeoff_longitude_deg, flight.takeoff_height_m
        ellipsoidal = float(to_ellipsoidal(lat, lon, h)[0])
        _el(cfg, "wpml:takeOffRefPoint", f"{lat:.9f},{lon:.9f},{ellipsoidal:.4f}")
        _el(cfg, "wpml:takeOffRefPointAGLHeight", 0)  # the take-off point is on the ground
    _el(cfg, "wpml:globalTransitionalSpeed", flight.speed_m_s)
    # the return height the checks passed (:mod:`sightplan.plan.trajectory`); without one, the highest waypoint's plus
    # a margin: DJI's return-to-home climbs to it at the last waypoint, flies home straight and lands
    rth = max(path[1], altitudes[-1]) if path else max(altitudes) + RTH_MARGIN_M
    _el(cfg, "wpml:globalRTHHeight", number_text(_clip(rth, HEIGHT_RANGE_M), 4))
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


def _write_heading_param(parent: ET.Element, tag: str, heading: float | None) -> None:
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
               template: bool, pitch: float | None = None, settle_s: float = GIMBAL_SETTLE_S) -> float | None:
    """One waypoint with its actions; ``pitch``: the gimbal's pitch before it (None: unknown); returns the pitch
    after it."""
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
    _write_heading_param(pm, "wpml:waypointHeadingParam", heading)
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
        action_id += 1
        if photo.pitch_deg != pitch:  # the actions run in sequence: the gimbal turns, then settles, then the shot
            _action(group, action_id, "hover", [("hoverTime", number_text(settle_s, 3))])
            action_id += 1
            pitch = photo.pitch_deg
        _action(group, action_id, "takePhoto", [("payloadPositionIndex", 0), ("fileSuffix", _suffix(photo.name)),
                                                ("payloadLensIndex", aircraft.image_format),
                                                ("useGlobalPayloadLensIndex", 0)])
        action_id += 1
    return pitch


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
    _write_heading_param(folder, "wpml:globalWaypointHeadingParam", None)
    _el(folder, "wpml:globalWaypointTurnMode", "toPointAndStopWithDiscontinuityCurvature")
    _el(folder, "wpml:globalUseStraightLine", 1)
    _el(folder, "wpml:globalHeight", number_text(wps[0].altitude_m, 4))
    return folder


def _document(flight: Flight, aircraft: DjiAircraft, template: bool, settle_s: float = GIMBAL_SETTLE_S) -> bytes:
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
        pitch: float | None = None
        for index, wp in enumerate(wps):
            pitch = _placemark(folder, flight, aircraft, wp, index, group_id, template, pitch, settle_s)
            group_id += 1
    ET.indent(root, space="  ")
    return ET.tostring(root, encoding="utf-8", xml_declaration=True)


def write_wpml(flight: Flight, path: Path, aircraft: DjiAircraft | str | None = None,
               settle_s: float = GIMBAL_SETTLE_S) -> list[Path]:
    """Write ``flight`` (every mission a wayline; :func:`~sightplan.export.export_plan` gives each mission its own file)
    for ``aircraft`` (a :class:`DjiAircraft`, a key of :data:`AIRCRAFT`, or None: the plan camera's)."""
    if not isinstance(aircraft, DjiAircraft):
        aircraft = resolve_aircraft(flight.plan, aircraft)[0]
    check_speed(aircraft, flight.speed_m_s)
    template = _document(flight, aircraft, template=True, settle_s=settle_s)
    waylines = _document(flight, aircraft, template=False, settle_s=settle_s)
    with zipfile.ZipFile(path, "w", compression=zipfile.ZIP_DEFLATED) as z:
        z.writestr("wpmz/template.kml", template)
        z.writestr("wpmz/waylines.wpml", waylines)
    return [path]


def _prepare(plan: Plan, aircraft: str | None, speed_m_s: float) -> Target:
    dji, note = resolve_aircraft(plan, aircraft)
    check_speed(dji, speed_m_s)
    return Target(aircraft=dji.name, vehicle=dji, pitch_range=dji.pitch_range, note=note)


def _write(flight: Flight, path: Path, target: Target) -> list[Path]:
    return write_wpml(flight, path, target.vehicle,
                      GIMBAL_SETTLE_S if target.gimbal is None else target.gimbal.settle_s)


FORMAT = FlightFormat(name="wpml", label="DJI WPML", order=30, read=_read, suffixes=(".kmz", ".kml", ".wpml"),
                      uses_camera=True,
                      write=_write, suffix=".kmz", media_type="application/vnd.google-earth.kmz", prepare=_prepare,
                      aircraft_choice=True, per_mission=True, pitch_range=(-90.0, 30.0), help="DJI Pilot 2 .kmz",
                      settings=("heights are above the actual take-off point (relativeToStartPoint)",))
