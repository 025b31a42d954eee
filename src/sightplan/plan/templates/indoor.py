"""Indoor route: a walked polyline sampled at a fixed step, for 360° or perspective cameras."""

from __future__ import annotations

import numpy as np
from numpy.typing import ArrayLike

from ...camera.models import Camera
from ...errors import PlanError
from ..poses import R_from_gimbal
from ..types import Mission, Plan


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
