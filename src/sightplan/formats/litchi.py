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

Read (a ``.csv`` whose header starts ``latitude,longitude,altitude(m)``): a row per waypoint, flown in order, at the
row's heading (as with Heading Mode Custom) and gimbal pitch (``gimbalmode`` 2; 1: toward the row's point of
interest; 0: the pitch kept from before, −90° before any, with a warning). Its actions in order: rotate (4) and tilt
(5) set the heading and pitch of the photos (1) that follow; the others (stay, video) take none. A row with
``photo_distinterval`` (or ``photo_timeinterval`` at its speed) also takes a photo every that many metres on the way
to the next row, at its heading and pitch. A mission without any photo has a frame at every row (and says so in
``plan.parameters["warnings"]``). The camera is ``camera`` (the file names none).

A Litchi mission has no take-off point: its altitudes are above wherever the aircraft takes off. They are read above
the model's ground (``ground_z``, or a ``takeoff_z`` given) under the first waypoint, which becomes
``plan.parameters["takeoff_m"]``; without either, above the model's height 0 (with a warning). ``altitudemode`` 1
(above ground level) is read above the same ground. Without a georeference the frame is topocentric at the first
waypoint (model +Y north).
"""

from __future__ import annotations

import csv
import math
from pathlib import Path

import numpy as np
from numpy.typing import NDArray

from ..camera.models import Camera
from ..errors import PlanError
from ..geo import Georeference, GeoreferenceError
from ..geometry.poses import R_from_gimbal
from ..plan import domain
from ..plan.types import Mission, Plan
from .base import FlightFormat, ReadOptions, Source, Target
from .flight import SAME_POSITION_M, Flight, Waypoint, mission_paths, number_text, same_angle
from .reading import DEFAULT_PITCH_DEG, DEFAULT_SPEED_M_S, given_camera, number_cell, place_takeoff

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


def rows_of(waypoint: Waypoint, pitch: float | None = None, settle_s: float = 0.5
            ) -> list[tuple[float, float, list[tuple[int, float]]]]:
    """(heading, pitch, actions) of each Litchi row needed for one waypoint (≤ 15 actions a row): a row flies
    to its first photo's heading and pitch; each further photo turns and tilts only where it differs. A photo after
    a change of the gimbal's pitch (from ``pitch``, the pitch before this waypoint; None: unknown) waits
    ``settle_s`` first (a "stay for" action): Litchi runs a row's actions one after the other."""
    rows: list[tuple[float, float, list[tuple[int, float]]]] = []
    heading = 0.0
    settle = (STAY_FOR, round(settle_s * 1000.0))
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


def write_litchi(flight: Flight, path: Path, settle_s: float = GIMBAL_SETTLE_S) -> list[Path]:
    groups = flight.by_mission()
    bases = mission_paths(path, [m for m, _ in groups], several=len(groups) > 1)
    written: list[Path] = []
    for m, wps in groups:
        rows, pitch = [], None
        for wp in wps:
            for h, p, acts in rows_of(wp, pitch, settle_s):
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


# ---- reading -----------------------------------------------------------------------------------

HEADER_START = b"latitude,longitude,altitude(m)"
REQUIRED = ("latitude", "longitude", "altitude(m)")


def sniff(source: Source) -> bool:
    """Whether the file is a CSV whose header starts as Litchi's does."""
    return source.head().lstrip(b"\xef\xbb\xbf").lower().startswith(HEADER_START)


def _cell(row: dict, key: str, where: str, default: float) -> float:
    return number_cell(row.get(key), key, where, default)  # type: ignore[return-value]


def _rows(path: Path) -> list[tuple[str, dict]]:
    """(where, row) of every non-empty row of a Litchi CSV."""
    try:
        text = path.read_text(encoding="utf-8-sig")
    except OSError as exc:
        raise PlanError(f"cannot read {path}: {exc.strerror or exc}") from None
    except UnicodeDecodeError:
        raise PlanError(f"{path.name} is not a text file") from None
    reader = csv.DictReader(text.splitlines())
    header = [h.strip().lower() for h in reader.fieldnames or []]
    missing = [k for k in REQUIRED if k not in header]
    if missing:
        raise PlanError(f"{path.name} is not a Litchi mission: the header lacks {', '.join(missing)}")
    rows = []
    for row in reader:
        row = {str(k).strip().lower(): v for k, v in row.items() if k is not None}
        if any((v or "").strip() for v in row.values()):
            rows.append((f"{path.name}, line {reader.line_num}", row))
    if not rows:
        raise PlanError(f"{path.name}: the mission has no waypoint")
    return rows


