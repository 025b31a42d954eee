"""MAVLink missions, as the QGroundControl ``.plan`` (:mod:`.qgc`) and ``QGC WPL 110`` (:mod:`.wpl`) formats
hold them: the command and frame numbers (``MAV_CMD``, ``MAV_FRAME``, ``MAV_AUTOPILOT``, ``MAV_MOUNT_MODE``, as the
MAVLink common message set defines them), reading a mission's commands into a plan and writing a flight as
commands for an autopilot.

Reading: the mission's commands are flown in order and a frame is made wherever a photo is taken:

- positions: ``NAV_WAYPOINT`` (16) and the other positional NAV commands (loiters 17/18/19/31,
  spline 82); ``NAV_TAKEOFF`` (22) moves the aircraft but makes no frame; ``NAV_RETURN_TO_LAUNCH``
  (20) and ``NAV_LAND`` (21) end the flight. Heights by MAVLink frame: 0/5 absolute (used as the
  georeference's heights), 3/6 above the home position, 10/11 (above terrain) taken as above home
  with a warning. A QGroundControl plan's home is its ``plannedHomePosition``; a WPL file's is line 0.
  The home is the take-off point: at the height the file gives, in the georeference's datum, unless a
  take-off height is given or the file's is unusable (:func:`~.reading.place_takeoff`: then the model's
  ground ``ground_z``); without a home, under the first waypoint on that ground.
- photos: ``IMAGE_START_CAPTURE`` (2000: one image, or a time-lapse of param3 images every param2 s,
  placed every speed × interval metres), ``DO_DIGICAM_CONTROL`` (203 with param5 = 1) and
  ``DO_SET_CAM_TRIGG_DIST`` (206: a frame every param1 metres along the legs flown until it is set to
  0; param3 = 1 adds one at once). A photo command before any position is an error. A mission without
  any photo command has a frame at every waypoint (and says so in ``plan.parameters["warnings"]``).
- heading: the waypoint's yaw (param4, a true heading; NaN: along the flight direction, i.e. toward
  the next position), changed by ``CONDITION_YAW`` (115), pointed by ``DO_SET_ROI_WPNEXT_OFFSET`` (196:
  toward the next waypoint plus a yaw offset) or a region of interest (195, 201), plus a gimbal yaw.
  Both forms of :mod:`.qgc` read back this way: PX4's waypoints repeated in place, one
  per heading, and ArduPilot's ``CONDITION_YAW`` after each waypoint; consecutive waypoints within
  1 cm count as one in the plan's waypoints.
- gimbal pitch: from the last ``DO_MOUNT_CONTROL`` (205, param1) or ``DO_GIMBAL_MANAGER_PITCHYAW``
  (1000, param1); inside Survey and CorridorScan items, and wherever none was given, −90 (nadir; a
  warning says where it was assumed outside a survey).

Positions go to the model frame with ``georef.from_geodetic``; without a georeference the frame is a
topocentric one at the home position (model +Y north), stored in ``plan.parameters["georeference"]``
with the home point as ``plan.parameters["takeoff_m"]`` so that exports round-trip. The camera is the
one the plan's camera settings name when the catalogue knows it (or a QGroundControl custom camera's
sensor and lens), else ``camera``. A plan written by :mod:`.qgc` carries a
``sightplan`` block (ignored by QGroundControl): its frame names, cameras and georeference are used
(a georeference given wins).

Writing (:func:`mission_items`, the command sequence of both formats, for an autopilot): positional
(NAV) items are in frame 3 (``MAV_FRAME_GLOBAL_RELATIVE_ALT``: metres above the take-off point),
every other item in frame 2 (``MAV_FRAME_MISSION``). Photo commands are ``MAV_CMD_DO_MOUNT_CONTROL``
(205: pitch in param1, roll and yaw 0, mode 2 = ``MAV_MOUNT_MODE_MAVLINK_TARGETING`` in param7) and
``MAV_CMD_IMAGE_START_CAPTURE`` (2000: all cameras, one image). Both autopilots run the commands that
follow a waypoint only once that waypoint is reached, and a waypoint's photos are grouped into *stops*:
runs of consecutive photos with the same heading. What differs (``autopilot``):

- ``px4`` (``firmwareType`` 12): the heading is the yaw of ``MAV_CMD_NAV_WAYPOINT`` (16, param4, a true
  heading): one waypoint per stop, all at the same position, each followed by its photos. PX4
  refuses ``MAV_CMD_CONDITION_YAW`` in a mission (``mavlink_mission.cpp``,
  ``parse_mavlink_mission_item``), and takes non-positional commands in frame 2 only. PX4 counts a
  waypoint reached on entering its acceptance radius and runs the photo after it in the same cycle
  (``MissionBlock::is_mission_item_reached``), so each stop is ``DO_MOUNT_CONTROL`` (before the waypoint:
  the gimbal turns on the way), ``NAV_WAYPOINT`` with acceptance radius :data:`PX4_ACCEPTANCE_M` (param2)
  and a hold (param1) of :data:`PX4_SETTLE_S` plus the turn at :data:`PX4_YAW_RATE_DEG_S` plus the
  gimbal's travel and settling, then ``IMAGE_START_CAPTURE``; a further photo with another pitch is
  ``DO_MOUNT_CONTROL``, ``MAV_CMD_NAV_DELAY`` (93: the gimbal's wait), ``IMAGE_START_CAPTURE``.
- ``ardupilot`` (``firmwareType`` 3): Copter keeps only the hold time (param1) of a waypoint and
  drops its yaw, so the heading is a ``MAV_CMD_CONDITION_YAW`` (115: param1 the true heading, param2 0
  = default turn rate, param3 0 = the shortest turn, param4 0 = absolute). ArduPilot starts the first
  command after a waypoint together with the next positional item, and every waypoint it starts
  resets the yaw to its ``WP_YAW_BEHAVIOR``; so after the arrival waypoint each stop is
  ``DO_MOUNT_CONTROL``, ``CONDITION_YAW``, ``MAV_CMD_CONDITION_DELAY`` (112: :data:`YAW_SETTLE_S`, or the
  gimbal's wait when longer), ``IMAGE_START_CAPTURE`` (then mount, delay and capture for more photos with
  that heading) followed by a waypoint at the same position that holds long enough for the turn, the
  waits and :data:`ARDUPILOT_STOP_HOLD_S` more: the commands it leaves unfinished would be dropped.

The waits follow :class:`~sightplan.flight.simulate.Gimbal` (slew rate and settling time); every export is
replayed under its autopilot's rules (:mod:`sightplan.flight`) before it is written.

A mission is the whole flight the checks passed (:mod:`sightplan.plan.trajectory`): ``MAV_CMD_NAV_TAKEOFF`` (22)
at the take-off point to the climb height (the first waypoint's altitude, at least 2 m, or the transit height when
the way out must clear the model), a waypoint above the first one where the climb height is higher, the waypoints,
then the return written out: a waypoint above the last one at the return height (where that is higher), one above
the take-off point, and ``MAV_CMD_NAV_LAND`` (21) there. An autopilot's return-to-launch is left to its own
altitude (ArduPilot's RTL_ALT, PX4's RTL_RETURN_ALT), which no check sees, so a plan whose return was never
checked (no model at hand) ends with ``MAV_CMD_NAV_RETURN_TO_LAUNCH`` (20) instead. The NAV_WAYPOINT yaw (param4)
is always the heading of the stop it starts or ends, so a ground station shows it.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from pathlib import Path
from typing import Literal, get_args

import numpy as np
from numpy.typing import NDArray

from ..camera.catalogue import get_camera
from ..camera.models import Camera, PinholeCamera, camera_from_dict
from ..errors import CameraError, PlanError
from ..geo import Georeference, GeoreferenceError
from ..geometry.poses import R_from_gimbal
from ..plan import domain
from ..plan.types import Mission, Plan
from .flight import DEFAULT_GIMBAL, SAME_POSITION_M, Flight, Gimbal, Photo, Waypoint, same_angle, wrap180
from .reading import DEFAULT_PITCH_DEG, DEFAULT_SPEED_M_S, bearing, differs, given_camera, place_takeoff

# MAV_CMD: navigation
NAV_WAYPOINT, NAV_LOITER_UNLIM, NAV_LOITER_TURNS, NAV_LOITER_TIME = 16, 17, 18, 19
NAV_RETURN_TO_LAUNCH, NAV_LAND, NAV_TAKEOFF, NAV_LOITER_TO_ALT, NAV_SPLINE_WAYPOINT = 20, 21, 22, 31, 82
# MAV_CMD: conditions and actions
CONDITION_YAW, DO_JUMP, DO_CHANGE_SPEED = 115, 177, 178
DO_SET_ROI_LOCATION, DO_SET_ROI_WPNEXT_OFFSET, DO_SET_ROI_NONE, DO_SET_ROI = 195, 196, 197, 201
DO_DIGICAM_CONTROL, DO_MOUNT_CONTROL, DO_SET_CAM_TRIGG_DIST = 203, 205, 206
DO_GIMBAL_MANAGER_PITCHYAW, IMAGE_START_CAPTURE, IMAGE_STOP_CAPTURE = 1000, 2000, 2001

# MAV_FRAME
FRAME_GLOBAL, FRAME_MISSION, FRAME_GLOBAL_RELATIVE_ALT = 0, 2, 3
# MAV_MOUNT_MODE
MOUNT_MODE_MAVLINK_TARGETING = 2
# MAV_AUTOPILOT, as QGroundControl's firmwareType
FIRMWARE_TYPES = {"ardupilot": 3, "px4": 12}  # MAV_AUTOPILOT_ARDUPILOTMEGA, MAV_AUTOPILOT_PX4

#: The autopilots a MAVLink file (qgc, wpl) is written for.
Autopilot = Literal["px4", "ardupilot"]
AUTOPILOTS: tuple[str, ...] = tuple(sorted(get_args(Autopilot)))
AUTOPILOT_LABELS = {"ardupilot": "ArduPilot", "px4": "PX4"}

# ---- reading a mission -------------------------------------------------------------------------

WAYPOINTS = {NAV_WAYPOINT, NAV_LOITER_UNLIM, NAV_LOITER_TURNS, NAV_LOITER_TIME, NAV_LOITER_TO_ALT, NAV_SPLINE_WAYPOINT}
POSITIONAL = WAYPOINTS | {NAV_TAKEOFF, NAV_LAND, NAV_RETURN_TO_LAUNCH}
ABSOLUTE_FRAMES, RELATIVE_FRAMES, TERRAIN_FRAMES = {0, 5}, {3, 6}, {10, 11}
GIMBAL_YAW_LOCK = 16
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


@dataclass
class _Frame:
    position: NDArray
    heading: float  # model heading
    pitch: float
    name: str


def home_position(values, where: str) -> tuple[float, float, float] | None:
    """A file's home (latitude, longitude, height; NaN for a height the file leaves out), None where it gives none
    (latitude and longitude 0); a PlanError starting with ``where`` for a latitude or longitude that is not a finite
    number in range."""
    lat, lon, h = (float(v) for v in values)
    if not (math.isfinite(lat) and math.isfinite(lon)):
        raise PlanError(f"{where}: its latitude and longitude are not finite numbers")
    if lat == 0 and lon == 0:
        return None
    if not (-90 <= lat <= 90 and -180 <= lon <= 360):
        raise PlanError(f"{where}: latitude {lat} / longitude {lon} out of range")
    if math.isfinite(h):
        domain.height(f"{where}: its height", h)
    return lat, lon, h


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
        domain.height(f"{c.where}: {name} altitude", alt)
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
                end, step = s0 + length + 1e-9, trigger["step"]
                ahead = 0.0 if trigger["next"] > end else (end - trigger["next"]) / step + 1 if step > 0 else math.inf
                domain.check_work(len(frames) + min(trigger["left"], ahead), domain.MAX_MISSION_PHOTOS,
                                  f"{c.where}: a camera trigger every {step:g} m", "the trigger distance or interval",
                                  "photos")
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
                count = total if math.isfinite(total) and total > 1 else 1
                domain.check_work(len(frames) + count, domain.MAX_MISSION_PHOTOS,
                                  f"{c.where}: IMAGE_START_CAPTURE of {count:g} photos", "the photo count", "photos")
                for _ in range(int(count)):
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
        return given_camera(camera, where)
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
                     ground_z: float | None = None, takeoff_z: float | None = None) -> Plan:
    """Fly a parsed mission and build the plan (frames, waypoints, georeference, take-off point, warnings).

    The take-off point is the file's home (:func:`~.reading.place_takeoff`: its height as the file gives it, unless
    ``takeoff_z`` replaces it or it is unusable; then the model's ground ``ground_z``)."""
    home = src.home
    what = "QGroundControl planned home position" if src.fmt == "qgc" else "home position (line 0)"
    if home is None:
        first = next((c for c in src.commands if c.command in WAYPOINTS and all(map(math.isfinite, c.params[4:6]))), None)
        if first is None:
            raise PlanError(f"{src.path.name}: the mission has no waypoint")
        home = (first.params[4], first.params[5], math.nan)
        src.warnings.append("the mission has no home position: heights above home start from "
                            f"{'the model ground' if ground_z is not None else 'height 0'} under the first waypoint")
    elif not math.isfinite(home[2]):
        src.warnings.append(f"the {what} has no height: heights above home start from "
                            f"{'the model ground' if ground_z is not None else 'height 0'}")
    block = src.sightplan
    model = georef is not None
    if georef is None and isinstance(block.get("georeference"), dict):
        try:
            georef = Georeference.from_dict(block["georeference"])
        except GeoreferenceError as exc:
            raise PlanError(f"{src.path.name}: the sightplan georeference: {exc}") from None
        model = True
    file_h = home[2] if math.isfinite(home[2]) else None
    try:
        if georef is None:
            georef = Georeference.from_origin(home[0], home[1], file_h or 0.0, 0.0,
                                              source=f"{'QGroundControl planned home' if src.fmt == 'qgc' else 'home'} "
                                                     f"position of {src.path.name}")
        takeoff = place_takeoff(georef, home[0], home[1], file_h, model=model, ground_z=ground_z, takeoff_z=takeoff_z,
                                what=what, warnings=src.warnings)
    except GeoreferenceError as exc:
        raise PlanError(f"{src.path.name}: home position: {exc}") from None
    home, home_xyz = (takeoff.latitude_deg, takeoff.longitude_deg, takeoff.height_m), takeoff.xyz
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
              "takeoff_m": [float(v) for v in home_xyz], "home": takeoff.to_dict(),
              "warnings": src.warnings}
    return Plan.build(cameras, R, C, frame_camera=frame_camera, frame_names=names,
                      missions=(Mission(src.path.stem, 0, len(frames)),),
                      waypoints=np.array(waypoints).reshape(-1, 3), parameters=params)


