"""Waypoint spacing (METRICS.md §9, paper eq. 11)."""

from __future__ import annotations

import math

from ...errors import PlanError
from ..domain import check_work


def waypoint_spacing(distance_m: float, fov_deg: float, overlap: float) -> float:
    """Spacing s = 2·g·tan(Φ/2)·(1 − l) in metres between neighbouring waypoints.

    distance_m: g, the distance to the surface; fov_deg: Φ, the field of view along the
    spacing direction; overlap: l in [0, 1). The image footprint on the surface is
    2·g·tan(Φ/2); moving by footprint × (1 − l) keeps the share l in common, which is also
    QGroundControl's rule for survey spacing.
    """
    if not (distance_m > 0 and math.isfinite(distance_m)):
        raise PlanError(f"the safety distance must be a positive number of metres, got {distance_m}")
    if not 0 < fov_deg < 180:
        raise PlanError(f"the field of view must be between 0° and 180°, got {fov_deg}")
    if not 0 <= overlap < 1:
        raise PlanError(f"the overlap must be at least 0 and below 100 %, got {overlap * 100:g} %")
    return 2.0 * distance_m * math.tan(math.radians(fov_deg) / 2) * (1.0 - overlap)


#: No template builds more frames than this (a walked route neither): more is a typo in a step or an overlap, and
#: would take the memory of the machine before anything is cast.
MAX_TEMPLATE_FRAMES = 100_000


def check_frame_budget(n_frames: float, what: str, change: str = "the step or the overlap") -> None:
    """Refuse, before anything is built, a template whose parameters give more than :data:`MAX_TEMPLATE_FRAMES`."""
    check_work(n_frames, MAX_TEMPLATE_FRAMES, what, change)
