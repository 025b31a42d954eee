"""Indoor route: a walked polyline sampled at a fixed step, for 360° or perspective cameras."""

from __future__ import annotations

import csv
import json
import math
from dataclasses import dataclass
from pathlib import Path

import numpy as np
from numpy.typing import ArrayLike

from ...camera.models import Camera
from ...errors import PlanError
from ...geometry.poses import R_from_gimbal
from ...model.scene import Scene
from ..domain import MAX_DISTANCE_M
from ..types import Mission, Plan
from .base import Params, Template, param
from .spacing import check_frame_budget

MAX_ROUTES = 1000  # one mission each


def indoor_route(camera: Camera, points_m: ArrayLike, step_m: float, pitch_deg: float = 0.0) -> Plan:
    """Frames every ``step_m`` along the (k, 3) polyline ``points_m`` (model frame, metres), its ends included.

    Each frame faces along the route (heading of the segment it lies on); for a 360° camera
    that only sets where the panorama's seam falls.
    """
    P = np.asarray(points_m, float)
    if P.ndim != 2 or P.shape[1] != 3 or len(P) < 2 or not np.isfinite(P).all():
        raise PlanError("an indoor route needs at least two finite (x, y, z) points")
    if not step_m > 0:
        raise PlanError(f"the step along the route must be positive, got {step_m}")
    seg = np.diff(P, axis=0)
    seg_len = np.linalg.norm(seg, axis=1)
    if (seg_len == 0).any():
        raise PlanError(f"route point {int(np.flatnonzero(seg_len == 0)[0]) + 1} repeats the one before it")
    total = seg_len.sum()
    check_frame_budget(total / step_m + 1, f"a step of {step_m:g} m along {total:,.1f} m of route", "step_m")
    n = int(np.ceil(total / step_m - 1e-9)) + 1
    s = np.linspace(0.0, total, n)
    ends = np.cumsum(seg_len)
    k = np.minimum(np.searchsorted(ends, s, side="left"), len(seg) - 1)
    start = ends[k] - seg_len[k]
    C = P[k] + seg[k] * ((s - start) / seg_len[k])[:, None]
    heading = np.degrees(np.arctan2(seg[k, 0], seg[k, 1])) % 360.0
    R = R_from_gimbal(heading, np.full(n, pitch_deg), 0.0)
    return Plan.build(camera, R, C, missions=(Mission("route", 0, n),), waypoints=P,
                      parameters={"template": "indoor_route", "step_m": float(step_m), "length_m": float(total)})


def indoor_routes(camera: Camera, polylines: list[ArrayLike], step_m: float, pitch_deg: float = 0.0,
                  names: list[str] | None = None) -> Plan:
    """Several walked polylines (e.g. one per storey), each sampled as :func:`indoor_route` and walked as one mission."""
    if not polylines:
        raise PlanError("give at least one route")
    names = names or [f"route {k + 1}" for k in range(len(polylines))]
    if len(names) != len(polylines):
        raise PlanError(f"{len(names)} route names for {len(polylines)} routes")
    if len(polylines) > MAX_ROUTES:
        raise PlanError(f"{len(polylines):,} routes, more than the {MAX_ROUTES:,} a plan takes")
    lengths = []
    for points in polylines:  # each route's own checks come below; here only the frames they would make
        try:
            P = np.asarray(points, float)
        except (TypeError, ValueError):
            P = np.zeros((0, 3))
        length = float(np.linalg.norm(np.diff(P, axis=0), axis=1).sum()) if P.ndim == 2 and len(P) > 1 else 0.0
        lengths.append(length if math.isfinite(length) else 0.0)
    if step_m > 0:
        check_frame_budget(sum(lengths) / step_m + len(polylines), f"a step of {step_m:g} m along "
                           f"{sum(lengths):,.1f} m of {len(polylines)} routes", "step_m")
    parts = []
    for k, points in enumerate(polylines):
        try:
            parts.append(indoor_route(camera, points, step_m, pitch_deg))
        except PlanError as exc:
            raise PlanError(f"{names[k]}: {exc}") from None
    C = np.concatenate([p.C_world for p in parts])
    R = np.concatenate([p.R_world_camera for p in parts])
    bounds = np.cumsum([0] + [len(p) for p in parts])
    missions = tuple(Mission(names[k], int(bounds[k]), int(bounds[k + 1])) for k in range(len(parts)))
    return Plan.build(camera, R, C, missions=missions, waypoints=np.concatenate([p.waypoints for p in parts]),
                      parameters={"template": "indoor_route", "step_m": float(step_m), "routes": len(parts),
                                  "length_m": float(sum(p.parameters["length_m"] for p in parts))})


def read_routes(path: str | Path) -> tuple[list[np.ndarray], list[str]]:
    """Polylines from a file: JSON ``[[[x, y, z], …], …]`` or ``{"name": [[x, y, z], …], …}``, or CSV with
    columns ``route, x, y, z`` (rows in walking order; a route is the rows sharing a name)."""
    path = Path(path)
    try:
        text = path.read_text(encoding="utf-8")
    except (OSError, UnicodeDecodeError) as exc:
        raise PlanError(f"cannot read the routes {path}: {exc}") from None
    if path.suffix.lower() == ".json":
        try:
            d = json.loads(text)
        except ValueError as exc:
            raise PlanError(f"{path.name} is not JSON: {exc}") from None
        items = list(d.items()) if isinstance(d, dict) else [(f"route {k + 1}", v) for k, v in enumerate(d or [])]
        try:
            return [np.asarray(v, float) for _, v in items], [str(k) for k, _ in items]
        except (TypeError, ValueError):
            raise PlanError(f"{path.name}: each route must be a list of [x, y, z] points in metres") from None
    rows = list(csv.DictReader(text.splitlines()))
    if not rows or not {"x", "y", "z"} <= set(rows[0]):
        raise PlanError(f"{path.name}: a routes CSV needs columns x, y, z (and route to hold several)")
    routes: dict[str, list] = {}
    for line, r in enumerate(rows, start=2):
        try:
            routes.setdefault(r.get("route") or "route 1", []).append([float(r["x"]), float(r["y"]), float(r["z"])])
        except (TypeError, ValueError):
            raise PlanError(f"{path.name}, line {line}: x, y, z must be numbers") from None
    return [np.asarray(v) for v in routes.values()], list(routes)


@dataclass(frozen=True)
class RouteParams(Params):
    points: tuple[tuple[float, float, float], ...] = param((), "the walked polyline, in order",
                                                           kind="points3", cli="point", label="Route")
    step_m: float | None = param(None, "metres between frames", gt=0, le=MAX_DISTANCE_M, cli="step", label="Step")
    routes_file: str | None = param(None, "polylines from a file (JSON: lists of x, y, z points; or CSV: route, x, y, z), one "
                                    "mission each, instead of the points", kind="file", cli="routes", web=False)


def _build(scene: Scene, camera: Camera, p: RouteParams, safety_distance_m: float, min_height_m: float) -> Plan:
    if (len(p.points) < 2 and p.routes_file is None) or p.step_m is None:
        raise PlanError("a route needs at least two points (x, y, z), or a routes file, and a step in metres")
    if p.routes_file is not None:
        polylines, names = read_routes(p.routes_file)
        return indoor_routes(camera, polylines, p.step_m, names=names)
    return indoor_route(camera, [list(q) for q in p.points], p.step_m)


TEMPLATE = Template("route", "indoor polyline, walked or driven", RouteParams, _build, walked=True, order=4)
