"""Poses from a CSV table (one row per frame, header row first).

Columns (case-insensitive; comma, semicolon or tab separated):

- ``name`` (aliases ``image``, ``filename``): the frame's name;
- ``x``, ``y``, ``z``: the camera centre in metres, model frame;
- one orientation set: ``heading_deg``, ``pitch_deg`` and optional ``roll_deg`` (aliases
  ``yaw``/``yaw_deg``/``heading``, ``pitch``, ``roll``; conventions of
  :mod:`sightplan.geometry.poses`), or ``qw``, ``qx``, ``qy``, ``qz`` (R_world_camera);
- optional ``camera``: a catalogue name per row (empty: the caller's camera);
- optional ``time`` (alias ``timestamp``): POSIX seconds or ISO 8601 (UTC unless it says).
"""

from __future__ import annotations

import csv
import io
from dataclasses import replace
from datetime import UTC, datetime
from pathlib import Path

import numpy as np

from ..camera.catalogue import get_camera
from ..camera.files import parse_camera_spec
from ..camera.models import Camera
from ..errors import CameraError, PlanError
from ..geometry.poses import R_from_gimbal
from ..plan import domain
from ..plan.format import checked_rotations, quaternions_to_R
from ..plan.types import Plan
from .base import FlightFormat, ReadOptions, Source

_ALIASES = {
    "name": ("name", "image", "filename", "image_name", "file"),
    "x": ("x", "x_m"), "y": ("y", "y_m"), "z": ("z", "z_m"),
    "heading": ("heading_deg", "heading", "yaw_deg", "yaw"),
    "pitch": ("pitch_deg", "pitch"),
    "roll": ("roll_deg", "roll"),
    "qw": ("qw",), "qx": ("qx",), "qy": ("qy",), "qz": ("qz",),
    "camera": ("camera",),
    "time": ("time", "timestamp", "capture_time"),
}


def _columns(header: list[str], path: str) -> dict[str, int]:
    """Canonical column → index; PlanError when a required column is missing or doubled."""
    norm = [h.strip().lower() for h in header]
    cols: dict[str, int] = {}
    for key, names in _ALIASES.items():
        hits = [i for i, h in enumerate(norm) if h in names]
        if len(hits) > 1:
            raise PlanError(f"{path}: columns {', '.join(header[i] for i in hits)} all mean {key!r}")
        if hits:
            cols[key] = hits[0]
    missing = [k for k in ("name", "x", "y", "z") if k not in cols]
    if missing:
        raise PlanError(f"{path}: missing column(s) {', '.join(missing)}; the header is {header}")
    angles, quat = {"heading", "pitch"} & set(cols), {"qw", "qx", "qy", "qz"} & set(cols)
    if angles and quat:
        raise PlanError(f"{path}: give gimbal angles or a quaternion, not both")
    if len(angles) == 1 or 0 < len(quat) < 4:
        raise PlanError(f"{path}: incomplete orientation columns: need heading_deg + pitch_deg (+ roll_deg) or qw, qx, qy, qz")
    if not angles and not quat:
        raise PlanError(f"{path}: no orientation columns: need heading_deg + pitch_deg (+ roll_deg) or qw, qx, qy, qz")
    return cols


def _time(text: str, where: str) -> float:
    if not text:
        return np.nan
    try:
        return float(text)
    except ValueError:
        pass
    try:
        t = datetime.fromisoformat(text)
    except ValueError:
        raise PlanError(f"{where}: time {text!r} is neither seconds nor an ISO 8601 date") from None
    return (t if t.tzinfo else t.replace(tzinfo=UTC)).timestamp()


