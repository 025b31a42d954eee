"""Top-down lawn-mower: a nadir grid over the model's footprint."""

from __future__ import annotations

import numpy as np

from ...camera.models import Camera, PinholeCamera
from ...errors import PlanError
from ...model.scene import Scene
from ..poses import R_from_gimbal
from ..types import Mission, Plan
from .facade import _positions
from .spacing import waypoint_spacing


def lawnmower(scene: Scene, camera: Camera, altitude_m: float | None = None, gsd_m: float | None = None,
              front_overlap: float = 0.8, side_overlap: float = 0.7, margin_m: float = 0.0) -> Plan:
    """Nadir frames on north–south lines over the footprint (plus ``margin_m``), flown as a snake.

    altitude_m: height of the camera above the model's lowest point; or ``gsd_m``, the
    ground sampling distance wanted on the model's top (m/px), which sets the altitude.
    Spacing follows eq. 11 at the distance to the model's top, where overlap is least:
    along a line with the vertical field of view (the image's height lies along the line),
    between lines with the horizontal one. The image's top points north.
    """
    if not isinstance(camera, PinholeCamera):
        raise PlanError("a lawn-mower grid needs a perspective (pinhole) camera")
    if (altitude_m is None) == (gsd_m is None):
        raise PlanError("give either an altitude or a ground sampling distance")
    lo, hi = scene.bounds()
    lo, hi = lo.copy(), hi.copy()
    lo[:2] -= margin_m
    hi[:2] += margin_m
    if altitude_m is None:
        if not gsd_m > 0:
            raise PlanError(f"the ground sampling distance must be positive, got {gsd_m}")
        clearance = gsd_m * camera.sampling_focal_px
        altitude_m = hi[2] - lo[2] + clearance
    clearance = altitude_m - (hi[2] - scene.bounds()[0][2])
    if not clearance > 0:
        raise PlanError(f"altitude {altitude_m:.1f} m does not clear the model's top "
                        f"({hi[2] - scene.bounds()[0][2]:.1f} m above its base)")
    along = waypoint_spacing(clearance, camera.vfov_deg, front_overlap)
    across = waypoint_spacing(clearance, camera.hfov_deg, side_overlap)
    xs = lo[0] + _positions(hi[0] - lo[0], across)
    ys = lo[1] + _positions(hi[1] - lo[1], along)
    z = scene.bounds()[0][2] + altitude_m
    C = np.array([[x, y, z] for j, x in enumerate(xs) for y in (ys if j % 2 == 0 else ys[::-1])])
    R = R_from_gimbal(np.zeros(len(C)), np.full(len(C), -90.0), 0.0)
    return Plan.build(camera, R, C, missions=(Mission("lawn-mower", 0, len(C)),), waypoints=C,
                      parameters={"template": "lawnmower", "altitude_m": float(altitude_m),
                                  "clearance_m": float(clearance), "gsd_on_top_m": clearance / camera.sampling_focal_px,
                                  "spacing_along_m": along, "spacing_across_m": across, "front_overlap": front_overlap,
                                  "side_overlap": side_overlap})
