"""Litchi mission CSV, written (the table Litchi Mission Hub imports and exports).

Header: ``latitude,longitude,altitude(m),heading(deg),curvesize(m),rotationdir,gimbalmode,
gimbalpitchangle,actiontype1,actionparam1,…,actiontype15,actionparam15,altitudemode,speed(m/s),
poi_latitude,poi_longitude,poi_altitude(m),poi_altitudemode,photo_timeinterval,photo_distinterval``.

One row per Litchi waypoint: altitude above take-off (``altitudemode`` 0), heading 0..360 (the
first photo's true heading), curve size 0 (stop at the point), ``gimbalmode`` 2 (interpolate) with the
first photo's pitch. Actions (type, param): 1 take photo (0); 4 rotate aircraft (heading) and 5 tilt
camera (pitch) before each further photo whose heading or pitch differs; −1 (0) unused. A waypoint
needing more than 15 actions becomes several rows at the same place; Litchi takes at most 99
waypoints per mission, so longer missions are split into files ``stem_p1.csv``, ``stem_p2.csv``… (and
``stem_m01_p1.csv``… when the plan has several missions).

Litchi flies the waypoint headings only when the mission's Heading Mode is Custom, a mission
setting the CSV cannot carry: the export's summary says to set it. The file is for the DJI aircraft
that carries the plan's camera (:func:`litchi_aircraft`); its altitudes are above the take-off point.
"""

from __future__ import annotations

import csv
from pathlib import Path

from ..plan.types import Plan
from .base import FlightFormat, Target
from .flight import Flight, Waypoint, mission_paths, number_text, same_angle

MAX_ACTIONS = 15
MAX_WAYPOINTS = 99
STAY_FOR, TAKE_PHOTO, ROTATE_AIRCRAFT, TILT_CAMERA, NO_ACTION = 0, 1, 4, 5, -1
GIMBAL_SETTLE_S = 0.5  # the wait between a change of the gimbal's pitch and the photo
HEADER = (["latitude", "longitude", "altitude(m)", "heading(deg)", "curvesize(m)", "rotationdir", "gimbalmode",
           "gimbalpitchangle"]
          + [f"action{kind}{k}" for k in range(1, MAX_ACTIONS + 1) for kind in ("type", "param")]
          + ["altitudemode", "speed(m/s)", "poi_latitude", "poi_longitude", "poi_altitude(m)", "poi_altitudemode",
             "photo_timeinterval", "photo_distinterval"])


# catalogue camera id → the DJI aircraft that carries it
AIRCRAFT_OF_CAMERA = {"p4p": "DJI Phantom 4 Pro", "m3e": "DJI Mavic 3 Enterprise"}


def litchi_aircraft(plan: Plan) -> str:
    """The aircraft a Litchi file of ``plan`` is for: the one carrying the plan's camera."""
    from ..camera.catalogue import list_cameras

    by_name = {e.name: e.id for e in list_cameras()}
    names = []
    for cam in plan.cameras.values():
        name = str(getattr(cam, "name", "") or "")
        names.append(AIRCRAFT_OF_CAMERA.get(by_name.get(name, ""), f"the DJI aircraft carrying {name or 'the camera'}"))
    return ", ".join(dict.fromkeys(names))


def rows_of(waypoint: Waypoint, pitch: float | None = None) -> list[tuple[float, float, list[tuple[int, float]]]]:
    """(heading, pitch, actions) of each Litchi row needed for one waypoint (≤ 15 actions a row): a row flies
    to its first photo's heading and pitch; each further photo turns and tilts only where it differs. A photo after
    a change of the gimbal's pitch (from ``pitch``, the pitch before this waypoint; None: unknown) waits
    :data:`GIMBAL_SETTLE_S` first (a "stay for" action): Litchi runs a row's actions one after the other."""
    rows: list[tuple[float, float, list[tuple[int, float]]]] = []
    heading = 0.0
    settle = (STAY_FOR, GIMBAL_SETTLE_S * 1000.0)
    for photo in waypoint.photos:
        tilted = pitch is None or abs(photo.pitch_deg - pitch) > 1e-9
        if rows:
            extra: list[tuple[int, float]] = []
            if not same_angle(photo.heading_deg, heading):
                extra.append((ROTATE_AIRCRAFT, photo.heading_deg % 360.0))
            if tilted:
                extra += [(TILT_CAMERA, photo.pitch_deg), settle]
            extra.append((TAKE_PHOTO, 0.0))
            if len(rows[-1][2]) + len(extra) <= MAX_ACTIONS:
                rows[-1][2].extend(extra)
                heading, pitch = photo.heading_deg, photo.pitch_deg
                continue
        rows.append((photo.heading_deg, photo.pitch_deg, [settle, (TAKE_PHOTO, 0.0)] if tilted else [(TAKE_PHOTO, 0.0)]))
        heading, pitch = photo.heading_deg, photo.pitch_deg
    return rows


def _row(flight: Flight, wp: Waypoint, heading: float, pitch: float, actions: list[tuple[int, float]]) -> list[str]:
    cells = [number_text(wp.latitude_deg, 9), number_text(wp.longitude_deg, 9), number_text(wp.altitude_m, 4),
             number_text(heading % 360.0), "0", "0", "2", number_text(pitch)]
    for k in range(MAX_ACTIONS):
        kind, param = actions[k] if k < len(actions) else (NO_ACTION, 0.0)
        cells += [str(kind), number_text(param)]
    cells += ["0", number_text(flight.speed_m_s), "0", "0", "0", "0", "-1", "-1"]
    return cells


def write_litchi(flight: Flight, path: Path) -> list[Path]:
    groups = flight.by_mission()
    bases = mission_paths(path, [m for m, _ in groups], several=len(groups) > 1)
    written: list[Path] = []
    for m, wps in groups:
        rows, pitch = [], None
        for wp in wps:
            for h, p, acts in rows_of(wp, pitch):
                rows.append(_row(flight, wp, h, p, acts))
            pitch = wp.photos[-1].pitch_deg
        parts = [rows[k:k + MAX_WAYPOINTS] for k in range(0, len(rows), MAX_WAYPOINTS)]
        base = bases[m]
        for k, part in enumerate(parts, start=1):
            out = base if len(parts) == 1 else base.with_name(f"{base.stem}_p{k}{base.suffix}")
            with out.open("w", newline="", encoding="utf-8") as f:
                w = csv.writer(f, lineterminator="\n")
                w.writerow(HEADER)
                w.writerows(part)
            written.append(out)
    return written


def _prepare(plan: Plan, aircraft: str | None, speed_m_s: float) -> Target:
    return Target(aircraft=litchi_aircraft(plan))


def _write(flight: Flight, path: Path, target: Target) -> list[Path]:
    return write_litchi(flight, path)


FORMAT = FlightFormat(name="litchi", label="Litchi", order=40, write=_write, suffix=".csv", media_type="text/csv",
                      prepare=_prepare, per_mission=True, pitch_range=(-90.0, 30.0), help="CSV",
                      settings=("in Litchi set the mission's Heading Mode = Custom (the CSV cannot carry it; "
                                "Litchi ignores the headings otherwise)",))