def read_csv_plan(path: str | Path, *, camera: Camera | str | dict | None = None) -> Plan:
    """A plan from a pose CSV; ``camera`` is used for rows without a ``camera`` value."""
    path = Path(path)
    try:
        text = path.read_text(encoding="utf-8-sig")
    except (OSError, UnicodeDecodeError) as exc:
        raise PlanError(f"cannot read {path}: {exc}") from None
    try:
        dialect = csv.Sniffer().sniff(text.split("\n", 1)[0], delimiters=",;\t")
    except csv.Error:
        dialect = csv.excel
    reader = csv.reader(io.StringIO(text), dialect)
    header = next(reader, None)
    if not header:
        raise PlanError(f"{path}: empty file, expected a header row")
    cols = _columns(header, str(path))
    default = parse_camera_spec(camera) if camera is not None else None
    default_id = (default.name or "camera") if default is not None else None
    has_q = "qw" in cols
    orient_keys = ("qw", "qx", "qy", "qz") if has_q else ("heading", "pitch", "roll")
    cameras: dict[str, Camera] = {default_id: default} if default is not None else {}
    names, cams, lines, pos, orient, times = [], [], [], [], [], []
    for row in reader:
        if not any(cell.strip() for cell in row):
            continue
        where = f"{path.name}, line {reader.line_num}"
        if len(row) < len(header):
            row = row + [""] * (len(header) - len(row))

        def number(key: str, default: float | None = None, row=row, where=where) -> float:
            cell = row[cols[key]].strip() if key in cols else ""
            if not cell and default is not None:
                return default
            try:
                return float(cell)
            except ValueError:
                raise PlanError(f"{where}, column {header[cols[key]]!r}: {cell!r} is not a number") from None

        cam = row[cols["camera"]].strip() if "camera" in cols else ""
        if not cam:
            if default_id is None:
                raise PlanError(f"{where}: no camera: fill the 'camera' column or pass camera=")
            cam = default_id
        elif cam not in cameras:
            try:
                cameras[cam] = get_camera(cam)
            except CameraError as exc:
                raise PlanError(f"{where}, column 'camera': {exc}") from None
        names.append(row[cols["name"]].strip())
        cams.append(cam)
        lines.append(where)
        pos.append([number("x"), number("y"), number("z")])
        orient.append([number(k, 0.0 if k == "roll" else None) for k in orient_keys])
        times.append(_time(row[cols["time"]].strip(), where) if "time" in cols else np.nan)
    if not names:
        raise PlanError(f"{path}: no frames after the header")
    C, O = np.array(pos), np.array(orient)
    bad = np.flatnonzero(~np.isfinite(C).all(axis=1) | ~np.isfinite(O).all(axis=1))
    if len(bad):
        raise PlanError(f"{lines[bad[0]]}: position or orientation is not finite")
    domain.check_points(C, lines.__getitem__, "x, y, z")
    domain.check_times(times, lines.__getitem__)
    i = None if has_q else domain.first_bad(O, -domain.MAX_ANGLE_DEG, domain.MAX_ANGLE_DEG)
    if i is not None:
        for key, v in zip(orient_keys, O[i]):
            domain.angle(f"{lines[i]}, {key}", v)
    R = quaternions_to_R(O, lines.__getitem__) if has_q else R_from_gimbal(*O.T)
    checked_rotations(R, lines.__getitem__)
    return Plan.build(cameras, R, C, frame_camera=cams, frame_names=names, capture_time=np.array(times),
                      parameters={"source": {"format": "csv", "path": str(path)}})


def in_capture_order(plan: Plan) -> Plan:
    """A flown capture with a time on every frame, sorted by it (tracks follow capture time, METRICS.md §5.3)."""
    t = plan.capture_time
    if len(t) < 2 or not np.isfinite(t).all() or np.all(np.diff(t) >= 0):
        return plan
    order = np.argsort(t, kind="stable")
    params = dict(plan.parameters)
    params["warnings"] = [*params.get("warnings", []), "frames were not in capture-time order: sorted by time"]
    return replace(plan.subset(order), parameters=params)


def _read(source: Source, options: ReadOptions) -> Plan:
    return in_capture_order(read_csv_plan(source.path, camera=options.camera))


FORMAT = FlightFormat(name="csv", label="poses CSV", order=2, read=_read, suffixes=(".csv",), uses_camera=True)
