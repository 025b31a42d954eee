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
from .checks.safety import CHECK_TOLERANCE_M, PLACEMENT_MARGIN_M, worst_segment_clearance
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
    """The level-flight heights over a scene, with its obstacles' boxes computed once."""

    def __init__(self, scene: Scene, obstacles: Scene, safety_m: float, error_m: tuple[float, float],
                 min_height_m: float | None) -> None:
        self.scene, self.obstacles = scene, obstacles
        self.safety, self.error = float(safety_m), (float(error_m[0]), float(error_m[1]))
        self.min_height = None if min_height_m is None else float(min_height_m)
        tri = obstacles.vertices[obstacles.faces] if len(obstacles.faces) else np.zeros((0, 3, 3))
        self.lo, self.hi = tri.min(axis=1) if len(tri) else np.zeros((0, 3)), tri.max(axis=1) if len(tri) else np.zeros((0, 3))

    def ground_top(self, a: NDArray, b: NDArray) -> float:
        """The ground's highest point under the way from a to b (XY), sampled every :data:`SAMPLE_M`."""
        n = max(2, int(np.ceil(np.linalg.norm(b[:2] - a[:2]) / SAMPLE_M)) + 1)
        P = a[None, :2] + np.linspace(0, 1, n)[:, None] * (b[:2] - a[:2])[None]
        return float(ground_z(self.scene, P).max())

    def ground_floor(self, a: NDArray, b: NDArray) -> float:
        """The least height a level flight from a to b (XY) may keep over the ground: the ground's highest point
        on the way plus the minimum height and the vertical position error (−inf without a minimum height)."""
        if self.min_height is None:
            return -np.inf
        return self.ground_top(a, b) + self.min_height + self.error[1] + PLACEMENT_MARGIN_M

    def over_obstacles(self, a: NDArray, b: NDArray) -> float:
        """The height at which a level flight from a to b (XY) clears every obstacle whose box comes within the
        safety distance plus the horizontal position error of the way (−inf when none does)."""
        if not len(self.lo):
            return -np.inf
        reach = float(np.hypot(*self.error))  # the most the position error can take away, in any direction
        r = self.safety + reach + PLACEMENT_MARGIN_M
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
        return float(self.hi[hit, 2].max()) + self.safety + reach + PLACEMENT_MARGIN_M

    def clear(self, segments: NDArray) -> NDArray[np.float64]:
        """(k,) each (k, 2, 3) segment's worst-case clearance from the obstacles."""
        S = np.asarray(segments, float).reshape(-1, 2, 3)
        return worst_segment_clearance(self.obstacles, S[:, 0], S[:, 1], self.error)

    def height(self, at: NDArray, home: NDArray) -> float:
        """z for the level flight between waypoint ``at`` and take-off point ``home``: the waypoint's own height
        where that is clear (:meth:`clear` and :meth:`ground_floor`), else the transit height."""
        floor = self.ground_floor(at, home)
        z = max(float(at[2]), floor)
        direct = np.array([[[home[0], home[1], home[2]], [home[0], home[1], z]],
                           [[home[0], home[1], z], [at[0], at[1], z]], [[at[0], at[1], z], at]])
        if (self.clear(direct) >= self.safety - CHECK_TOLERANCE_M).all():
            return z
        return max(z, self.over_obstacles(at, home))


def mission_paths(scene: Scene, obstacles: Scene, C: NDArray, missions, takeoffs: list[NDArray], safety_m: float,
                  error_m: tuple[float, float], min_height_m: float | None) -> list[MissionPath]:
    """One :class:`MissionPath` per mission with waypoints: C (n, 3) the waypoints, ``takeoffs`` each mission's
    take-off point (on the ground)."""
    transit = Transit(scene, obstacles, safety_m, error_m, min_height_m)
    out = []
    for m, T in zip(missions, takeoffs):
        if m.stop <= m.start:
            continue
        T = np.asarray(T, float)
        A, B = np.asarray(C[m.start], float), np.asarray(C[m.stop - 1], float)
        out.append(MissionPath(m.name, T, A, B, transit.height(A, T), transit.height(B, T)))
    return out


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
