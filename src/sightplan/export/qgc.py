"""QGroundControl ``.plan`` export (JSON: ``fileType`` "Plan", version 1; mission version 2), per autopilot.

The mission is a list of ``SimpleItem`` MAVLink commands, ``doJumpId`` counting from 1. Positional
(NAV) items are in frame 3 (``MAV_FRAME_GLOBAL_RELATIVE_ALT``: metres above the take-off point),
every other item in frame 2 (``MAV_FRAME_MISSION``). Photo commands are ``MAV_CMD_DO_MOUNT_CONTROL``
(205: pitch in param1, roll and yaw 0, mode 2 = ``MAV_MOUNT_MODE_MAVLINK_TARGETING`` in param7) and
``MAV_CMD_IMAGE_START_CAPTURE`` (2000: all cameras, one image). Both autopilots run the commands that
follow a waypoint only once that waypoint is reached, and a waypoint's photos are grouped into *stops*:
runs of consecutive photos with the same heading. What differs (``autopilot``):

- ``px4`` (``firmwareType`` 12): the heading is the yaw of ``MAV_CMD_NAV_WAYPOINT`` (16, param4, a true
  heading): one waypoint per stop, all at the same position, each followed by its photos. PX4
  refuses ``MAV_CMD_CONDITION_YAW`` in a mission (``mavlink_mission.cpp``,
  ``parse_mavlink_mission_item``), and takes non-positional commands in frame 2 only.
- ``ardupilot`` (``firmwareType`` 3): Copter keeps only the hold time (param1) of a waypoint and
  drops its yaw, so the heading is a ``MAV_CMD_CONDITION_YAW`` (115: param1 the true heading, param2 0
  = default turn rate, param3 0 = the shortest turn, param4 0 = absolute). ArduPilot starts the first
  command after a waypoint together with the next positional item, and every waypoint it starts
  resets the yaw to its ``WP_YAW_BEHAVIOR``; so after the arrival waypoint each stop is
  ``DO_MOUNT_CONTROL``, ``CONDITION_YAW``, ``IMAGE_START_CAPTURE`` (then mount and capture for more
  photos with that heading) followed by a waypoint at the same position that holds
  :data:`ARDUPILOT_STOP_HOLD_S` seconds: the aircraft turns and shoots during that hold, in place.

A mission is ``MAV_CMD_NAV_TAKEOFF`` (22) at the take-off point to the first waypoint's altitude (at
least 2 m), the waypoints, then ``MAV_CMD_NAV_RETURN_TO_LAUNCH`` (20). The NAV_WAYPOINT yaw (param4) is
always the heading of the stop it starts or ends, so a ground station shows it.

``plannedHomePosition`` is the take-off point's latitude, longitude and absolute height. A
``sightplan`` block (ignored by QGroundControl) records the autopilot, the frames' names and cameras,
the georeference and the take-off point, so that an import gives back the same frames. A plan with
several missions is written as one file per mission (``stem_m01.plan``…).
"""

from __future__ import annotations

import json
from pathlib import Path
from typing import get_args

from ..errors import PlanError
from ..formats import Autopilot
from ..formats.mavlink import (
    CONDITION_YAW,
    DO_MOUNT_CONTROL,
    FIRMWARE_TYPES,
    FRAME_GLOBAL_RELATIVE_ALT,
    FRAME_MISSION,
    IMAGE_START_CAPTURE,
    MOUNT_MODE_MAVLINK_TARGETING,
    NAV_RETURN_TO_LAUNCH,
    NAV_TAKEOFF,
    NAV_WAYPOINT,
)
from .common import Flight, Photo, Waypoint, mission_paths, same_angle

MIN_TAKEOFF_ALTITUDE_M = 2.0
ARDUPILOT_STOP_HOLD_S = 4.0  # a 180° turn at Copter's default yaw slew (60°/s) takes 3 s; then the shot

AUTOPILOTS: tuple[str, ...] = tuple(sorted(get_args(Autopilot)))
AUTOPILOT_LABELS = {"ardupilot": "ArduPilot", "px4": "PX4"}
# QGroundControl is PX4's ground station; a QGC WPL file is Mission Planner's (ArduPilot's) format
DEFAULT_AUTOPILOT = {"qgc": "px4", "wpl": "ardupilot"}


