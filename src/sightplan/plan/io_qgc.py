"""Import MAVLink missions: QGroundControl ``.plan`` files and ``QGC WPL 110`` waypoint files.

The mission's commands are flown in order and a frame is made wherever a photo is taken:

- positions: ``NAV_WAYPOINT`` (16) and the other positional NAV commands (loiters 17/18/19/31,
  spline 82); ``NAV_TAKEOFF`` (22) moves the aircraft but makes no frame; ``NAV_RETURN_TO_LAUNCH``
  (20) and ``NAV_LAND`` (21) end the flight. Heights by MAVLink frame: 0/5 absolute (used as the
  georeference's heights), 3/6 above the home position, 10/11 (above terrain) taken as above home
  with a warning. A QGroundControl plan's home is its ``plannedHomePosition``; a WPL file's is line 0.
- photos: ``IMAGE_START_CAPTURE`` (2000: one image, or a time-lapse of param3 images every param2 s,
  placed every speed × interval metres), ``DO_DIGICAM_CONTROL`` (203 with param5 = 1) and
  ``DO_SET_CAM_TRIGG_DIST`` (206: a frame every param1 metres along the legs flown until it is set to
  0; param3 = 1 adds one at once). A photo command before any position is an error. A mission without
  any photo command has a frame at every waypoint (and says so in ``plan.parameters["warnings"]``).
- heading: the waypoint's yaw (param4, a true heading; NaN: along the flight direction, i.e. toward
  the next position), changed by ``CONDITION_YAW`` (115), pointed by ``DO_SET_ROI_WPNEXT_OFFSET`` (196:
  toward the next waypoint plus a yaw offset) or a region of interest (195, 201), plus a gimbal yaw.
  Both forms of :mod:`sightplan.export.qgc` read back this way: PX4's waypoints repeated in place, one
  per heading, and ArduPilot's ``CONDITION_YAW`` after each waypoint; consecutive waypoints within
  1 cm count as one in the plan's waypoints.
- gimbal pitch: from the last ``DO_MOUNT_CONTROL`` (205, param1) or ``DO_GIMBAL_MANAGER_PITCHYAW``
  (1000, param1); inside Survey and CorridorScan items, and wherever none was given, −90 (nadir; a
  warning says where it was assumed outside a survey).

QGroundControl complex items: Survey and CorridorScan are read from their expanded
``TransectStyleComplexItem.Items`` (or ``Items``); a StructureScan (which QGroundControl saves
without items) is expanded as QGroundControl does: its polygon, made clockwise, offset outward by the
camera's distance to the surface; ``Layers`` loops around it at heights from ``StructureHeight`` (or
``ScanBottomAlt``) in steps of the frontal footprint, each triggering a photo every side footprint
metres, the camera ``GimbalPitch`` and 90° right of the direction of flight, toward the structure.

Positions go to the model frame with ``georef.from_geodetic``; without a georeference the frame is a
topocentric one at the home position (model +Y north), stored in ``plan.parameters["georeference"]``
with the home point as ``plan.parameters["takeoff_m"]`` so that exports round-trip. The camera is the
one the plan's camera settings name when the catalogue knows it (or a QGroundControl custom camera's
sensor and lens), else ``camera``. A plan written by :mod:`sightplan.export.qgc` carries a
``sightplan`` block (ignored by QGroundControl): its frame names, cameras and georeference are used
(a georeference given wins).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np
from numpy.typing import NDArray

from ..camera.catalogue import get_camera
from ..camera.files import parse_camera_spec
from ..camera.models import Camera, PinholeCamera, camera_from_dict
from ..errors import CameraError, PlanError
from ..formats.mavlink import (
    CONDITION_YAW,
    DO_CHANGE_SPEED,
    DO_DIGICAM_CONTROL,
    DO_GIMBAL_MANAGER_PITCHYAW,
    DO_JUMP,
    DO_MOUNT_CONTROL,
    DO_SET_CAM_TRIGG_DIST,
    DO_SET_ROI,
    DO_SET_ROI_LOCATION,
    DO_SET_ROI_NONE,
    DO_SET_ROI_WPNEXT_OFFSET,
    IMAGE_START_CAPTURE,
    IMAGE_STOP_CAPTURE,
    NAV_LAND,
    NAV_LOITER_TIME,
    NAV_LOITER_TO_ALT,
    NAV_LOITER_TURNS,
    NAV_LOITER_UNLIM,
    NAV_RETURN_TO_LAUNCH,
    NAV_SPLINE_WAYPOINT,
    NAV_TAKEOFF,
    NAV_WAYPOINT,
)
from ..geo import Georeference, GeoreferenceError
from ..geometry.poses import R_from_gimbal
from .format import read_json
from .types import Mission, Plan

WAYPOINTS = {NAV_WAYPOINT, NAV_LOITER_UNLIM, NAV_LOITER_TURNS, NAV_LOITER_TIME, NAV_LOITER_TO_ALT, NAV_SPLINE_WAYPOINT}
POSITIONAL = WAYPOINTS | {NAV_TAKEOFF, NAV_LAND, NAV_RETURN_TO_LAUNCH}
ABSOLUTE_FRAMES, RELATIVE_FRAMES, TERRAIN_FRAMES = {0, 5}, {3, 6}, {10, 11}
GIMBAL_YAW_LOCK = 16
DEFAULT_PITCH_DEG = -90.0
DEFAULT_SPEED_M_S = 5.0
SAME_WAYPOINT_M = 0.01
MANUAL_CAMERAS = {"", "manual (no camera specs)", "custom camera", "manual"}


@dataclass
class Command:
    """One MAVLink mission item: params are 7 floats (NaN where the file has null)."""

    command: int
    frame: int
    params: tuple[float, ...]
    where: str
    ident: int
    survey: bool = False


@dataclass
class MissionSource:
    """A parsed mission file: its commands, home (lat, lon, absolute height), speed and camera settings."""

    path: Path
    commands: list[Command]
    home: tuple[float, float, float] | None
    speed_m_s: float = DEFAULT_SPEED_M_S
    camera_settings: dict = field(default_factory=dict)
    prefix: str = "item"
    fmt: str = "qgc"
    warnings: list[str] = field(default_factory=list)
    sightplan: dict = field(default_factory=dict)


def differs(camera: Camera | str | dict | None, cam: Camera) -> bool:
    """Whether a camera argument was given and names another camera than ``cam``."""
    if camera is None:
        return False
    try:
        return parse_camera_spec(camera) != cam
    except CameraError:
        return True


def _float(value: Any, where: str) -> float:
    if value is None:
        return math.nan
    if isinstance(value, bool) or not isinstance(value, (int, float)):
        raise PlanError(f"{where}: {value!r} is not a number")
    return float(value)


# ---- QGroundControl .plan ----------------------------------------------------------------------


def _simple(item: Any, where: str, ident: int, survey: bool) -> Command:
    if not isinstance(item, dict):
        raise PlanError(f"{where}: a mission item must be an object")
    try:
        command, params = item["command"], item["params"]
    except KeyError as exc:
        raise PlanError(f"{where}: the SimpleItem lacks {exc.args[0]!r}") from None
    if not isinstance(params, list) or len(params) != 7:
        raise PlanError(f"{where}: 'params' must be a list of 7 values")
    frame = item.get("frame", 2)
    if not isinstance(command, int) or not isinstance(frame, int):
        raise PlanError(f"{where}: 'command' and 'frame' must be integers")
    return Command(command, frame, tuple(_float(p, f"{where}, params[{k}]") for k, p in enumerate(params)), where,
                   int(item.get("doJumpId", ident)) if isinstance(item.get("doJumpId"), int) else ident, survey)


def _need(d: dict, key: str, where: str) -> float:
    if key not in d:
        raise PlanError(f"{where}: lacks {key!r}")
    v = _float(d[key], f"{where}, {key!r}")
    if not math.isfinite(v):
        raise PlanError(f"{where}: {key!r} is not a finite number")
    return v


def _clockwise_offset(xy: NDArray, distance: float) -> NDArray:
    """The clockwise polygon ``xy`` (east, north) with every edge moved ``distance`` outward (mitred corners)."""
    n = len(xy)
    e = np.roll(xy, -1, axis=0) - xy
    e /= np.linalg.norm(e, axis=1)[:, None]
    normal = np.stack([-e[:, 1], e[:, 0]], axis=1)  # left of travel: outside for a clockwise polygon
    out = np.zeros_like(xy)
    for i in range(n):
        j = i - 1
        a, b = xy[j] + distance * normal[j], xy[i] + distance * normal[i]
        cross = e[j, 0] * e[i, 1] - e[j, 1] * e[i, 0]
        if abs(cross) < 1e-12:
            out[i] = b
            continue
        d = b - a
        s = (d[0] * e[i, 1] - d[1] * e[i, 0]) / cross
        out[i] = a + s * e[j]
    return out


def _structure_scan(item: dict, where: str, ident: int) -> tuple[list[Command], dict]:
    """The items QGroundControl flies for a StructureScan complex item (see the module docstring)."""
    cc = item.get("CameraCalc")
    if not isinstance(cc, dict):
        raise PlanError(f"{where}: the StructureScan lacks 'CameraCalc'")
    poly = item.get("polygon")
    if not (isinstance(poly, list) and len(poly) >= 3 and all(isinstance(p, list) and len(p) >= 2 for p in poly)):
        raise PlanError(f"{where}: the StructureScan's 'polygon' must hold at least 3 [latitude, longitude] points")
    ll = np.array([[_float(p[0], where), _float(p[1], where)] for p in poly])
    if not np.isfinite(ll).all():
        raise PlanError(f"{where}: the StructureScan's polygon has a coordinate that is not a finite number")
    entrance, bottom, top = (_need(item, k, where) for k in ("EntranceAltitude", "ScanBottomAlt", "StructureHeight"))
    layers, pitch = int(_need(item, "Layers", where)), _need(item, "GimbalPitch", where)
    distance, frontal, side = (_need(cc, k, f"{where}, CameraCalc")
                               for k in ("DistanceToSurface", "AdjustedFootprintFrontal", "AdjustedFootprintSide"))
    if frontal <= 0 or side <= 0 or layers < 1:
        raise PlanError(f"{where}: the StructureScan needs positive footprints and at least one layer")
    local = Georeference.from_origin(ll[0, 0], ll[0, 1], 0.0)
    xy = local.from_geodetic(ll[:, 0], ll[:, 1], np.zeros(len(ll)))[:, :2]
    x, y = xy[:, 0], xy[:, 1]
    if np.sum(x * np.roll(y, -1) - np.roll(x, -1) * y) > 0:  # counter-clockwise: fly it the other way round
        xy = np.vstack([xy[:1], xy[:0:-1]])
    flight = _clockwise_offset(xy, distance)
    lat, lon, _ = local.to_geodetic(np.column_stack([flight, np.zeros(len(flight))]))
    nan = math.nan
    cmds: list[Command] = []
    k = 0

    def add(command: int, frame: int, params: list[float]) -> None:
        nonlocal k
        k += 1
        cmds.append(Command(command, frame, tuple(float(p) for p in params), f"{where}, generated item {k}", ident, True))

    add(NAV_WAYPOINT, 3, [0, 0, 0, nan, lat[0], lon[0], entrance])
    add(DO_SET_ROI_WPNEXT_OFFSET, 2, [0, 0, 0, 0, pitch, 0, 90])
    half = frontal / 2
    altitude = top - half if item.get("StartFromTop", True) else bottom + half
    step = -frontal if item.get("StartFromTop", True) else frontal
    order = list(range(len(flight))) + [0]
    for _ in range(layers):
        for n, v in enumerate(order):
            add(NAV_WAYPOINT, 3, [0, 0, 0, nan, lat[v], lon[v], altitude])
            if n == 0:
                add(DO_SET_CAM_TRIGG_DIST, 2, [side, 0, 1, 0, 0, 0, 0])
        add(DO_SET_CAM_TRIGG_DIST, 2, [0, 0, 0, 0, 0, 0, 0])
        altitude += step
    add(DO_SET_ROI_NONE, 2, [0] * 7)
    add(NAV_WAYPOINT, 3, [0, 0, 0, nan, lat[0], lon[0], entrance])
    return cmds, cc


def _complex(item: dict, where: str, ident: int) -> tuple[list[Command], dict]:
    kind = str(item.get("complexItemType", ""))
    if kind.lower() == "structurescan":
        return _structure_scan(item, where, ident)
    if kind.lower() not in ("survey", "corridorscan"):
        raise PlanError(f"{where}: unsupported complex item {kind!r} (Survey, CorridorScan and StructureScan are read)")
    tsi = item.get("TransectStyleComplexItem") if isinstance(item.get("TransectStyleComplexItem"), dict) else item
    sub = tsi.get("Items")
    if not isinstance(sub, list):
        raise PlanError(f"{where}: the {kind} item has no expanded 'Items'; save the plan again with QGroundControl 4 or later")
    cmds = [_simple(s, f"{where}, {kind} item {k + 1}", ident, True) for k, s in enumerate(sub)]
    cc = tsi.get("CameraCalc") if isinstance(tsi.get("CameraCalc"), dict) else {}
    return cmds, cc


def parse_qgc_plan(path: Path) -> MissionSource:
    """The commands of a QGroundControl ``.plan`` file, complex items expanded."""
    data = read_json(path)
    if not isinstance(data, dict) or data.get("fileType") != "Plan":
        raise PlanError(f"{path.name} is not a QGroundControl plan (expected \"fileType\": \"Plan\")")
    mission = data.get("mission")
    if not isinstance(mission, dict) or not isinstance(mission.get("items"), list):
        raise PlanError(f"{path.name}: the plan has no 'mission' with a list of 'items'")
    home_raw = mission.get("plannedHomePosition")
    if not (isinstance(home_raw, list) and len(home_raw) >= 3):
        raise PlanError(f"{path.name}: 'plannedHomePosition' must be [latitude, longitude, altitude]")
    home = tuple(_float(v, f"{path.name}, plannedHomePosition") for v in home_raw[:3])
    if not all(math.isfinite(v) for v in home):
        raise PlanError(f"{path.name}: 'plannedHomePosition' is not three finite numbers")
    src = MissionSource(path, [], home if any(home[:2]) else None)
    if isinstance(data.get("sightplan"), dict):
        src.sightplan = data["sightplan"]
    speed = mission.get("hoverSpeed") if mission.get("vehicleType", 2) not in (1,) else mission.get("cruiseSpeed")
    for candidate in (speed, mission.get("cruiseSpeed")):
        if isinstance(candidate, (int, float)) and not isinstance(candidate, bool) and candidate > 0:
            src.speed_m_s = float(candidate)
            break
    for k, item in enumerate(mission["items"]):
        where = f"{path.name}, mission item {k + 1}"
        if not isinstance(item, dict):
            raise PlanError(f"{where}: a mission item must be an object")
        kind = item.get("type")
        if kind == "SimpleItem":
            src.commands.append(_simple(item, where, k + 1, False))
        elif kind == "ComplexItem":
            cmds, cc = _complex(item, where, k + 1)
            src.commands.extend(cmds)
            if cc and not src.camera_settings:
                src.camera_settings = cc
        else:
            raise PlanError(f"{where}: unknown item type {kind!r} (expected 'SimpleItem' or 'ComplexItem')")
    return src


# ---- QGC WPL 110 -------------------------------------------------------------------------------


def sniff_wpl(path: Path) -> bool:
    """Whether ``path`` is a text file starting with the ``QGC WPL`` header."""
    try:
        with path.open("rb") as f:
            head = f.read(64)
    except OSError:
        return False
    return head.lstrip(b"\xef\xbb\xbf").startswith(b"QGC WPL")


def parse_wpl(path: Path) -> MissionSource:
    """The commands of a ``QGC WPL 110`` file; line 0 is the home position."""
    try:
        lines = path.read_text(encoding="utf-8-sig").splitlines()
    except OSError as exc:
        raise PlanError(f"cannot read {path}: {exc.strerror or exc}") from None
    except UnicodeDecodeError:
        raise PlanError(f"{path.name} is not a text file") from None
    if not lines or lines[0].strip() != "QGC WPL 110":
        first = lines[0].strip()[:40] if lines else ""
        raise PlanError(f"{path.name} is not a QGC WPL 110 waypoint file (first line {first!r})")
    src = MissionSource(path, [], None, prefix="seq", fmt="wpl")
    for n, line in enumerate(lines[1:], start=2):
        if not line.strip() or line.lstrip().startswith("#"):
            continue
        where = f"{path.name}, line {n}"
        cells = line.split()
        if len(cells) != 12:
            raise PlanError(f"{where}: expected 12 values (seq current frame command p1 p2 p3 p4 lat lon alt "
                            f"autocontinue), got {len(cells)}")
        try:
            seq, _current, frame, command = (int(c) for c in cells[:4])
            params = tuple(float(c) for c in cells[4:11])
        except ValueError:
            raise PlanError(f"{where}: {line.strip()[:60]!r} has a value that is not a number") from None
        if seq == 0 and src.home is None and not src.commands:
            if not all(math.isfinite(v) for v in params[4:7]):
                raise PlanError(f"{where}: the home position is not finite")
            src.home = (params[4], params[5], params[6]) if any(params[4:6]) else None
            continue
        src.commands.append(Command(command, frame, params, where, seq))
    return src


# ---- flying the commands -----------------------------------------------------------------------


def bearing(a: NDArray, b: NDArray) -> float | None:
    """Model heading (clockwise from +Y, [0, 360)) from point ``a`` toward ``b``; None when they are
    less than a micrometre apart horizontally."""
    d = b[:2] - a[:2]
    if math.hypot(*d) < 1e-6:
        return None
    return math.degrees(math.atan2(d[0], d[1])) % 360.0


@dataclass
class _Frame:
    position: NDArray
    heading: float  # model heading
    pitch: float
    name: str


def _positions(src: MissionSource, georef: Georeference, home: tuple[float, float, float]) -> dict[int, NDArray]:
    """Model-frame position of every positional command and region of interest, by command index."""
    lat_h, lon_h, h_home = home
    geo: dict[int, tuple[float, float, float]] = {}
    cur = (lat_h, lon_h, h_home)
    terrain = False
    for k, c in enumerate(src.commands):
        roi = c.command == DO_SET_ROI_LOCATION or (c.command == DO_SET_ROI and c.params[0] == 3)
        if c.command not in POSITIONAL and not roi:
            continue
        lat, lon, alt = c.params[4:7]
        if c.command == NAV_RETURN_TO_LAUNCH:
            geo[k] = (lat_h, lon_h, cur[2])
            continue
        if c.command in (NAV_TAKEOFF, NAV_LAND) and (not math.isfinite(lat) or not math.isfinite(lon) or (lat == 0 and lon == 0)):
            lat, lon = (lat_h, lon_h) if c.command == NAV_TAKEOFF else cur[:2]
        name = {NAV_WAYPOINT: "NAV_WAYPOINT", NAV_TAKEOFF: "NAV_TAKEOFF", NAV_LAND: "NAV_LAND"}.get(c.command,
                                                                                                 f"command {c.command}")
        for label, v in (("latitude", lat), ("longitude", lon)):
            if not math.isfinite(v):
                raise PlanError(f"{c.where}: {name} {label} is not a finite number")
        if not (-90 <= lat <= 90 and -180 <= lon <= 360):
            raise PlanError(f"{c.where}: {name} latitude {lat} / longitude {lon} out of range")
        if not math.isfinite(alt):
            if c.command == NAV_LAND:
                alt, frame = 0.0, 3
            else:
                raise PlanError(f"{c.where}: {name} altitude is not a finite number")
        else:
            frame = c.frame
        if frame in ABSOLUTE_FRAMES:
            h = alt
        elif frame in RELATIVE_FRAMES or frame in TERRAIN_FRAMES:
            h = h_home + alt
            terrain |= frame in TERRAIN_FRAMES
        else:
            raise PlanError(f"{c.where}: {name} uses MAVLink frame {frame}; global frames are read (0/5 absolute, "
                            "3/6 above home, 10/11 above terrain)")
        geo[k] = (lat, lon, h)
        if not roi:
            cur = geo[k]
    if terrain:
        src.warnings.append("heights above terrain (MAVLink frame 10/11) read as heights above the home position")
    if not geo:
        return {}
    keys = list(geo)
    arr = np.array([geo[k] for k in keys])
    try:
        xyz = georef.from_geodetic(arr[:, 0], arr[:, 1], arr[:, 2])
    except GeoreferenceError as exc:
        raise PlanError(f"{src.path.name}: {exc}") from None
    return {k: xyz[n] for n, k in enumerate(keys)}


def fly(src: MissionSource, georef: Georeference, home_xyz: NDArray, home: tuple[float, float, float]) -> tuple[
        list[_Frame], list[NDArray]]:
    """Frames made by flying ``src``'s commands, and the positions of its waypoints (model frame)."""
    pos_of = _positions(src, georef, home)
    cmds = src.commands
    nav_after: list[int | None] = [None] * (len(cmds) + 1)
    for k in range(len(cmds) - 1, -1, -1):
        nav_after[k] = k if cmds[k].command in POSITIONAL else nav_after[k + 1]
    photo_cmds = {IMAGE_START_CAPTURE, DO_SET_CAM_TRIGG_DIST}
    shooting = any(c.command in photo_cmds or (c.command == DO_DIGICAM_CONTROL and c.params[4] == 1) for c in cmds)
    if not shooting:
        src.warnings.append("the mission has no photo command (IMAGE_START_CAPTURE, DO_DIGICAM_CONTROL, "
                            "DO_SET_CAM_TRIGG_DIST): a frame is made at every waypoint")

    frames: list[_Frame] = []
    waypoints: list[NDArray] = []
    pos: NDArray = np.asarray(home_xyz, float)
    airborne = False
    leg_heading = 0.0
    yaw_true: float | None = None
    pitch: float | None = None
    gimbal_yaw: tuple[float, bool] | None = None
    roi: tuple | None = None
    trigger: dict | None = None
    speed = src.speed_m_s
    counts: dict[int, int] = {}
    assumed_pitch: list[str] = []
    digicam_ignored = 0

    def target_after(k: int) -> NDArray | None:
        j = nav_after[k + 1]
        return pos_of.get(j) if j is not None else None

    def shoot(at: NDArray, target: NDArray | None, c: Command) -> None:
        if not airborne:
            raise PlanError(f"{c.where}: a photo is taken before the first waypoint or take-off: no position for it")
        p: float
        if roi is not None and roi[0] == "point":
            d = roi[1] - at
            heading = bearing(at, roi[1])
            heading = leg_heading if heading is None else heading
            p = math.degrees(math.atan2(d[2], math.hypot(d[0], d[1])))
        else:
            ahead = bearing(at, target) if target is not None else None
            along = leg_heading if ahead is None else ahead
            if roi is not None:
                heading, p = (along + roi[2]) % 360.0, roi[1]
            elif yaw_true is not None:
                heading = float(georef.model_heading(at, yaw_true)[0])
            else:
                heading = along
            if roi is None:
                if pitch is not None:
                    p = pitch
                else:
                    p = DEFAULT_PITCH_DEG
                    if not c.survey:
                        assumed_pitch.append(c.where)
        if gimbal_yaw is not None and (roi is None or roi[0] != "point"):
            value, absolute = gimbal_yaw
            heading = float(georef.model_heading(at, value)[0]) if absolute else (heading + value) % 360.0
        counts[c.ident] = counts.get(c.ident, 0) + 1
        frames.append(_Frame(np.array(at, float), heading % 360.0, float(np.clip(p, -90.0, 90.0)),
                             f"{src.prefix}{c.ident:03d}_{counts[c.ident]}"))

    for k, c in enumerate(cmds):
        cmd, prm = c.command, c.params
        if cmd in POSITIONAL:
            new = pos_of[k]
            leg = new - pos
            length = float(np.linalg.norm(leg))
            if cmd in (NAV_TAKEOFF, NAV_LAND, NAV_RETURN_TO_LAUNCH):
                yaw_true = None
            else:
                yaw_true = prm[3] if math.isfinite(prm[3]) else None
            b = bearing(pos, new)
            if b is not None and cmd != NAV_TAKEOFF:
                leg_heading = b
            if trigger is not None and airborne and length > 0:
                s0 = trigger["travelled"]
                while trigger["left"] > 0 and trigger["next"] <= s0 + length + 1e-9:
                    shoot(pos + (trigger["next"] - s0) / length * leg, new, c)
                    trigger["next"] += trigger["step"]
                    trigger["left"] -= 1
                trigger["travelled"] = s0 + length
            pos = new
            airborne = True
            if cmd in WAYPOINTS:
                if not waypoints or np.linalg.norm(new - waypoints[-1]) > SAME_WAYPOINT_M:
                    waypoints.append(new)  # a waypoint repeated in place (one per heading) is one waypoint
                if not shooting:
                    shoot(pos, target_after(k), c)
            if cmd in (NAV_RETURN_TO_LAUNCH, NAV_LAND):
                if any(x.command in photo_cmds | {DO_DIGICAM_CONTROL} for x in cmds[k + 1:]):
                    src.warnings.append(f"{c.where}: the flight ends here; the commands after it are not flown")
                break
        elif cmd == IMAGE_START_CAPTURE:
            interval, total = prm[1], prm[2]
            if math.isfinite(interval) and interval > 0 and total != 1:
                shoot(pos, target_after(k), c)
                left = (total - 1) if math.isfinite(total) and total > 0 else math.inf
                trigger = {"step": speed * interval, "next": speed * interval, "travelled": 0.0, "left": left, "time": True}
            else:
                for _ in range(int(total) if math.isfinite(total) and total > 1 else 1):
                    shoot(pos, target_after(k), c)
        elif cmd == IMAGE_STOP_CAPTURE:
            if trigger is not None and trigger.get("time"):
                trigger = None
        elif cmd == DO_DIGICAM_CONTROL:
            if prm[4] == 1:
                shoot(pos, target_after(k), c)
            else:
                digicam_ignored += 1
        elif cmd == DO_SET_CAM_TRIGG_DIST:
            if math.isfinite(prm[0]) and prm[0] > 0:
                trigger = {"step": prm[0], "next": prm[0], "travelled": 0.0, "left": math.inf}
                if prm[2] == 1:
                    shoot(pos, target_after(k), c)
            elif prm[0] == 0:
                trigger = None
        elif cmd == CONDITION_YAW:
            angle = prm[0]
            if not math.isfinite(angle):
                continue
            if prm[3] == 1:
                if yaw_true is None:
                    ahead = bearing(pos, target_after(k)) if target_after(k) is not None else None
                    current = float(georef.true_heading(pos, leg_heading if ahead is None else ahead)[0])
                else:
                    current = yaw_true
                yaw_true = (current + (-1.0 if prm[2] == -1 else 1.0) * angle) % 360.0
            else:
                yaw_true = angle % 360.0
        elif cmd == DO_MOUNT_CONTROL:
            if prm[6] in (0, 1):
                pitch = 0.0 if prm[6] == 1 else pitch
                continue
            if math.isfinite(prm[0]):
                pitch = prm[0]
            if math.isfinite(prm[2]):
                gimbal_yaw = (prm[2], False) if prm[2] != 0 else None
        elif cmd == DO_GIMBAL_MANAGER_PITCHYAW:
            if math.isfinite(prm[0]):
                pitch = prm[0]
            if math.isfinite(prm[1]):
                locked = math.isfinite(prm[4]) and int(prm[4]) & GIMBAL_YAW_LOCK
                gimbal_yaw = (prm[1], bool(locked)) if (prm[1] != 0 or locked) else None
        elif cmd == DO_SET_ROI_WPNEXT_OFFSET:
            roi = ("next", prm[4] if math.isfinite(prm[4]) else 0.0, prm[6] if math.isfinite(prm[6]) else 0.0)
        elif cmd == DO_SET_ROI_LOCATION or (cmd == DO_SET_ROI and prm[0] == 3):
            roi = ("point", pos_of[k])
        elif cmd == DO_SET_ROI_NONE or (cmd == DO_SET_ROI and prm[0] == 0):
            roi = None
        elif cmd == DO_CHANGE_SPEED:
            if math.isfinite(prm[1]) and prm[1] > 0:
                speed = prm[1]
        elif cmd == DO_JUMP:
            src.warnings.append(f"{c.where}: DO_JUMP is not followed (each item is flown once)")
    if assumed_pitch:
        src.warnings.append(f"no gimbal command before {len(assumed_pitch)} photo(s) (first: {assumed_pitch[0]}): "
                            f"gimbal pitch {DEFAULT_PITCH_DEG:g}° (nadir) assumed")
    if digicam_ignored:
        src.warnings.append(f"{digicam_ignored} DO_DIGICAM_CONTROL item(s) without the shoot command (param5 = 1) ignored")
    return frames, waypoints