# ---- writing a flight --------------------------------------------------------------------------

MIN_TAKEOFF_ALTITUDE_M = 2.0
NAV_DELAY, CONDITION_DELAY = 93, 112
# PX4: each photo waypoint is reached within this radius (param2) and then held (param1) for the position to settle,
# plus the yaw turn at MPC_YAWRAUTO_MAX and the gimbal's travel: the photo is taken still, on the frame
PX4_ACCEPTANCE_M = 0.5
PX4_SETTLE_S = 1.0
PX4_YAW_RATE_DEG_S = 45.0
# ArduPilot: the hold of a stop's waypoint covers the turn at ATC_SLEW_YAW, the waits, and this margin
ARDUPILOT_STOP_HOLD_S = 1.0
ARDUPILOT_YAW_RATE_DEG_S = 60.0
UNKNOWN_PITCH_MOVE_DEG = 90.0  # the gimbal's travel assumed for the first pitch of a mission
YAW_SETTLE_S = 0.5  # CONDITION_YAW is verified within 2°: the photo waits this long after it


def resolve_autopilot(autopilot: str | None, default: str = "px4") -> str:
    """``autopilot``, or ``default`` (the format's) when None; a PlanError for an unknown one."""
    if autopilot is None:
        return default
    if autopilot not in AUTOPILOTS:
        raise PlanError(f"unknown autopilot {autopilot!r}; expected one of {', '.join(AUTOPILOTS)}")
    return autopilot