def resolve_autopilot(fmt: str, autopilot: str | None) -> str:
    """``autopilot``, or the format's default when None; a PlanError for an unknown one."""
    if autopilot is None:
        return DEFAULT_AUTOPILOT.get(fmt, "px4")
    if autopilot not in AUTOPILOTS:
        raise PlanError(f"unknown autopilot {autopilot!r}; expected one of {', '.join(AUTOPILOTS)}")
    return autopilot


def stops(photos: tuple[Photo, ...]) -> list[list[Photo]]:
    """A waypoint's photos in runs of consecutive photos with the same heading."""
    out: list[list[Photo]] = []
    for photo in photos:
        if out and same_angle(out[-1][0].heading_deg, photo.heading_deg):
            out[-1].append(photo)
        else:
            out.append([photo])
    return out


def mission_items(flight: Flight, waypoints: list[Waypoint], autopilot: Autopilot = "px4") -> list[dict]:
    """The command sequence of one mission for ``autopilot``: dicts with ``command``, ``frame``, 7 ``params`` and
    ``nav`` (positional); see the module docstring."""
    autopilot = resolve_autopilot("qgc", autopilot)
    items: list[dict] = []

    def add(command: int, params: list[float], nav: bool = False) -> None:
        items.append({"command": command, "frame": FRAME_GLOBAL_RELATIVE_ALT if nav else FRAME_MISSION,
                      "params": [float(p) for p in params], "nav": nav})

    def waypoint(wp: Waypoint, heading: float, hold_s: float = 0.0) -> None:
        add(NAV_WAYPOINT, [hold_s, 0, 0, heading, wp.latitude_deg, wp.longitude_deg, wp.altitude_m], nav=True)

    def mount(photo: Photo) -> None:
        add(DO_MOUNT_CONTROL, [photo.pitch_deg, 0, 0, 0, 0, 0, MOUNT_MODE_MAVLINK_TARGETING])

    first = waypoints[0]
    add(NAV_TAKEOFF, [0, 0, 0, first.photos[0].heading_deg, flight.takeoff_latitude_deg, flight.takeoff_longitude_deg,
                      max(first.altitude_m, MIN_TAKEOFF_ALTITUDE_M)], nav=True)
    for wp in waypoints:
        groups = stops(wp.photos)
        if autopilot == "ardupilot":
            waypoint(wp, groups[0][0].heading_deg)
        for group in groups:
            heading = group[0].heading_deg
            if autopilot == "px4":
                waypoint(wp, heading)
            for k, photo in enumerate(group):
                mount(photo)
                if autopilot == "ardupilot" and k == 0:
                    add(CONDITION_YAW, [heading, 0, 0, 0, 0, 0, 0])
                add(IMAGE_START_CAPTURE, [0, 0, 1, 0, 0, 0, 0])
            if autopilot == "ardupilot":
                waypoint(wp, heading, ARDUPILOT_STOP_HOLD_S)
    add(NAV_RETURN_TO_LAUNCH, [0, 0, 0, 0, 0, 0, 0])
    return items


def plan_document(flight: Flight, waypoints: list[Waypoint], autopilot: Autopilot = "px4") -> dict:
    """The ``.plan`` JSON object of one mission for ``autopilot``."""
    autopilot = resolve_autopilot("qgc", autopilot)
    plan = flight.plan
    frames = [p.frame for wp in waypoints for p in wp.photos]
    cams = sorted({str(plan.frame_camera[i]) for i in frames})
    items = []
    for k, it in enumerate(mission_items(flight, waypoints, autopilot), start=1):
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


def write_qgc(flight: Flight, path: Path, autopilot: Autopilot | None = None) -> list[Path]:
    """One ``.plan`` per mission for ``autopilot`` (default :data:`DEFAULT_AUTOPILOT`: PX4)."""
    autopilot = resolve_autopilot("qgc", autopilot)
    groups = flight.by_mission()
    paths = mission_paths(path, [m for m, _ in groups], several=len(groups) > 1)
    for m, wps in groups:
        doc = plan_document(flight, wps, autopilot)
        paths[m].write_text(json.dumps(doc, indent=2, allow_nan=False), encoding="utf-8")
    return [paths[m] for m, _ in groups]
