"""Safety distance: the true minimum distance from waypoints and flight segments to the model."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from ...errors import PlanError
from ...geometry.distance import min_point_distances, min_segment_distances
from ...model.scene import Scene
from ..types import Plan


@dataclass(frozen=True)
class SafetyReport:
    """waypoint_m: (n,) distance of each waypoint to the nearest triangle (m);
    segment_m: (n−1,) of each straight flight segment between consecutive waypoints of a
    mission (NaN between two missions: not flown as a segment, not checked);
    violations: human-readable list of what comes closer than ``minimum_m``."""

    minimum_m: float
    waypoint_m: NDArray[np.float64]
    segment_m: NDArray[np.float64]
    violations: tuple[str, ...]

    @property
    def ok(self) -> bool:
        return not self.violations


def _triangles(scene: Scene) -> tuple[NDArray, NDArray, NDArray]:
    """(F, 3, 3) triangles and their (F, 3) bounding boxes."""
    tri = np.ascontiguousarray(scene.vertices[scene.faces], dtype=np.float64)
    return tri, np.ascontiguousarray(tri.min(axis=1)), np.ascontiguousarray(tri.max(axis=1))


def point_distances(scene: Scene, points: NDArray) -> NDArray[np.float64]:
    """(n,) exact distance from each (n, 3) point to the scene's nearest triangle (inf for an empty scene)."""
    pts = np.ascontiguousarray(np.asarray(points, float).reshape(-1, 3))
    if len(scene.faces) == 0:
        return np.full(len(pts), np.inf)
    from scipy.spatial import cKDTree

    used = scene.vertices[np.unique(scene.faces)]
    nearest_vertex, _ = cKDTree(used).query(pts)  # the nearest vertex bounds the distance from above
    return min_point_distances(pts, *_triangles(scene), (nearest_vertex * (1 + 1e-9) + 1e-9) ** 2)


def segment_distances(scene: Scene, start: NDArray, end: NDArray) -> NDArray[np.float64]:
    """(m,) exact distance from each segment start[i]→end[i] to the nearest triangle (0 where it passes through)."""
    p = np.ascontiguousarray(np.asarray(start, float).reshape(-1, 3))
    q = np.ascontiguousarray(np.asarray(end, float).reshape(-1, 3))
    if len(scene.faces) == 0:
        return np.full(len(p), np.inf)
    ends = np.minimum(point_distances(scene, p), point_distances(scene, q))  # a segment is no farther than its ends
    return min_segment_distances(p, q, *_triangles(scene), (ends * (1 + 1e-9) + 1e-9) ** 2)


def check_safety(scene: Scene, plan: Plan, minimum_m: float) -> SafetyReport:
    """Distances of every waypoint (the frames' centres, in flight order) and every segment within a mission."""
    if not minimum_m > 0:
        raise PlanError(f"the safety distance must be positive, got {minimum_m}")
    C = plan.C_world
    wp = point_distances(scene, C)
    seg = np.full(max(len(C) - 1, 0), np.nan)
    inside = np.zeros(len(seg), bool)
    for m in plan.missions:
        inside[m.start:max(m.stop - 1, m.start)] = True
    if inside.any():
        idx = np.flatnonzero(inside)
        seg[idx] = segment_distances(scene, C[idx], C[idx + 1])
    violations = [f"waypoint {i} ({plan.frame_names[i]}) is {wp[i]:.2f} m from the model" for i in np.flatnonzero(wp < minimum_m)]
    violations += [f"segment {i}→{i + 1} passes {seg[i]:.2f} m from the model" for i in np.flatnonzero(seg < minimum_m)]
    return SafetyReport(float(minimum_m), wp, seg, tuple(violations))