# ---- camera and plan ---------------------------------------------------------------------------


def resolve_camera(settings: dict, camera: Camera | str | dict | None, where: str,
                   warnings: list[str]) -> Camera:
    """The camera a mission's settings name (catalogue, or a custom sensor and lens), else ``camera``."""
    name = str(settings.get("CameraName", "") or "").strip()
    if name.lower() not in MANUAL_CAMERAS:
        try:
            cam = get_camera(name)
        except CameraError:
            cam = None
        if cam is not None:
            if differs(camera, cam):
                warnings.append(f"the file names the camera {name!r}: it is used, not the camera given")
            return cam
    spec = [settings.get(k) for k in ("SensorWidth", "FocalLength", "ImageWidth", "ImageHeight")]
    if all(isinstance(v, (int, float)) and not isinstance(v, bool) and v > 0 for v in spec):
        try:
            sh = settings.get("SensorHeight")
            sh = float(sh) if isinstance(sh, (int, float)) and not isinstance(sh, bool) and sh > 0 else None
            cam = PinholeCamera.from_sensor(float(spec[0]), float(spec[1]), int(spec[2]), int(spec[3]), sh,
                                            name or "custom camera")
            if differs(camera, cam):
                warnings.append(f"the file describes its camera {name or 'custom camera'!r}: it is used, not the camera given")
            return cam
        except CameraError:
            pass
    if camera is not None:
        try:
            return parse_camera_spec(camera)
        except CameraError as exc:
            raise PlanError(f"{where}: {exc}") from None
    said = f"names the camera {name!r}, which the catalogue lacks" if name else "names no camera"
    raise PlanError(f"{where} {said}: say which camera took the photos with --camera (camera=, e.g. 'm3e')")


