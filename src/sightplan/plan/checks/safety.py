"""Safety distance: the true minimum distance from waypoints and flight segments to the model, and what is left of
it when the aircraft strays by its position error.

**Position error** (``(h, v)`` metres: how far the aircraft may stand off its planned point horizontally and
vertically; :data:`POSITION_ERROR`). The aircraft is somewhere in a cylinder of radius h and half-height v around
the planned point (or segment). Its worst-case clearance is the nominal distance d less the cylinder's reach along
the distance's gradient n (the unit direction away from the nearest surface, found by central differences of the
exact distance): d − (h·|n_xy| + v·|n_z|). That is exact for a plane (a wall, a roof) and a lower bound for any
convex obstacle (the distance to a convex set is a convex function of the position); at an inside corner it is
the reach toward the nearer surface.

**One tolerance** (:data:`CHECK_TOLERANCE_M`): a clearance passes when it is at least the minimum less 1 mm, so a
point placed at the minimum by arithmetic does not fail on rounding. Templates place their frames
:data:`PLACEMENT_MARGIN_M` beyond the safety distance plus the position error's reach (:func:`placement_distance`).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from ...errors import PlanError
from ...geometry.distance import min_point_distances, min_segment_distances
from ...model.scene import Scene
from ..types import Plan

CHECK_TOLERANCE_M = 1e-3  # every flight check's comparison: a value passes when ≥ its minimum − 1 mm
PLACEMENT_MARGIN_M = 0.01  # templates place frames this far beyond the safety distance plus the position error
_STEP_M = 1e-3  # the central differences' step

#: Position error presets (horizontal, vertical) in metres: how far a multirotor holds off its planned point.
#: ``gnss``: DJI's published hovering accuracy with GNSS positioning (±1.5 m horizontal, ±0.5 m vertical, the
#: figure on the Phantom 4 Pro V2.0, Mavic 3 Enterprise and Matrice 300 RTK specification pages); ``rtk``: the same
#: pages' figure with RTK positioning (±0.1 m both ways); ``none``: a route walked by a person, or an exact replay.
POSITION_ERROR: dict[str, tuple[float, float]] = {"gnss": (1.5, 0.5), "rtk": (0.1, 0.1), "none": (0.0, 0.0)}


def position_error(value: object) -> tuple[float, float]:
    """(h, v) metres from a preset name, "H,V" text or a pair; a PlanError names a bad value."""
    if isinstance(value, str):
        if value.strip().lower() in POSITION_ERROR:
            return POSITION_ERROR[value.strip().lower()]
        parts = value.split(",")
    else:
        parts = list(value) if isinstance(value, (list, tuple, np.ndarray)) else [value]
    try:
        h, v = (float(x) for x in parts)
    except (TypeError, ValueError):
        raise PlanError(f"the position error must be 'H,V' in metres or one of {', '.join(POSITION_ERROR)}, "
                        f"got {value!r}") from None
    if not (np.isfinite(h) and np.isfinite(v) and 0 <= h <= 100 and 0 <= v <= 100):
        raise PlanError(f"the position error must be two numbers of metres from 0 to 100, got {value!r}")
    return float(h), float(v)


def placement_distance(safety_distance_m: float, error_m: tuple[float, float] = (0.0, 0.0)) -> float:
    """How far from the model a template places its frames: the safety distance, plus the most the position error
    can reach in any direction (√(h² + v²)), plus :data:`PLACEMENT_MARGIN_M`; frames placed so pass the checks at
    that error whatever the direction of the nearest surface."""
    return float(safety_distance_m) + float(np.hypot(*error_m)) + PLACEMENT_MARGIN_M


def placement(safety_distance_m: float, min_height_m: float | None,
              error_m: tuple[float, float] = (0.0, 0.0)) -> tuple[float, float | None]:
    """(distance from the model, least height above the ground) at which templates and the optimiser place frames so
    that they pass the checks at the position error ``error_m``: :func:`placement_distance`, and the minimum height
    plus the vertical error plus :data:`PLACEMENT_MARGIN_M` (None without a minimum height)."""
    low = None if min_height_m is None else float(min_height_m) + error_m[1] + PLACEMENT_MARGIN_M
    return placement_distance(safety_distance_m, error_m), low


def _worst(nominal: NDArray, ends: list[NDArray], dist, error_m: tuple[float, float]) -> NDArray[np.float64]:
    """(n,) the nominal distances less what the position-error cylinder can take away, h·|n_xy| + v·|n_z| with n the
    distance's gradient (central differences). ``ends``: the (n, 3) points, or a segment's two ends; ``dist(*ends)``
    measures them. The six displaced copies are measured in one call."""
    d = np.asarray(nominal, float)
    h, v = error_m
    near = np.isfinite(d) & (d < 1e6)
    if (h == 0 and v == 0) or not near.any():
        return d.copy()
    k = int(near.sum())
    step = _STEP_M * np.concatenate([np.eye(3), -np.eye(3)])  # +x, +y, +z, −x, −y, −z
    moved = [(e[near][None] + step[:, None]).reshape(-1, 3) for e in ends]
    dd = dist(*moved).reshape(6, k)
    g = ((dd[:3] - dd[3:]) / (2 * _STEP_M)).T
    norm = np.linalg.norm(g, axis=1)
    n = g / np.maximum(norm, 1e-12)[:, None]
    reach = np.where(norm > 1e-9, h * np.hypot(n[:, 0], n[:, 1]) + v * np.abs(n[:, 2]),
                     max(h, v))  # no gradient (inside, or on a ridge): the whole error
    out = d.copy()
    out[near] = d[near] - reach
    return out


def worst_point_clearance(scene: Scene, points: NDArray, error_m: tuple[float, float] = (0.0, 0.0),
                          nominal: NDArray | None = None) -> NDArray[np.float64]:
    """(n,) the least distance to the model of an aircraft planned at each (n, 3) point but off it by up to the
    position error (see the module docstring)."""
    P = np.asarray(points, float).reshape(-1, 3)
    d = point_distances(scene, P) if nominal is None else nominal
    return _worst(d, [P], lambda q: point_distances(scene, q), error_m)


def worst_segment_clearance(scene: Scene, start: NDArray, end: NDArray, error_m: tuple[float, float] = (0.0, 0.0),
                            nominal: NDArray | None = None) -> NDArray[np.float64]:
    """(m,) :func:`worst_point_clearance` for the segments start[i]→end[i]."""
    p = np.asarray(start, float).reshape(-1, 3)
    q = np.asarray(end, float).reshape(-1, 3)
    d = segment_distances(scene, p, q) if nominal is None else nominal
    return _worst(d, [p, q], lambda a, b: segment_distances(scene, a, b), error_m)


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
    error_m: tuple[float, float] = (0.0, 0.0)
    waypoint_worst_m: NDArray[np.float64] | None = None  # (n,) at the worst of the position error
    segment_worst_m: NDArray[np.float64] | None = None

    @property
    def ok(self) -> bool:
        return not self.violations


def _triangles(scene: Scene) -> tuple[NDArray, NDArray, NDArray]:
    """(F, 3, 3) triangles and their (F, 3) bounding boxes."""
    tri = np.ascontiguousarray(scene.vertices[scene.faces], dtype=np.float64)
    return tri, np.ascontiguousarray(tri.min(axis=1)), np.ascontiguousarray(tri.max(axis=1))


def _vertex_tree(scene: Scene):
    """A k-d tree of the vertices the scene's faces use, built once per scene object and kept on it."""
    tree = scene.__dict__.get("_vertex_tree")
    if tree is None:
        from scipy.spatial import cKDTree

        tree = cKDTree(scene.vertices[np.unique(scene.faces)])
        object.__setattr__(scene, "_vertex_tree", tree)
    return tree