def _bearing(a: tuple[float, float], b: tuple[float, float]) -> float | None:
    """The true bearing from (latitude°, longitude°) a to b, None closer than 1 m (a local flat approximation: it
    only sizes a turn's time; ArduPilot faces its way only beyond 2 m, so a leg near that length counts)."""
    dy = math.radians(b[0] - a[0]) * 6_371_000.0
    dx = math.radians(b[1] - a[1]) * 6_371_000.0 * math.cos(math.radians(a[0]))
    return None if math.hypot(dx, dy) < 1.0 else math.degrees(math.atan2(dx, dy)) % 360.0


def stops(photos: tuple[Photo, ...]) -> list[list[Photo]]:
    """A waypoint's photos in runs of consecutive photos with the same heading."""
    out: list[list[Photo]] = []
    for photo in photos:
        if out and same_angle(out[-1][0].heading_deg, photo.heading_deg):
            out[-1].append(photo)
        else:
            out.append([photo])
    return out


def _turn(a: float, b: float) -> float:
    """The least turn from heading a to heading b (degrees, ≥ 0)."""
    return abs(wrap180(b - a))


def _up(seconds: float) -> float:
    """A wait written to the hundredth of a second, rounded up: never shorter than the time it covers."""
    return math.ceil(round(seconds * 100.0, 6)) / 100.0


