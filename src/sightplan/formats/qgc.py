"""QGroundControl ``.plan`` missions (JSON: ``fileType`` "Plan", version 1; mission version 2), read and written as
:mod:`.mavlink` reads and writes a mission's commands.

Read: a plan's home is its ``plannedHomePosition``, the take-off point its relative heights start from (see
:mod:`.mavlink`). QGroundControl complex items: Survey and CorridorScan
are read from their expanded ``TransectStyleComplexItem.Items`` (or ``Items``); a StructureScan (which
QGroundControl saves without items) is expanded as QGroundControl does: its polygon, made clockwise, offset outward by the
camera's distance to the surface; ``Layers`` loops around it at heights from ``StructureHeight`` (or
``ScanBottomAlt``) in steps of the frontal footprint, each triggering a photo every side footprint
metres, the camera ``GimbalPitch`` and 90° right of the direction of flight, toward the structure.

Written: the mission is a list of ``SimpleItem`` commands (:func:`~.mavlink.mission_items`), ``doJumpId``
counting from 1, for PX4 by default (``firmwareType`` 12; ArduPilot 3). ``plannedHomePosition`` is the
take-off point's latitude, longitude and absolute height. A ``sightplan`` block (ignored by QGroundControl)
records the autopilot, the frames' names and cameras, the georeference and the take-off point, so that an
import gives back the same frames. A plan with several missions is written as one file per mission
(``stem_m01.plan``…).
"""

from __future__ import annotations

import json
import math
from pathlib import Path
from typing import Any

import numpy as np
from numpy.typing import NDArray

from ..camera.models import Camera
from ..errors import PlanError
from ..geo import Georeference
from ..plan import domain
from ..plan.format import read_json
from ..plan.types import Plan
from .base import FlightFormat, ReadOptions, Source, Target
from .flight import Flight, Waypoint, write_missions
from .mavlink import (
    DO_SET_CAM_TRIGG_DIST,
    DO_SET_ROI_NONE,
    DO_SET_ROI_WPNEXT_OFFSET,
    FIRMWARE_TYPES,
    NAV_WAYPOINT,
    Autopilot,
    Command,
    MissionSource,
    home_position,
    mission_items,
    plan_from_source,
    resolve_autopilot,
)

DEFAULT_AUTOPILOT = "px4"  # QGroundControl is PX4's ground station

# ---- reading -----------------------------------------------------------------------------------


def _float(value: Any, where: str) -> float:
    if value is None:
        return math.nan
    if isinstance(value, bool) or not isinstance(value, (int, float)):
        raise PlanError(f"{where}: {value!r} is not a number")
    return float(value)


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
    domain.check_work(layers * (len(poly) + 3), domain.MAX_MISSION_PHOTOS, f"{where}: a StructureScan of {layers:,} "
                      f"layers", "'Layers'", "mission items")
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
    src = MissionSource(path, [], home_position(home, f"{path.name}: 'plannedHomePosition'"))
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


def read_qgc_plan(path: str | Path, georef: Georeference | None = None, camera: Camera | str | dict | None = None,
                  ground_z: float | None = None, takeoff_z: float | None = None) -> Plan:
    """A plan from a QGroundControl ``.plan`` mission; see the module docstring (``ground_z``, ``takeoff_z``:
    :func:`~sightplan.plan.load.load_plan`)."""
    return plan_from_source(parse_qgc_plan(Path(path)), georef, camera, ground_z, takeoff_z)


def _read(source: Source, options: ReadOptions) -> Plan:
    return read_qgc_plan(source.path, georef=options.georef, camera=options.camera, ground_z=options.ground_z,
                         takeoff_z=options.takeoff_z)


# ---- writing -----------------------------------------------------------------------------------


def plan_document(flight: Flight, waypoints: list[Waypoint], autopilot: Autopilot = "px4", gimbal=None) -> dict:
    """The ``.plan`` JSON object of one mission for ``autopilot`` (waits sized for ``gimbal``)."""
    autopilot = resolve_autopilot(autopilot, DEFAULT_AUTOPILOT)
    plan = flight.plan
    frames = [p.frame for wp in waypoints for p in wp.photos]
    cams = sorted({str(plan.frame_camera[i]) for i in frames})
    items = []
    for k, it in enumerate(mission_items(flight, waypoints, autopilot, gimbal), start=1):
        item = {"autoContinue": True, "command": it["command"], "doJumpId": k, "frame": it["frame"],
                "params": it["params"], "type": "SimpleItem"}
        if it["nav"]:
            item.update({"AMSLAltAboveTerrain": None, "Altitude": it["params"][6], "AltitudeMode": 1})
        items.append(item)
    return {
        "fileType": "Plan",
        "geoFence": {"circles": [], "polygons": [], "version": 2},
        "groundStation": "sightplan",
        "mission": {
            "cruiseSpeed": flight.speed_m_s,
            "firmwareType": FIRMWARE_TYPES[autopilot],
            "globalPlanAltitudeMode": 1,
            "hoverSpeed": flight.speed_m_s,
            "items": items,
            "plannedHomePosition": [flight.takeoff_latitude_deg, flight.takeoff_longitude_deg, flight.takeoff_height_m],
            "vehicleType": 2,
            "version": 2,
        },
        "rallyPoints": {"points": [], "version": 2},
        "sightplan": {"version": 1, "autopilot": autopilot, "frames": [str(plan.frame_names[i]) for i in frames],
                      "frame_cameras": [str(plan.frame_camera[i]) for i in frames],
                      "cameras": {c: plan.cameras[c].to_dict() for c in cams},
                      "georeference": flight.georef.to_dict(), "takeoff_m": list(flight.takeoff_m)},
        "version": 1,
    }


def write_qgc(flight: Flight, path: Path, autopilot: Autopilot | None = None, gimbal=None) -> list[Path]:
    """One ``.plan`` per mission for ``autopilot`` (default :data:`DEFAULT_AUTOPILOT`: PX4)."""
    autopilot = resolve_autopilot(autopilot, DEFAULT_AUTOPILOT)
    return write_missions(flight, path, lambda wps: json.dumps(plan_document(flight, wps, autopilot, gimbal), indent=2,
                                                               allow_nan=False))


def _write(flight: Flight, path: Path, target: Target) -> list[Path]:
    return write_qgc(flight, path, target.autopilot, target.gimbal)


FORMAT = FlightFormat(name="qgc", label="QGroundControl", order=10, read=_read, suffixes=(".plan",), uses_camera=True,
                      write=_write, suffix=".plan", media_type="application/json", autopilot=DEFAULT_AUTOPILOT,
                      per_mission=True, pitch_range=(-90.0, 90.0), title="QGroundControl plan",
                      help="QGroundControl .plan")
