"""The whole flight of a mission, from take-off to landing, as the checks test it and the exports write it.

A mission flies:

1. **take-off**: a vertical climb from the take-off point T (the ground under its pilot's station) to the
   *climb height* z_out;
2. **out**: a level flight at z_out to above the first waypoint W₀, then straight down to it (no descent when
   z_out is W₀'s height);
3. **the legs** between its waypoints;
4. **return**: a vertical climb at the last waypoint Wₙ to the *return height* z_home, a level flight home at
   z_home, and the **landing**: straight down to T.

z_out is W₀'s height when that level flight keeps the safety distance at the worst of the position error and the
minimum height over the ground; else the *transit height* of the way: the top of every obstacle whose box comes
within the safety distance plus the error's reach (√(h² + v²)) of the way, plus the safety distance and that reach
(or the ground's highest point on the way plus the minimum height and v, whichever is higher), plus
:data:`~sightplan.plan.checks.safety.PLACEMENT_MARGIN_M`. z_home is found the same way from Wₙ. The
exports write that return explicitly (a climb, the way home and a landing for MAVLink; DJI's return-to-home height
for WPML) instead of leaving it to an autopilot's return-to-launch at an altitude of its own.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from ..model.scene import Scene
from .checks.safety import CHECK_TOLERANCE_M, PLACEMENT_MARGIN_M, _triangles, worst_segment_clearance
from .ground import ground_z

SAMPLE_M = 0.5  # level flights are checked against the ground at points this far apart
TRAJECTORY_KEY = "trajectory"  # the plan parameter recording each mission's take-off point and heights

#: the parts of a mission's flight outside its legs, in flight order
PARTS = ("take-off climb", "flight out", "descent to the first waypoint", "climb after the last waypoint",
         "flight home", "landing")


@dataclass(frozen=True)
class MissionPath:
    """One mission's flight outside its legs: take-off point T, the first and last waypoints, the climb height
    z_out and the return height z_home (model frame, m)."""

    name: str
    takeoff_m: NDArray[np.float64]
    first_m: NDArray[np.float64]
    last_m: NDArray[np.float64]
    climb_z_m: float
    return_z_m: float

    def segments(self) -> NDArray[np.float64]:
        """(6, 2, 3) the segments of :data:`PARTS`, in order (a part of no length is a point)."""
        T, A, B = self.takeoff_m, self.first_m, self.last_m
        up, home = np.array([T[0], T[1], self.climb_z_m]), np.array([T[0], T[1], self.return_z_m])
        over_a = np.array([A[0], A[1], self.climb_z_m])
        over_b = np.array([B[0], B[1], self.return_z_m])
        return np.array([[T, up], [up, over_a], [over_a, A], [B, over_b], [over_b, home], [home, T]], float)

    def points(self) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
        """The flight out (T to W₀) and home (Wₙ to T) as (4, 3) polylines, for a viewer or a map."""
        s = self.segments()
        return np.array([s[0, 0], s[0, 1], s[1, 1], s[2, 1]]), np.array([s[3, 0], s[3, 1], s[4, 1], s[5, 1]])

    def to_dict(self) -> dict:
        return {"name": self.name, "takeoff_m": [round(float(v), 4) for v in self.takeoff_m],
                "climb_z_m": round(self.climb_z_m, 4), "return_z_m": round(self.return_z_m, 4)}


class Transit:
    """The level-flight heights over a scene: its obstacles' boxes found once, every way measured in one call."""

    def __init__(self, scene: Scene, obstacles: Scene, safety_m: float, error_m: tuple[float, float],
                 min_height_m: float | None) -> None:
        self.scene, self.obstacles = scene, obstacles
        self.safety, self.error = float(safety_m), (float(error_m[0]), float(error_m[1]))
        self.min_height = None if min_height_m is None else float(min_height_m)
        self.reach = float(np.hypot(*self.error))  # the most the position error can take away, in any direction
        _, self.lo, self.hi = _triangles(obstacles)

    def ground_tops(self, a: NDArray, b: NDArray) -> NDArray[np.float64]:
        """(k,) the ground's highest point under each way from a[i] to b[i] (XY), sampled every :data:`SAMPLE_M`."""
        a, b = np.atleast_2d(a)[:, :2], np.atleast_2d(b)[:, :2]
        n = np.maximum(2, np.ceil(np.linalg.norm(b - a, axis=1) / SAMPLE_M).astype(int) + 1)
        owner = np.repeat(np.arange(len(a)), n)
        t = (np.arange(len(owner)) - np.repeat(np.cumsum(n) - n, n)) / np.repeat(n - 1, n)
        top = np.full(len(a), -np.inf)
        np.maximum.at(top, owner, ground_z(self.scene, a[owner] + t[:, None] * (b[owner] - a[owner])))
        return top

    def ground_floors(self, a: NDArray, b: NDArray) -> NDArray[np.float64]:
        """(k,) the least height each level flight from a[i] to b[i] may keep over the ground: the ground's highest
        point on the way plus the minimum height and the vertical position error (−inf without a minimum height)."""
        if self.min_height is None:
            return np.full(len(np.atleast_2d(a)), -np.inf)
        return self.ground_tops(a, b) + self.min_height + self.error[1] + PLACEMENT_MARGIN_M

    def over_obstacles(self, a: NDArray, b: NDArray) -> float:
        """The height at which a level flight from a to b (XY) clears every obstacle whose box comes within the
        safety distance plus the error's reach of the way (−inf when none does)."""
        if not len(self.lo):
            return -np.inf
        r = self.safety + self.reach + PLACEMENT_MARGIN_M
        lo, hi = self.lo[:, :2] - r, self.hi[:, :2] + r
        d = b[:2] - a[:2]
        t0, t1 = np.zeros(len(lo)), np.ones(len(lo))
        for k in range(2):  # the segment against each expanded box, slab by slab
            if abs(d[k]) < 1e-12:
                inside = (a[k] >= lo[:, k]) & (a[k] <= hi[:, k])
                t0 = np.where(inside, t0, 2.0)
                continue
            s0, s1 = (lo[:, k] - a[k]) / d[k], (hi[:, k] - a[k]) / d[k]
            t0, t1 = np.maximum(t0, np.minimum(s0, s1)), np.minimum(t1, np.maximum(s0, s1))
        hit = t0 <= t1
        if not hit.any():
            return -np.inf
        return float(self.hi[hit, 2].max()) + self.safety + self.reach + PLACEMENT_MARGIN_M

    def clear(self, segments: NDArray) -> NDArray[np.float64]:
        """(k,) each (k, 2, 3) segment's worst-case clearance from the obstacles."""
        S = np.asarray(segments, float).reshape(-1, 2, 3)
        return worst_segment_clearance(self.obstacles, S[:, 0], S[:, 1], self.error)

    def heights(self, at: NDArray, home: NDArray) -> NDArray[np.float64]:
        """(k,) z for the level flight between each waypoint ``at[i]`` and take-off point ``home[i]``: the waypoint's
        own height where that is clear (:meth:`clear` and :meth:`ground_floors`), else the transit height."""
        at, home = np.atleast_2d(np.asarray(at, float)), np.atleast_2d(np.asarray(home, float))
        z = np.maximum(at[:, 2], self.ground_floors(at, home))
        up = np.column_stack([home[:, :2], z])
        over = np.column_stack([at[:, :2], z])
        direct = np.stack([np.stack([home, up], 1), np.stack([up, over], 1), np.stack([over, at], 1)], 1)  # (k, 3, 2, 3)
        ok = (self.clear(direct).reshape(-1, 3) >= self.safety - CHECK_TOLERANCE_M).all(axis=1)
        for i in np.flatnonzero(~ok):
            z[i] = max(z[i], self.over_obstacles(at[i], home[i]))
        return z


