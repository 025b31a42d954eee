"""Exports of a plan to flight apps and maps: :func:`export_plan`.

Formats (:data:`EXPORT_FORMATS`):

- ``qgc``: QGroundControl ``.plan`` (:mod:`.qgc`), one file per mission, for PX4 or ArduPilot;
- ``wpl``: ``QGC WPL 110`` waypoints text (:mod:`.wpl`), one file per mission, for ArduPilot or PX4;
- ``wpml``: DJI WPML ``.kmz`` (:mod:`.wpml`), one wayline per mission;
- ``litchi``: Litchi mission CSV (:mod:`.litchi`), one file per mission and per 99 waypoints;
- ``kml`` and ``geojson``: paths, waypoints and footprints of all missions (:mod:`.kml`).

All share :func:`~sightplan.export.common.build_flight`: frames at one place become one waypoint
with several photo actions, headings are true headings, altitudes are above the take-off point.
"""

from __future__ import annotations

from pathlib import Path
from typing import Literal, get_args

from numpy.typing import ArrayLike

from ..errors import PlanError
from ..geo import Georeference
from ..plan.types import Plan
from .common import Flight, Photo, Waypoint, build_flight
from .kml import write_geojson, write_kml
from .litchi import write_litchi
from .qgc import AUTOPILOT_LABELS, AUTOPILOTS, DEFAULT_AUTOPILOT, Autopilot, resolve_autopilot, write_qgc
from .wpl import write_wpl
from .wpml import write_wpml

ExportFormat = Literal["qgc", "wpl", "wpml", "litchi", "kml", "geojson"]
EXPORT_FORMATS: tuple[str, ...] = get_args(ExportFormat)
EXTENSIONS = {"qgc": ".plan", "wpl": ".waypoints", "wpml": ".kmz", "litchi": ".csv", "kml": ".kml", "geojson": ".geojson"}
_WRITERS = {"qgc": write_qgc, "wpl": write_wpl, "wpml": write_wpml, "litchi": write_litchi, "kml": write_kml,
            "geojson": write_geojson}
MAVLINK_FORMATS = ("qgc", "wpl")  # the formats written for one autopilot (``autopilot=``)


def file_summary(fmt: str, autopilot: str | None = None) -> str:
    """What a file of format ``fmt`` is for, e.g. "QGroundControl plan for PX4" (the autopilot for MAVLink formats)."""
    from .common import FORMAT_LABELS

    what = {"qgc": "QGroundControl plan", "wpl": "QGC WPL 110 waypoints"}.get(fmt, FORMAT_LABELS.get(fmt, fmt))
    if fmt in MAVLINK_FORMATS:
        return f"{what} for {AUTOPILOT_LABELS[resolve_autopilot(fmt, autopilot)]}"
    return what


def export_plan(plan: Plan, fmt: ExportFormat, path: str | Path, georef: Georeference, takeoff_m: ArrayLike,
                speed_m_s: float = 5.0, mission: int | None = None, autopilot: Autopilot | None = None) -> list[Path]:
    """Write ``plan`` for a flight app or a map; returns the files written.

    georef: where the model frame lies on the Earth. takeoff_m: (3,) model-frame take-off (home)
    point on the ground; altitudes are measured from it. speed_m_s: flight speed between waypoints.
    mission: index (from 0) into ``plan.missions`` of the only mission to write, to ``path`` itself;
    all missions when None (file names number them from 1: ``stem_m01``…).
    autopilot: for ``qgc`` and ``wpl``, the flight controller the file is for, ``"px4"`` or
    ``"ardupilot"`` (they accept different commands and frames; see :mod:`.qgc`); None: PX4 for
    ``qgc``, ArduPilot for ``wpl`` (:data:`DEFAULT_AUTOPILOT`). Ignored by the other formats.
    Raises :class:`~sightplan.errors.PlanError` naming the frames a drone cannot take in that
    format (gimbal pitch out of range, a rolled camera).
    """
    if fmt not in _WRITERS:
        raise PlanError(f"unknown export format {fmt!r}; expected one of {', '.join(EXPORT_FORMATS)}")
    if fmt in MAVLINK_FORMATS:
        autopilot = resolve_autopilot(fmt, autopilot)
    path = Path(path)
    if not path.parent.is_dir():
        raise PlanError(f"cannot write {path}: the folder {path.parent} does not exist")
    flight = build_flight(plan, georef, takeoff_m, fmt=fmt, speed_m_s=speed_m_s, mission=mission)
    try:
        if fmt in MAVLINK_FORMATS:
            return _WRITERS[fmt](flight, path, autopilot)
        return _WRITERS[fmt](flight, path)
    except OSError as exc:
        raise PlanError(f"cannot write {path}: {exc.strerror or exc}") from None


__all__ = ["AUTOPILOTS", "DEFAULT_AUTOPILOT", "EXPORT_FORMATS", "EXTENSIONS", "MAVLINK_FORMATS", "Autopilot", "ExportFormat",
           "Flight", "Photo", "Waypoint", "build_flight", "export_plan", "file_summary"]