def _recorded(block: dict, n: int, camera, src: MissionSource) -> tuple[dict | None, list | None]:
    """The cameras a sightplan export recorded for its ``n`` frames, or (None, None)."""
    cams, per_frame = block.get("cameras"), block.get("frame_cameras")
    if not (isinstance(cams, dict) and isinstance(per_frame, list) and len(per_frame) == n):
        return None, None
    if not set(map(str, per_frame)) <= set(cams):
        return None, None
    try:
        cameras = {str(k): camera_from_dict(v) for k, v in cams.items()}
    except CameraError as exc:
        raise PlanError(f"{src.path.name}: the sightplan camera: {exc}") from None
    if any(differs(camera, c) for c in cameras.values()):
        src.warnings.append("the file records the cameras of its frames: they are used, not the camera given")
    return cameras, [str(c) for c in per_frame]


def plan_from_source(src: MissionSource, georef: Georeference | None, camera: Camera | str | dict | None,
                     ground_z: float | None = None) -> Plan:
    """Fly a parsed mission and build the plan (frames, waypoints, georeference, take-off point, warnings)."""
    home = src.home
    if home is None:
        first = next((c for c in src.commands if c.command in WAYPOINTS and all(map(math.isfinite, c.params[4:6]))), None)
        if first is None:
            raise PlanError(f"{src.path.name}: the mission has no waypoint")
        home = (first.params[4], first.params[5], 0.0)
        src.warnings.append("the mission has no home position: heights above home are taken from the first waypoint's "
                            "latitude/longitude at height 0")
    block = src.sightplan
    if georef is None and isinstance(block.get("georeference"), dict):
        try:
            georef = Georeference.from_dict(block["georeference"])
        except GeoreferenceError as exc:
            raise PlanError(f"{src.path.name}: the sightplan georeference: {exc}") from None
    if georef is None:
        georef = Georeference.from_origin(home[0], home[1], home[2], 0.0,
                                          source=f"{'QGroundControl planned home' if src.fmt == 'qgc' else 'home'} position "
                                                 f"of {src.path.name}")
    try:
        if ground_z is not None:  # take off from the model's ground: heights above home are measured from there
            home = (home[0], home[1], georef.height_at(home[0], home[1], ground_z, home[2]))
        home_xyz = georef.from_geodetic(home[0], home[1], home[2])[0]
    except GeoreferenceError as exc:
        raise PlanError(f"{src.path.name}: home position: {exc}") from None
    frames, waypoints = fly(src, georef, home_xyz, home)
    if not frames:
        raise PlanError(f"{src.path.name}: the mission takes no photo")
    names = [f.name for f in frames]
    cameras, frame_camera = _recorded(block, len(frames), camera, src)
    if cameras is None:
        cam = resolve_camera(src.camera_settings, camera, src.path.name, src.warnings)
        cameras, frame_camera = {cam.name or "camera": cam}, [cam.name or "camera"] * len(frames)
    recorded = block.get("frames")
    if isinstance(recorded, list) and len(recorded) == len(frames) and all(isinstance(n, str) for n in recorded):
        names = recorded
    C = np.array([f.position for f in frames])
    R = R_from_gimbal([f.heading for f in frames], [f.pitch for f in frames], 0.0)
    params = {"source": {"format": src.fmt, "path": str(src.path)}, "georeference": georef.to_dict(),
              "takeoff_m": [float(v) for v in home_xyz],
              "home": {"latitude_deg": home[0], "longitude_deg": home[1], "height_m": home[2]},
              "warnings": src.warnings}
    return Plan.build(cameras, R, C, frame_camera=frame_camera, frame_names=names,
                      missions=(Mission(src.path.stem, 0, len(frames)),),
                      waypoints=np.array(waypoints).reshape(-1, 3), parameters=params)


def read_qgc_plan(path: str | Path, georef: Georeference | None = None, camera: Camera | str | dict | None = None,
                  ground_z: float | None = None) -> Plan:
    """A plan from a QGroundControl ``.plan`` mission; see the module docstring (``ground_z``: :func:`load_plan`)."""
    return plan_from_source(parse_qgc_plan(Path(path)), georef, camera, ground_z)


def read_wpl(path: str | Path, georef: Georeference | None = None, camera: Camera | str | dict | None = None,
             ground_z: float | None = None) -> Plan:
    """A plan from a ``QGC WPL 110`` waypoint file (Mission Planner ``.waypoints``); see the module docstring."""
    return plan_from_source(parse_wpl(Path(path)), georef, camera, ground_z)