def mission_paths(transit: Transit, C: NDArray, missions, takeoffs: list[NDArray]) -> list[MissionPath]:
    """One :class:`MissionPath` per mission with waypoints: C (n, 3) the waypoints, ``takeoffs`` each mission's
    take-off point (on the ground); the heights of every mission found together."""
    flown = [(m, np.asarray(T, float)) for m, T in zip(missions, takeoffs) if m.stop > m.start]
    if not flown:
        return []
    T = np.array([t for _, t in flown])
    A = np.array([C[m.start] for m, _ in flown], float)
    B = np.array([C[m.stop - 1] for m, _ in flown], float)
    z = transit.heights(np.concatenate([A, B]), np.concatenate([T, T]))
    k = len(flown)
    return [MissionPath(m.name, T[i], A[i], B[i], float(z[i]), float(z[k + i])) for i, (m, _) in enumerate(flown)]


def recorded_paths(parameters: dict) -> list[dict]:
    """The missions' take-off points and heights recorded in a plan's parameters (empty when none are)."""
    rec = parameters.get(TRAJECTORY_KEY)
    if not isinstance(rec, dict) or not isinstance(rec.get("missions"), list):
        return []
    good = []
    for m in rec["missions"]:
        try:
            T = [float(v) for v in m["takeoff_m"]]
            z_out, z_home = float(m["climb_z_m"]), float(m["return_z_m"])
        except (KeyError, TypeError, ValueError):
            return []
        if len(T) != 3 or not np.isfinite([*T, z_out, z_home]).all():
            return []
        good.append({"name": str(m.get("name", "")), "takeoff_m": T, "climb_z_m": z_out, "return_z_m": z_home})
    return good
