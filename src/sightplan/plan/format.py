"""sightplan's own plan file: JSON, format ``"sightplan-plan"``, version 1.

Layout (every axis and angle convention is the one of :mod:`sightplan.geometry.poses`)::

    {"format": "sightplan-plan", "version": 1, "units": "m", "frame_convention": "...",
     "cameras": {id: camera dict},                       # Camera.to_dict()
     "missions": [{"name": str, "frames": [start, stop],  # half-open frame ranges
                   "ground_station": [x, y, z]}],          # optional
     "frames": [{"name": str, "camera": id, "position": [x, y, z],
                 "rotation": [[r00, r01, r02], [r10, r11, r12], [r20, r21, r22]],  # R_world_camera rows
                 "time": seconds}],                      # optional, POSIX seconds
     "waypoints": [[x, y, z], ...], "parameters": {...}, "georeference": {...}}

On read a frame may give, instead of ``"rotation"``, gimbal angles ``"heading_deg"``,
``"pitch_deg"`` (and optional ``"roll_deg"``, default 0) or ``"quaternion_wxyz"``.
"""

from __future__ import annotations

import json
import math
from collections.abc import Callable
from pathlib import Path
from typing import Any

import numpy as np

from ..camera.models import Camera, camera_from_dict
from ..errors import CameraError, FormatVersionError, PlanError
from ..geometry.poses import R_from_gimbal, R_from_quaternion, check_rotations
from . import domain
from .types import Mission, Plan

FORMAT_NAME = "sightplan-plan"
FORMAT_VERSION = 1
FRAME_CONVENTION = (
    "world: the model's local frame, metres, +Z up, +Y north, +X east; rotation: R_world_camera, its columns are "
    "the camera's +X right, +Y down, +Z forward (OpenCV axes) in world coordinates; heading_deg clockwise from +Y "
    "seen from above, pitch_deg up from the horizon (-90 = nadir), roll_deg clockwise seen from behind the camera; "
    "quaternion_wxyz: Hamilton (w, x, y, z) of R_world_camera"
)
_GIMBAL_KEYS = ("heading_deg", "pitch_deg", "roll_deg")


# -- writing ---------------------------------------------------------------------------------


def _jsonable(value: Any) -> Any:
    if isinstance(value, np.ndarray):
        return value.tolist()
    if isinstance(value, np.generic):
        return value.item()
    raise TypeError(f"cannot write {type(value).__name__} to a plan file")


def plan_to_dict(plan: Plan) -> dict:
    """The plan as a JSON-ready dict in format version 1 (lossless for floats)."""
    params = dict(plan.parameters)
    georef = params.pop("georeference", None)
    frames = []
    for name, cam, pos, rot, t in zip(plan.frame_names.tolist(), plan.frame_camera.tolist(), plan.C_world.tolist(),
                                      plan.R_world_camera.tolist(), plan.capture_time.tolist()):
        frame = {"name": name, "camera": cam, "position": pos, "rotation": rot}
        if math.isfinite(t):
            frame["time"] = t
        frames.append(frame)
    out = {
        "format": FORMAT_NAME, "version": FORMAT_VERSION, "units": "m", "frame_convention": FRAME_CONVENTION,
        "cameras": {cid: cam.to_dict() for cid, cam in plan.cameras.items()},
        "missions": [{"name": m.name, "frames": [m.start, m.stop]}
                     | ({"ground_station": list(m.ground_station)} if m.ground_station is not None else {})
                     for m in plan.missions],
        "frames": frames,
        "waypoints": np.asarray(plan.waypoints, float).reshape(-1, 3).tolist(),
        "parameters": params,
    }
    if georef is not None:
        out["georeference"] = georef
    return out


def write_plan(plan: Plan, path: str | Path) -> None:
    """Write ``plan`` to ``path`` as a sightplan JSON plan (UTF-8)."""
    try:
        text = json.dumps(plan_to_dict(plan), indent=1, allow_nan=False, default=_jsonable, ensure_ascii=False)
    except (TypeError, ValueError) as exc:
        raise PlanError(f"plan parameters cannot be written as JSON: {exc}") from None
    try:
        Path(path).write_text(text + "\n", encoding="utf-8")
    except OSError as exc:
        raise PlanError(f"cannot write the plan to {path}: {exc.strerror or exc}") from None


# -- reading ---------------------------------------------------------------------------------


def _numbers(value: Any, shape: tuple[int, ...], where: str, field: str) -> np.ndarray:
    """``value`` as a float array of ``shape``; PlanError naming ``where`` and ``field`` otherwise."""
    try:
        arr = np.array(value, dtype=float)
        ok = arr.shape == shape and not _has_bool_or_str(value)
    except (TypeError, ValueError):
        ok = False
    if not ok:
        dims = "×".join(map(str, shape)) if shape else "a"
        raise PlanError(f"{where}: field {field!r} must be {dims} number{'s' if shape else ''}, got {value!r}")
    return arr


