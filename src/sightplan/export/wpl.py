"""``QGC WPL 110`` text export (Mission Planner ``.waypoints``, read by QGroundControl and MAVProxy), per autopilot.

First line ``QGC WPL 110``; then one tab-separated line per item: ``seq current frame command p1 p2 p3
p4 lat lon alt autocontinue``. Line 0 is the home (take-off) position, ``current`` 1, frame 0
(``MAV_FRAME_GLOBAL``, absolute height); the items after it are the command sequence of
:func:`sightplan.export.qgc.mission_items` for the autopilot (ArduPilot by default: this is Mission
Planner's format), each in its own frame: 3 (heights above home) for positional items, 2
(``MAV_FRAME_MISSION``) for the others; autocontinue 1. One file per mission when the plan has
several (``stem_m01.waypoints``…).
"""

from __future__ import annotations

from pathlib import Path

from ..formats.mavlink import FRAME_GLOBAL, NAV_WAYPOINT
from .common import Flight, mission_paths, number_text
from .qgc import Autopilot, mission_items, resolve_autopilot


def _line(seq: int, current: int, frame: int, command: int, params: list[float]) -> str:
    p = [number_text(v, 8) for v in params[:4]] + [number_text(v, 9) for v in params[4:6]] + [number_text(params[6], 4)]
    return "\t".join([str(seq), str(current), str(frame), str(command), *p, "1"])


def wpl_text(flight: Flight, waypoints, autopilot: Autopilot | None = None) -> str:
    """The file of one mission for ``autopilot`` (default ArduPilot)."""
    autopilot = resolve_autopilot("wpl", autopilot)
    lines = ["QGC WPL 110",
             _line(0, 1, FRAME_GLOBAL, NAV_WAYPOINT,
                   [0, 0, 0, 0, flight.takeoff_latitude_deg, flight.takeoff_longitude_deg, flight.takeoff_height_m])]
    for seq, it in enumerate(mission_items(flight, waypoints, autopilot), start=1):
        lines.append(_line(seq, 0, it["frame"], it["command"], it["params"]))
    return "\n".join(lines) + "\n"


def write_wpl(flight: Flight, path: Path, autopilot: Autopilot | None = None) -> list[Path]:
    """One ``.waypoints`` file per mission for ``autopilot`` (default ArduPilot)."""
    autopilot = resolve_autopilot("wpl", autopilot)
    groups = flight.by_mission()
    paths = mission_paths(path, [m for m, _ in groups], several=len(groups) > 1)
    for m, wps in groups:
        paths[m].write_text(wpl_text(flight, wps, autopilot), encoding="utf-8")
    return [paths[m] for m, _ in groups]
