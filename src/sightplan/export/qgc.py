"""QGroundControl ``.plan`` export (JSON: ``fileType`` "Plan", version 1; mission version 2).

The mission is a list of ``SimpleItem`` MAVLink commands, ``doJumpId`` counting from 1:

- ``MAV_CMD_NAV_TAKEOFF`` (22) at the take-off point, to the first waypoint's altitude (at least 2 m);
- per waypoint ``MAV_CMD_NAV_WAYPOINT`` (16), frame 3 (``MAV_FRAME_GLOBAL_RELATIVE_ALT``: metres above
  the take-off point), params ``[hold 0, acceptance 0, pass-through 0, yaw, lat, lon, alt]`` with the yaw
  the true heading of its first photo; then per photo ``MAV_CMD_CONDITION_YAW`` (115: absolute heading,
  shortest turn) when the heading differs from the one the aircraft holds, ``MAV_CMD_DO_MOUNT_CONTROL``
  (205: pitch in param1, yaw 0, mode 2 = ``MAV_MOUNT_MODE_MAVLINK_TARGETING``, the form QGroundControl's
  own camera section writes and ArduPilot and PX4 fly) and ``MAV_CMD_IMAGE_START_CAPTURE`` (2000: one image);
- ``MAV_CMD_NAV_RETURN_TO_LAUNCH`` (20).

``plannedHomePosition`` is the take-off point's latitude, longitude and absolute height. A
``sightplan`` block (ignored by QGroundControl) records the frames' names and cameras, the
georeference and the take-off point, so that an import gives back the same frames. Autopilots run
the commands that follow a waypoint while flying on to the next one: give the waypoints a hold time in
the ground station where the aircraft must be still for its photos. A plan with several missions is
written as one file per mission (``stem_m01.plan``…).
"""

from __future__ import annotations

import json
from pathlib import Path

from .common import Flight, Waypoint, mission_paths, same_angle

NAV_WAYPOINT = 16
NAV_RETURN_TO_LAUNCH = 20
NAV_TAKEOFF = 22
CONDITION_YAW = 115
DO_MOUNT_CONTROL = 205
IMAGE_START_CAPTURE = 2000
MOUNT_MODE_MAVLINK_TARGETING = 2
FRAME_GLOBAL = 0
FRAME_MISSION = 2
FRAME_GLOBAL_RELATIVE_ALT = 3
MIN_TAKEOFF_ALTITUDE_M = 2.0


def mission_items(flight: Flight, waypoints: list[Waypoint]) -> list[dict]:
    """The command sequence of one mission: dicts with ``command``, ``frame``, 7 ``params`` and ``nav`` (positional)."""
    items: list[dict] = []

    def add(command: int, frame: int, params: list[float], nav: bool = False) -> None:
        items.append({"command": command, "frame": frame, "params": [float(p) for p in params], "nav": nav})

    first = waypoints[0]
    add(NAV_TAKEOFF, FRAME_GLOBAL_RELATIVE_ALT,
        [0, 0, 0, first.photos[0].heading_deg, flight.takeoff_latitude_deg, flight.takeoff_longitude_deg,
         max(first.altitude_m, MIN_TAKEOFF_ALTITUDE_M)], nav=True)
    for wp in waypoints:
        heading = wp.photos[0].heading_deg
        add(NAV_WAYPOINT, FRAME_GLOBAL_RELATIVE_ALT, [0, 0, 0, heading, wp.latitude_deg, wp.longitude_deg, wp.altitude_m],
            nav=True)
        for photo in wp.photos:
            if not same_angle(photo.heading_deg, heading):
                heading = photo.heading_deg
                add(CONDITION_YAW, FRAME_MISSION, [heading, 0, 0, 0, 0, 0, 0])
            add(DO_MOUNT_CONTROL, FRAME_MISSION, [photo.pitch_deg, 0, 0, 0, 0, 0, MOUNT_MODE_MAVLINK_TARGETING])
            add(IMAGE_START_CAPTURE, FRAME_MISSION, [0, 0, 1, 0, 0, 0, 0])
    add(NAV_RETURN_TO_LAUNCH, FRAME_MISSION, [0, 0, 0, 0, 0, 0, 0])
    return items


def plan_document(flight: Flight, waypoints: list[Waypoint]) -> dict:
    """The ``.plan`` JSON object of one mission."""
    plan = flight.plan
    frames = [p.frame for wp in waypoints for p in wp.photos]
    cams = sorted({str(plan.frame_camera[i]) for i in frames})
    items = []
    for k, it in enumerate(mission_items(flight, waypoints), start=1):
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
            "firmwareType": 0,
            "globalPlanAltitudeMode": 1,
            "hoverSpeed": flight.speed_m_s,
            "items": items,
            "plannedHomePosition": [flight.takeoff_latitude_deg, flight.takeoff_longitude_deg, flight.takeoff_height_m],
            "vehicleType": 2,
            "version": 2,
        },
        "rallyPoints": {"points": [], "version": 2},
        "sightplan": {"version": 1, "frames": [str(plan.frame_names[i]) for i in frames],
                      "frame_cameras": [str(plan.frame_camera[i]) for i in frames],
                      "cameras": {c: plan.cameras[c].to_dict() for c in cams},
                      "georeference": flight.georef.to_dict(), "takeoff_m": list(flight.takeoff_m)},
        "version": 1,
    }


def write_qgc(flight: Flight, path: Path) -> list[Path]:
    groups = flight.by_mission()
    paths = mission_paths(path, [m for m, _ in groups], several=len(groups) > 1)
    for m, wps in groups:
        paths[m].write_text(json.dumps(plan_document(flight, wps), indent=2, allow_nan=False), encoding="utf-8")
    return [paths[m] for m, _ in groups]