def _has_bool_or_str(value: Any) -> bool:
    if isinstance(value, (bool, str)):
        return True
    return isinstance(value, (list, tuple)) and any(_has_bool_or_str(v) for v in value)


def checked_rotations(R: np.ndarray, where: Callable[[int], str]) -> np.ndarray:
    """Validate (n, 3, 3) rotations; the error names the first bad one by ``where(i)``."""
    try:
        return check_rotations(R, what="rotation")
    except PlanError:
        for i in range(len(R)):
            try:
                check_rotations(R[i : i + 1], what="rotation")
            except PlanError as exc:
                reason = str(exc).removeprefix("rotation 0 has a rotation that is ").removeprefix("rotation 0 has ")
                raise PlanError(f"{where(i)}: the rotation is {reason}") from None
        raise


def quaternions_to_R(q: np.ndarray, where: Callable[[int], str]) -> np.ndarray:
    """(n, 3, 3) R_world_camera from (n, 4) quaternions (w, x, y, z); errors name ``where(i)``."""
    try:
        return R_from_quaternion(q)
    except PlanError:
        for i in range(len(q)):
            try:
                R_from_quaternion(q[i : i + 1])
            except PlanError:
                raise PlanError(f"{where(i)}: quaternion {q[i].tolist()} is not a unit quaternion "
                                f"(norm {np.linalg.norm(q[i]):.6g})") from None
        raise


def _orientation_kind(frame: dict, where: str) -> str:
    given = [k for k in ("rotation", "quaternion_wxyz") if k in frame]
    if "heading_deg" in frame or "pitch_deg" in frame:
        given.append("gimbal")
    if len(given) > 1:
        raise PlanError(f"{where}: give one orientation, got {' and '.join(given)}")
    if not given:
        raise PlanError(f"{where}: missing field 'rotation' (or 'heading_deg' + 'pitch_deg', or 'quaternion_wxyz')")
    return given[0]


def _cameras(d: dict) -> dict[str, Camera]:
    cams = d.get("cameras")
    if not isinstance(cams, dict) or not cams:
        raise PlanError("a plan needs a non-empty 'cameras' object (camera id → camera)")
    out = {}
    for cid, spec in cams.items():
        try:
            out[cid] = camera_from_dict(spec)
        except CameraError as exc:
            raise PlanError(f"camera {cid!r}: {exc}") from None
    return out


def _check_header(d: Any) -> None:
    if not isinstance(d, dict):
        raise PlanError(f"a sightplan plan is a JSON object, got a JSON {type(d).__name__}")
    if d.get("format") != FORMAT_NAME:
        raise PlanError(f"not a sightplan plan: field 'format' is {d.get('format')!r}, expected {FORMAT_NAME!r}")
    version = d.get("version")
    if isinstance(version, bool) or not isinstance(version, int):
        raise PlanError(f"field 'version' must be a whole number, got {version!r}")
    if version > FORMAT_VERSION:
        raise FormatVersionError(
            f"written by a newer sightplan: format version {version}, this one reads up to {FORMAT_VERSION}")
    if version < 1:
        raise PlanError(f"field 'version' must be ≥ 1, got {version}")
    if d.get("units", "m") != "m":
        raise PlanError(f"field 'units' must be 'm', got {d.get('units')!r}")