def read_litchi(path: str | Path, georef: Georeference | None = None, camera: Camera | str | dict | None = None,
                ground_z: float | None = None, takeoff_z: float | None = None) -> Plan:
    """A plan from a Litchi mission CSV; see the module docstring (``ground_z``, ``takeoff_z``:
    :func:`~sightplan.plan.load.load_plan`)."""
    path = Path(path)
    rows = _rows(path)
    warnings: list[str] = []
    if camera is None:
        raise PlanError(f"{path.name}: a Litchi mission names no camera: say which camera took the photos with "
                        "--camera (camera=, e.g. 'm3e')")
    cam = given_camera(camera, path.name)
    lat, lon, alt = (np.array([_cell(r, k, w, math.nan) for w, r in rows]) for k in REQUIRED)
    for (where, _), a, b, c in zip(rows, lat, lon, alt):
        if not (math.isfinite(a) and math.isfinite(b) and math.isfinite(c)):
            raise PlanError(f"{where}: latitude, longitude and altitude(m) must be numbers")
        if not (-90 <= a <= 90 and -180 <= b <= 180):
            raise PlanError(f"{where}: latitude {a} / longitude {b} out of range")
        domain.height(f"{where}: altitude(m)", c)
    model = georef is not None
    try:
        if georef is None:
            georef = Georeference.from_origin(lat[0], lon[0], 0.0, 0.0, source=f"first waypoint of {path.name}")
        takeoff = place_takeoff(georef, lat[0], lon[0], None, model=model, ground_z=ground_z, takeoff_z=takeoff_z,
                                what="take-off point", warnings=warnings)
        agl = np.array([_cell(r, "altitudemode", w, 0.0) == 1 for w, r in rows])
        ground_h = takeoff.height_m if ground_z is None else georef.height_at(lat[0], lon[0], ground_z, takeoff.height_m)
        xyz = georef.from_geodetic(lat, lon, np.where(agl, ground_h, takeoff.height_m) + alt)
    except GeoreferenceError as exc:
        raise PlanError(f"{path.name}: {exc}") from None
    zero = {"ground": f"the model's ground (z {takeoff.xyz[2]:.2f} m)", "given": "the take-off height given",
            "zero": "the model's height 0"}[takeoff.source]
    warnings.append(f"a Litchi mission has no take-off point: its altitudes are read above {zero} under the first "
                    "waypoint")
    if agl.any():
        warnings.append(f"{int(agl.sum())} waypoint(s) above ground level (altitudemode 1): read above the model's ground "
                        "under the first waypoint")
    frames = _fly(rows, georef, xyz, takeoff.height_m, warnings)
    C = np.array([f[0] for f in frames])
    heading = np.array([f[1] for f in frames])
    if len(frames):
        heading = georef.model_heading(C, heading)
    R = R_from_gimbal(heading, [f[2] for f in frames], 0.0)
    waypoints = [xyz[0]]
    for p in xyz[1:]:
        if np.linalg.norm(p - waypoints[-1]) > SAME_POSITION_M:
            waypoints.append(p)
    params = {"source": {"format": "litchi", "path": str(path)}, "georeference": georef.to_dict(),
              "takeoff_m": [float(v) for v in takeoff.xyz], "home": takeoff.to_dict(), "warnings": warnings}
    cid = cam.name or "camera"
    return Plan.build({cid: cam}, R, C, frame_names=[f[3] for f in frames],
                      missions=(Mission(path.stem, 0, len(frames)),), waypoints=np.array(waypoints),
                      parameters=params)