def point_distances(scene: Scene, points: NDArray) -> NDArray[np.float64]:
    """(n,) exact distance from each (n, 3) point to the scene's nearest triangle (inf for an empty scene)."""
    pts = np.ascontiguousarray(np.asarray(points, float).reshape(-1, 3))
    if len(scene.faces) == 0:
        return np.full(len(pts), np.inf)
    return _point_distances(pts, _triangles(scene), _vertex_tree(scene))


def _point_distances(pts: NDArray, tri: tuple[NDArray, NDArray, NDArray], tree) -> NDArray[np.float64]:
    nearest_vertex, _ = tree.query(pts)  # the nearest vertex bounds the distance from above
    return min_point_distances(np.ascontiguousarray(pts), *tri, (nearest_vertex * (1 + 1e-9) + 1e-9) ** 2)


def segment_distances(scene: Scene, start: NDArray, end: NDArray) -> NDArray[np.float64]:
    """(m,) exact distance from each segment start[i]→end[i] to the nearest triangle (0 where it passes through)."""
    p = np.ascontiguousarray(np.asarray(start, float).reshape(-1, 3))
    q = np.ascontiguousarray(np.asarray(end, float).reshape(-1, 3))
    if len(scene.faces) == 0:
        return np.full(len(p), np.inf)
    tri = _triangles(scene)
    both = _point_distances(np.concatenate([p, q]), tri, _vertex_tree(scene))
    ends = np.minimum(both[:len(p)], both[len(p):])  # a segment is no farther than its ends
    return min_segment_distances(p, q, *tri, (ends * (1 + 1e-9) + 1e-9) ** 2)


def check_safety(scene: Scene, plan: Plan, minimum_m: float,
                 error_m: tuple[float, float] = (0.0, 0.0)) -> SafetyReport:
    """Distances of every waypoint (the frames' centres, in flight order) and every segment within a mission,
    nominal and at the worst of the position error ``error_m`` (h, v); what falls short of ``minimum_m`` (less
    :data:`CHECK_TOLERANCE_M`) at the worst is a violation."""
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
    wp_w = worst_point_clearance(scene, C, error_m, nominal=wp)
    seg_w = seg.copy()
    if inside.any():
        seg_w[idx] = worst_segment_clearance(scene, C[idx], C[idx + 1], error_m, nominal=seg[idx])
    lim = minimum_m - CHECK_TOLERANCE_M
    strays = any(error_m)

    def worst(d: float, w: float) -> str:
        if not strays or d < lim:
            return ""
        return f" ({max(w, 0.0):.2f} m at the worst of ±{error_m[0]:g} m / ±{error_m[1]:g} m position error)"

    violations = [f"waypoint {i} ({plan.frame_names[i]}) is {wp[i]:.2f} m from the model{worst(wp[i], wp_w[i])}"
                  for i in np.flatnonzero(wp_w < lim)]
    with np.errstate(invalid="ignore"):
        bad_seg = np.flatnonzero(seg_w < lim)
    violations += [f"segment {i}→{i + 1} passes {seg[i]:.2f} m from the model{worst(seg[i], seg_w[i])}"
                   for i in bad_seg]
    return SafetyReport(float(minimum_m), wp, seg, tuple(violations), tuple(error_m), wp_w, seg_w)