def plan_from_dict(d: dict) -> Plan:
    """Inverse of :func:`plan_to_dict`; raises PlanError / FormatVersionError naming the frame and field."""
    _check_header(d)
    cameras = _cameras(d)
    frames = d.get("frames")
    if not isinstance(frames, list):
        raise PlanError(f"field 'frames' must be a list, got {type(frames).__name__}")
    n = len(frames)
    if n > domain.MAX_PLAN_FRAMES:
        raise PlanError(f"field 'frames': {n:,} frames, more than the {domain.MAX_PLAN_FRAMES:,} a plan may have")
    names, cams, times = [], [], np.full(n, np.nan)
    C, R = np.zeros((n, 3)), np.zeros((n, 3, 3))
    kinds = np.empty(n, dtype=object)
    quats, gimbal = np.zeros((n, 4)), np.zeros((n, 3))
    for i, f in enumerate(frames):
        if not isinstance(f, dict):
            raise PlanError(f"frame {i}: must be an object, got {type(f).__name__}")
        name = f.get("name", f"frame_{i:05d}")
        if not isinstance(name, str):
            raise PlanError(f"frame {i}: field 'name' must be a string, got {name!r}")
        where = f"frame {i} ({name!r})"
        cam = f.get("camera", next(iter(cameras)) if len(cameras) == 1 else None)
        if cam is None:
            raise PlanError(f"{where}: missing field 'camera' (the plan defines several cameras)")
        if cam not in cameras:
            raise PlanError(f"{where}: unknown camera {cam!r}; the plan defines {', '.join(map(repr, cameras))}")
        if "position" not in f:
            raise PlanError(f"{where}: missing field 'position'")
        C[i] = _numbers(f["position"], (3,), where, "position")
        domain.check_points(C[i], where)
        kinds[i] = _orientation_kind(f, where)
        if kinds[i] == "rotation":
            R[i] = _numbers(f["rotation"], (3, 3), where, "rotation")
        elif kinds[i] == "quaternion_wxyz":
            quats[i] = _numbers(f["quaternion_wxyz"], (4,), where, "quaternion_wxyz")
        else:
            for j, key in enumerate(_GIMBAL_KEYS):
                if key not in f and key != "roll_deg":
                    raise PlanError(f"{where}: missing field {key!r} (gimbal angles need heading_deg and pitch_deg)")
                gimbal[i, j] = domain.angle(f"{where}: field {key!r}", _numbers(f.get(key, 0.0), (), where, key))
        if f.get("time") is not None:
            times[i] = domain.capture_time(f"{where}: field 'time'", _numbers(f["time"], (), where, "time"))
        names.append(name)
        cams.append(cam)
    where_i = lambda i: f"frame {i} ({names[i]!r})"  # noqa: E731
    is_q, is_g = kinds == "quaternion_wxyz", kinds == "gimbal"
    if is_q.any():
        idx = np.flatnonzero(is_q)
        R[idx] = quaternions_to_R(quats[idx], lambda k: where_i(idx[k]))
    if is_g.any():
        idx = np.flatnonzero(is_g)
        R[idx] = R_from_gimbal(*gimbal[idx].T)
    checked_rotations(R, where_i)
    return Plan.build(cameras, R, C, frame_camera=cams, frame_names=names, capture_time=times,
                      missions=_missions(d, n), waypoints=_waypoints(d), parameters=_parameters(d))


def _missions(d: dict, n: int) -> tuple[Mission, ...]:
    raw = d.get("missions")
    if raw is None:
        return (Mission("mission 1", 0, n),)
    if not isinstance(raw, list):
        raise PlanError(f"field 'missions' must be a list, got {type(raw).__name__}")
    out = []
    for i, m in enumerate(raw):
        if not isinstance(m, dict) or not isinstance(m.get("name"), str) or "frames" not in m:
            raise PlanError(f"mission {i}: needs 'name' (a string) and 'frames' ([start, stop])")
        span = m["frames"]
        if not (isinstance(span, list) and len(span) == 2 and all(type(v) is int for v in span)):
            raise PlanError(f"mission {i} ({m['name']!r}): field 'frames' must be [start, stop] whole numbers, got {span!r}")
        station = m.get("ground_station")
        if station is not None:
            station = tuple(_numbers(station, (3,), f"mission {i}", "ground_station").tolist())
            domain.check_points(station, f"mission {i}", "ground_station")
        out.append(Mission(m["name"], span[0], span[1], station))
    return tuple(out)


def _waypoints(d: dict) -> np.ndarray:
    raw = d.get("waypoints", [])
    if not isinstance(raw, list):
        raise PlanError(f"field 'waypoints' must be a list of [x, y, z], got {type(raw).__name__}")
    w = _numbers(raw, (len(raw), 3), "plan", "waypoints") if raw else np.zeros((0, 3))
    return domain.check_points(w, lambda i: f"waypoint {i}", "waypoints")


def _parameters(d: dict) -> dict:
    params = d.get("parameters", {})
    if not isinstance(params, dict):
        raise PlanError(f"field 'parameters' must be an object, got {type(params).__name__}")
    params = dict(params)
    if d.get("georeference") is not None:
        if not isinstance(d["georeference"], dict):
            raise PlanError("field 'georeference' must be an object")
        params["georeference"] = d["georeference"]
    return params


def read_json(path: str | Path) -> Any:
    """The parsed JSON content of ``path``; PlanError when unreadable or not JSON."""
    try:
        text = Path(path).read_text(encoding="utf-8")
    except (OSError, UnicodeDecodeError) as exc:
        raise PlanError(f"cannot read {path}: {exc}") from None
    try:
        return json.loads(text)
    except json.JSONDecodeError as exc:
        raise PlanError(f"{path} is not JSON: {exc.msg} at line {exc.lineno}, column {exc.colno}") from None
    except RecursionError:
        raise PlanError(f"{path} is not a plan: its JSON is nested too deeply to read") from None


def read_plan(path: str | Path) -> Plan:
    """Read a sightplan JSON plan written by :func:`write_plan` (or by hand)."""
    return plan_from_dict(read_json(path))
