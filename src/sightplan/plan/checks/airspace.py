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
    """The south-west corner of the plan's region (waypoints and model), ``height_m`` above the model's base."""
    lo = np.minimum(plan.C_world.min(axis=0), scene.bounds()[0])
    return np.array([lo[0], lo[1], scene.bounds()[0][2] + height_m])


def check_line_of_sight(scene: Scene, plan: Plan, radius_m: float, ground_station: NDArray | None = None,
                        engine: str = "auto") -> LineOfSightReport:
    """A mission keeps VLOS when every waypoint is within ``radius_m`` and seen from the ground station."""
    from ...engines import make_engine

    if not radius_m > 0:
        raise PlanError(f"the VLOS radius must be positive, got {radius_m}")
    gs = default_ground_station(scene, plan) if ground_station is None else np.asarray(ground_station, float).reshape(3)
    rel = plan.C_world - gs
    dist = np.linalg.norm(rel, axis=1)
    in_range = dist <= radius_m
    unblocked = np.ones(len(plan), bool)
    away = dist > 0
    if away.any() and len(scene.faces):
        with make_engine(engine, scene, threads=1) as eng:
            d = (rel[away] / dist[away, None]).astype(np.float32)
            origin = np.broadcast_to((gs - eng.centre).astype(np.float32), d.shape)
            hit = eng.hit_distance(origin, d)
        unblocked[away] = hit >= dist[away] - LOS_TOLERANCE_M
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


def check_altitude(scene: Scene, plan: Plan, limit_m: float = FAA_LIMIT_M, ground_z: float | None = None) -> AltitudeReport:
    """FAA §107.51: at most ``limit_m`` above the ground, or above the structure's highest point within
    ``limit_m`` horizontally. The ground is the model's base unless ``ground_z`` says otherwise."""
    from scipy.spatial import cKDTree

    if not limit_m > 0:
        raise PlanError(f"the altitude limit must be positive, got {limit_m}")
    ground = scene.bounds()[0][2] if ground_z is None else float(ground_z)
    used = scene.vertices[np.unique(scene.faces)] if len(scene.faces) else np.zeros((0, 3))
    limit = np.full(len(plan), ground + limit_m)
    if len(used):
        tree = cKDTree(used[:, :2])
        for i, near in enumerate(tree.query_ball_point(plan.C_world[:, :2], r=limit_m)):
            if near:
                limit[i] = max(limit[i], used[near, 2].max() + limit_m)
    over = plan.C_world[:, 2] - limit
    violations = tuple(f"waypoint {i} is {over[i]:.1f} m above the altitude limit" for i in np.flatnonzero(over > 0))
    return AltitudeReport(limit, over, violations)
