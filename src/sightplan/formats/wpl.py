"""``QGC WPL 110`` waypoint files (Mission Planner ``.waypoints``, read by QGroundControl and MAVProxy), read and
written as :mod:`.mavlink` reads and writes a mission's commands; line 0 is the home position, the take-off point the
relative heights start from.

First line ``QGC WPL 110``; then one tab-separated line per item: ``seq current frame command p1 p2 p3
p4 lat lon alt autocontinue``. Line 0 is the home (take-off) position, ``current`` 1, frame 0
(``MAV_FRAME_GLOBAL``, absolute height); the items after it are the command sequence of
:func:`~.mavlink.mission_items` for the autopilot (ArduPilot by default: this is Mission
Planner's format), each in its own frame: 3 (heights above home) for positional items, 2
(``MAV_FRAME_MISSION``) for the others; autocontinue 1. One file per mission when the plan has
several (``stem_m01.waypoints``…).
"""

from __future__ import annotations

from pathlib import Path

from ..camera.models import Camera
from ..errors import PlanError
from ..geo import Georeference
from ..plan.types import Plan
from .base import FlightFormat, ReadOptions, Source, Target
from .flight import Flight, number_text, write_missions
from .mavlink import (
    FRAME_GLOBAL,
    NAV_WAYPOINT,
    Autopilot,
    Command,
    MissionSource,
    home_position,
    mission_items,
    plan_from_source,
    resolve_autopilot,
)

DEFAULT_AUTOPILOT = "ardupilot"  # a QGC WPL file is Mission Planner's (ArduPilot's) format

# ---- reading -----------------------------------------------------------------------------------


def sniff(source: Source) -> bool:
    """Whether the file is a text file starting with the ``QGC WPL`` header."""
    return source.head().lstrip(b"\xef\xbb\xbf").startswith(b"QGC WPL")


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
            src.home = home_position(params[4:7], f"{where}: the home position")
            continue
        src.commands.append(Command(command, frame, params, where, seq))
    return src


def read_wpl(path: str | Path, georef: Georeference | None = None, camera: Camera | str | dict | None = None,
             ground_z: float | None = None, takeoff_z: float | None = None) -> Plan:
    """A plan from a ``QGC WPL 110`` waypoint file (Mission Planner ``.waypoints``); see the module docstring."""
    return plan_from_source(parse_wpl(Path(path)), georef, camera, ground_z, takeoff_z)


def _read(source: Source, options: ReadOptions) -> Plan:
    return read_wpl(source.path, georef=options.georef, camera=options.camera, ground_z=options.ground_z,
                    takeoff_z=options.takeoff_z)


# ---- writing -----------------------------------------------------------------------------------


def _line(seq: int, current: int, frame: int, command: int, params: list[float]) -> str:
    p = [number_text(v, 8) for v in params[:4]] + [number_text(v, 9) for v in params[4:6]] + [number_text(params[6], 4)]
    return "\t".join([str(seq), str(current), str(frame), str(command), *p, "1"])


def wpl_text(flight: Flight, waypoints, autopilot: Autopilot | None = None, gimbal=None) -> str:
    """The file of one mission for ``autopilot`` (default ArduPilot)."""
    autopilot = resolve_autopilot(autopilot, DEFAULT_AUTOPILOT)
    lines = ["QGC WPL 110",
             _line(0, 1, FRAME_GLOBAL, NAV_WAYPOINT,
                   [0, 0, 0, 0, flight.takeoff_latitude_deg, flight.takeoff_longitude_deg, flight.takeoff_height_m])]
    for seq, it in enumerate(mission_items(flight, waypoints, autopilot, gimbal), start=1):
        lines.append(_line(seq, 0, it["frame"], it["command"], it["params"]))
    return "\n".join(lines) + "\n"


def write_wpl(flight: Flight, path: Path, autopilot: Autopilot | None = None, gimbal=None) -> list[Path]:
    """One ``.waypoints`` file per mission for ``autopilot`` (default ArduPilot)."""
    autopilot = resolve_autopilot(autopilot, DEFAULT_AUTOPILOT)
    return write_missions(flight, path, lambda wps: wpl_text(flight, wps, autopilot, gimbal))


def _write(flight: Flight, path: Path, target: Target) -> list[Path]:
    return write_wpl(flight, path, target.autopilot, target.gimbal)


FORMAT = FlightFormat(name="wpl", label="QGC WPL", order=20, read=_read, suffixes=(".waypoints", ".txt"), sniff=sniff,
                      what="a QGC WPL 110 waypoint file", uses_camera=True,
                      write=_write, suffix=".waypoints", media_type="text/plain", autopilot=DEFAULT_AUTOPILOT,
                      per_mission=True, pitch_range=(-90.0, 90.0), title="QGC WPL 110 waypoints",
                      help="QGC WPL 110 for Mission Planner")