def _fly(rows: list[tuple[str, dict]], georef: Georeference, xyz: NDArray, takeoff_h: float, warnings: list[str]
         ) -> list[tuple[NDArray, float, float, str]]:
    """(position, true heading, pitch, name) of every photo of the rows (see the module docstring); ``takeoff_h``:
    the take-off height the altitudes are above."""
    shooting = any(_cell(r, f"actiontype{k}", w, -1.0) == TAKE_PHOTO for w, r in rows for k in range(1, MAX_ACTIONS + 1)) \
        or any(_cell(r, key, w, -1.0) > 0 for w, r in rows for key in ("photo_distinterval", "photo_timeinterval"))
    if not shooting:
        warnings.append("the mission has no photo action (actiontype 1) nor photo interval: a frame is made at every "
                        "waypoint")
    frames: list[tuple[NDArray, float, float, str]] = []
    pitch: float | None = None
    assumed = 0
    counts = [0] * len(rows)

    def shoot(n: int, at: NDArray, heading: float) -> None:
        nonlocal assumed
        if pitch is None:
            assumed += 1
        counts[n] += 1
        p = DEFAULT_PITCH_DEG if pitch is None else pitch
        frames.append((np.array(at, float), heading, float(np.clip(p, -90.0, 90.0)), f"row{n + 1:03d}_{counts[n]}"))

    for n, (where, row) in enumerate(rows):
        P = xyz[n]
        heading = _cell(row, "heading(deg)", where, 0.0) % 360.0
        mode = _cell(row, "gimbalmode", where, 0.0)
        if mode == 2:
            pitch = _cell(row, "gimbalpitchangle", where, pitch if pitch is not None else DEFAULT_PITCH_DEG)
        elif mode == 1:
            poi = [_cell(row, k, where, 0.0) for k in ("poi_latitude", "poi_longitude", "poi_altitude(m)")]
            if poi[0] or poi[1]:
                q = georef.from_geodetic(poi[0], poi[1], takeoff_h + poi[2])[0]
                pitch = math.degrees(math.atan2(q[2] - P[2], max(math.hypot(*(q[:2] - P[:2])), 1e-9)))
        for k in range(1, MAX_ACTIONS + 1):
            kind, param = _cell(row, f"actiontype{k}", where, -1.0), _cell(row, f"actionparam{k}", where, 0.0)
            if kind == ROTATE_AIRCRAFT:
                heading = param % 360.0
            elif kind == TILT_CAMERA:
                pitch = param
            elif kind == TAKE_PHOTO:
                shoot(n, P, heading)
        if not shooting:
            shoot(n, P, heading)
        if n + 1 < len(rows):  # the photos of an interval on the way to the next row
            step = _cell(row, "photo_distinterval", where, -1.0)
            if step <= 0:
                seconds = _cell(row, "photo_timeinterval", where, -1.0)
                speed = _cell(row, "speed(m/s)", where, 0.0)
                step = seconds * (speed if speed > 0 else DEFAULT_SPEED_M_S) if seconds > 0 else -1.0
            leg = xyz[n + 1] - P
            length = float(np.linalg.norm(leg))
            s = step
            if step > 0:
                domain.check_work(len(frames) + max(length - SAME_POSITION_M - step, 0.0) / step + 1,
                                  domain.MAX_MISSION_PHOTOS, f"{where}: a photo every {step:g} m", "the photo interval",
                                  "photos")
            while step > 0 and s < length - SAME_POSITION_M:
                shoot(n, P + s / length * leg, heading)
                s += step
    if assumed:
        warnings.append(f"no gimbal pitch before {assumed} photo(s) (gimbalmode 0): {DEFAULT_PITCH_DEG:g}° (nadir) "
                        "assumed")
    return frames


def _read(source: Source, options: ReadOptions) -> Plan:
    return read_litchi(source.path, georef=options.georef, camera=options.camera, ground_z=options.ground_z,
                       takeoff_z=options.takeoff_z)


# ---- writing -----------------------------------------------------------------------------------


def _prepare(plan: Plan, aircraft: str | None, speed_m_s: float) -> Target:
    return Target(aircraft=litchi_aircraft(plan))


def _write(flight: Flight, path: Path, target: Target) -> list[Path]:
    return write_litchi(flight, path, GIMBAL_SETTLE_S if target.gimbal is None else target.gimbal.settle_s)


FORMAT = FlightFormat(name="litchi", label="Litchi", order=40, read=_read, suffixes=(".csv",), sniff=sniff,
                      what="a Litchi mission (header 'latitude,longitude,altitude(m),…')", uses_camera=True,
                      write=_write, suffix=".csv", media_type="text/csv",
                      prepare=_prepare, per_mission=True, pitch_range=(-90.0, 30.0), help="CSV",
                      settings=("in Litchi set the mission's Heading Mode = Custom (the CSV cannot carry it; "
                                "Litchi ignores the headings otherwise)",))