def _worst_turn(yaw: float | None, travel: float | None, heading: float) -> float:
    """The largest turn to ``heading`` the aircraft may need at a stop: from its last heading ``yaw`` (None:
    unknown, 180°), or from anywhere on its way round to the direction of travel ``travel`` (an autopilot that faces
    the way it flies may not have finished that turn on a short leg)."""
    if yaw is None:
        return 180.0
    if travel is None:
        return _turn(yaw, heading)
    arc = (travel - yaw + 180.0) % 360.0 - 180.0
    return max(_turn(yaw + arc * t, heading) for t in np.linspace(0.0, 1.0, 37))


def mission_items(flight: Flight, waypoints: list[Waypoint], autopilot: Autopilot = "px4",
                  gimbal: Gimbal | None = None) -> list[dict]:
    """The command sequence of one mission for ``autopilot``: dicts with ``command``, ``frame``, 7 ``params`` and
    ``nav`` (positional); see the module docstring. ``gimbal``: its slew rate and settle time, which set the waits
    (default :class:`~sightplan.flight.simulate.Gimbal`)."""
    autopilot = resolve_autopilot(autopilot)
    gimbal = gimbal or DEFAULT_GIMBAL
    items: list[dict] = []

    def add(command: int, params: list[float], nav: bool = False) -> None:
        items.append({"command": command, "frame": FRAME_GLOBAL_RELATIVE_ALT if nav else FRAME_MISSION,
                      "params": [float(p) for p in params], "nav": nav})

    def waypoint(wp: Waypoint, heading: float, hold_s: float = 0.0, accept_m: float = 0.0) -> None:
        add(NAV_WAYPOINT, [_up(hold_s), accept_m, 0, heading, wp.latitude_deg, wp.longitude_deg, wp.altitude_m],
            nav=True)

    def mount(pitch: float) -> None:
        add(DO_MOUNT_CONTROL, [pitch, 0, 0, 0, 0, 0, MOUNT_MODE_MAVLINK_TARGETING])

    first, last = waypoints[0], waypoints[-1]
    path = flight.path_of(first.mission)
    climb = max(first.altitude_m, MIN_TAKEOFF_ALTITUDE_M, path[0] if path else -np.inf)
    add(NAV_TAKEOFF, [0, 0, 0, first.photos[0].heading_deg, flight.takeoff_latitude_deg, flight.takeoff_longitude_deg,
                      climb], nav=True)
    if path and climb > first.altitude_m + SAME_POSITION_M:  # level at the climb height, then down to the first
        add(NAV_WAYPOINT, [0, 0, 0, first.photos[0].heading_deg, first.latitude_deg, first.longitude_deg, climb], nav=True)
    # the aircraft's heading and the gimbal's pitch so far, unknown at take-off: any turn may be needed, and the
    # first photo's pitch is always sent
    yaw, pitch, at = None, None, None
    for wp in waypoints:
        groups = stops(wp.photos)
        travel = None if at is None else _bearing(at, (wp.latitude_deg, wp.longitude_deg))
        at = (wp.latitude_deg, wp.longitude_deg)
        if autopilot == "ardupilot":
            waypoint(wp, groups[0][0].heading_deg)
        for group in groups:
            heading = group[0].heading_deg
            turn = _worst_turn(yaw, travel, heading)
            travel, yaw = None, heading
            if autopilot == "px4":
                # the gimbal turns on the way; the waypoint holds until the aircraft, its yaw and the gimbal are still
                moved = UNKNOWN_PITCH_MOVE_DEG if pitch is None else abs(group[0].pitch_deg - pitch)
                if moved > 0:
                    mount(group[0].pitch_deg)
                    pitch = group[0].pitch_deg
                hold = PX4_SETTLE_S + turn / PX4_YAW_RATE_DEG_S + (gimbal.wait_s(moved) if moved > 0 else 0.0)
                waypoint(wp, heading, hold, PX4_ACCEPTANCE_M)
                add(IMAGE_START_CAPTURE, [0, 0, 1, 0, 0, 0, 0])
                for photo in group[1:]:
                    if photo.pitch_deg != pitch:
                        mount(photo.pitch_deg)
                        add(NAV_DELAY, [_up(gimbal.wait_s(photo.pitch_deg - pitch)), -1, -1, -1, 0, 0, 0])
                        pitch = photo.pitch_deg
                    add(IMAGE_START_CAPTURE, [0, 0, 1, 0, 0, 0, 0])
                continue
            waits = 0.0
            for k, photo in enumerate(group):
                moved = UNKNOWN_PITCH_MOVE_DEG if pitch is None else abs(photo.pitch_deg - pitch)
                mount(photo.pitch_deg)
                pitch = photo.pitch_deg
                if k == 0:
                    add(CONDITION_YAW, [heading, 0, 0, 0, 0, 0, 0])
                wait = max(gimbal.wait_s(moved) if moved > 0 else 0.0, YAW_SETTLE_S if k == 0 else 0.0)
                if wait > 0:
                    add(CONDITION_DELAY, [_up(wait), 0, 0, 0, 0, 0, 0])
                    waits += _up(wait)
                add(IMAGE_START_CAPTURE, [0, 0, 1, 0, 0, 0, 0])
            hold = ARDUPILOT_STOP_HOLD_S + turn / ARDUPILOT_YAW_RATE_DEG_S + waits
            waypoint(wp, heading, hold)
    if path is None:
        add(NAV_RETURN_TO_LAUNCH, [0, 0, 0, 0, 0, 0, 0])
        return items
    # the return the checks passed, written out: up to the return height, home level, then land at the take-off point
    home = flight.takeoff_of(first.mission)
    back = max(path[1], last.altitude_m)
    heading = last.photos[-1].heading_deg
    if back > last.altitude_m + SAME_POSITION_M:
        add(NAV_WAYPOINT, [0, 0, 0, heading, last.latitude_deg, last.longitude_deg, back], nav=True)
    add(NAV_WAYPOINT, [0, 0, 0, heading, home.latitude_deg, home.longitude_deg, back], nav=True)
    add(NAV_LAND, [0, 0, 0, heading, home.latitude_deg, home.longitude_deg, 0], nav=True)
    return items
