"""A ring of frames around a model: the sample job's plan until templates arrive."""

from __future__ import annotations

import numpy as np

from ..camera.models import Camera
from ..errors import PlanError
from ..geometry.poses import R_from_gimbal
from ..model.scene import Scene
from .templates.orbit import ring_poses
from .types import Mission, Plan


def ring_plan(scene: Scene, camera: Camera, n_frames: int = 36, distance_m: float = 15.0, height_m: float | None = None,
              pitch_deg: float | None = None) -> Plan:
    """``n_frames`` frames on a circle around the model's bounding box, aimed at its centre.

    distance_m: clearance from the bounding box's horizontal half-diagonal to the circle.
    height_m: camera height (default: 1.5 × the box's top). pitch_deg: default aims at the centre.
    """
    if n_frames < 1:
        raise PlanError(f"a ring needs at least one frame, got {n_frames}")
    lo, hi = scene.bounds()
    centre = (lo + hi) / 2
    radius = float(np.hypot(*(hi - lo)[:2]) / 2 + distance_m)
    z = hi[2] + 0.5 * (hi[2] - lo[2]) if height_m is None else height_m
    C, heading, pitch = ring_poses(centre, radius, z, n_frames)
    if pitch_deg is not None:
        pitch = np.full(n_frames, pitch_deg)
    R = R_from_gimbal(heading, pitch, 0.0)
    return Plan.build(camera, R, C, missions=(Mission("ring", 0, n_frames),),
                      parameters={"template": "ring", "n_frames": n_frames, "distance_m": distance_m, "radius_m": radius,
                                  "height_m": float(z)})
