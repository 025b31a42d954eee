"""Visual line of sight to the ground station, and the altitude limit (FAA §107.51)."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from ...errors import PlanError
from ...model.scene import Scene
from ..types import Plan

LOS_TOLERANCE_M = 0.01
FAA_LIMIT_M = 120.0


@dataclass(frozen=True)
class LineOfSightReport:
    """ground_station: (3,) metres. distance_m: (n,) from it to each waypoint. in_range: (n,)
    within the VLOS radius. unblocked: (n,) nothing of the model on the sight line.
    mission_ok: one flag per mission. violations: readable list."""

    ground_station: NDArray[np.float64]
    radius_m: float
    distance_m: NDArray[np.float64]
    in_range: NDArray[np.bool_]
    unblocked: NDArray[np.bool_]
    mission_ok: tuple[bool, ...]
    violations: tuple[str, ...]


def default_ground_station(scene: Scene, plan: Plan, height_m: float = 1.5) -> NDArray[np.float64]:
    """The south-west corner of the plan's region (waypoints and the model's targets), ``height_m`` above the ground
    there (the terrain, else the model's base)."""
    from ..ground import ground_z, targets_only

    lo = np.minimum(plan.C_world.min(axis=0), targets_only(scene).bounds()[0])
    return np.array([lo[0], lo[1], float(ground_z(scene, lo[:2])[0]) + height_m])


def sight_lines(scene: Scene, points: NDArray, stations: NDArray, radius_m: float,
                engine: str = "auto") -> tuple[NDArray[np.float64], NDArray[np.bool_], NDArray[np.bool_]]:
    """(k, n) distance from each of k stations to each of n points, within ``radius_m``, and not hidden by the
    model (one engine casts every sight line)."""
    from ...engines import make_engine
    from ...engines.registry import ray_engine_name

    if not radius_m > 0:
        raise PlanError(f"the VLOS radius must be positive, got {radius_m}")
    P = np.asarray(points, float).reshape(-1, 3)
    S = np.asarray(stations, float).reshape(-1, 3)
    rel = P[None, :, :] - S[:, None, :]
    dist = np.linalg.norm(rel, axis=2)
    unblocked = np.ones(dist.shape, bool)
    away = dist > 0
    if away.any() and len(scene.faces):
        with make_engine(ray_engine_name(engine), scene, threads=1) as eng:
            d = (rel[away] / dist[away][:, None]).astype(np.float32)
            origin = np.broadcast_to(S[:, None, :], rel.shape)[away] - eng.centre
            hit = eng.hit_distance(origin.astype(np.float32), d)
        unblocked[away] = hit >= dist[away] - LOS_TOLERANCE_M
    return dist, dist <= radius_m, unblocked


def check_line_of_sight(scene: Scene, plan: Plan, radius_m: float, ground_station: NDArray | None = None,
                        engine: str = "auto") -> LineOfSightReport:
    """A mission keeps VLOS when every waypoint is within ``radius_m`` and seen from the ground station."""
    gs = default_ground_station(scene, plan) if ground_station is None else np.asarray(ground_station, float).reshape(3)
    dist, in_range, unblocked = (a[0] for a in sight_lines(scene, plan.C_world, gs, radius_m, engine))
    violations = []
    for i in np.flatnonzero(~in_range):
        violations.append(f"waypoint {i} is {dist[i]:.0f} m from the ground station (VLOS radius {radius_m:g} m)")
    for i in np.flatnonzero(~unblocked):
        violations.append(f"waypoint {i} is hidden from the ground station by the model")
    ok = tuple(bool((in_range & unblocked)[m.start:m.stop].all()) for m in plan.missions)
    return LineOfSightReport(gs, float(radius_m), dist, in_range, unblocked, ok, tuple(violations))


@dataclass(frozen=True)
class AltitudeReport:
    """limit_z: (n,) highest allowed camera height (model frame, m) at each waypoint;
    over_m: (n,) metres above it (≤ 0 is fine)."""

    limit_z: NDArray[np.float64]
    over_m: NDArray[np.float64]
    violations: tuple[str, ...]


def check_altitude(scene: Scene, plan: Plan, limit_m: float = FAA_LIMIT_M,
                   ground_z: float | NDArray | None = None, error_v_m: float = 0.0) -> AltitudeReport:
    """FAA §107.51: at most ``limit_m`` above the ground, or above the structure's highest point within
    ``limit_m`` horizontally, when the aircraft strays ``error_v_m`` above its waypoint. The ground is the model's
    base unless ``ground_z`` says otherwise (one height, or one per waypoint)."""
    from scipy.spatial import cKDTree

    if not limit_m > 0:
        raise PlanError(f"the altitude limit must be positive, got {limit_m}")
    ground = scene.bounds()[0][2] if ground_z is None else np.asarray(ground_z, float)
    used = scene.vertices[np.unique(scene.faces)] if len(scene.faces) else np.zeros((0, 3))
    limit = np.full(len(plan), ground + limit_m)
    if len(used):
        xy, C = used[:, :2], plan.C_world[:, :2]
        # a waypoint within limit_m of the far corner of the vertices' box has every vertex in reach
        far = np.maximum(np.abs(C - xy.min(axis=0)), np.abs(C - xy.max(axis=0)))
        everything = np.hypot(far[:, 0], far[:, 1]) <= limit_m
        limit[everything] = np.maximum(limit[everything], used[:, 2].max() + limit_m)
        rest = np.flatnonzero(~everything)
        if len(rest):
            tree = cKDTree(xy)
            for i, near in zip(rest, tree.query_ball_point(C[rest], r=limit_m)):
                if near:
                    limit[i] = max(limit[i], used[near, 2].max() + limit_m)
    over = plan.C_world[:, 2] + float(error_v_m) - limit
    violations = tuple(f"waypoint {i} is {over[i]:.1f} m above the altitude limit" for i in np.flatnonzero(over > 1e-3))
    return AltitudeReport(limit, over, violations)
