"""Orbit (circular) template: rings around the model, the camera aimed at its centre."""

from __future__ import annotations

import math
from typing import Literal

import numpy as np
from numpy.typing import NDArray

from ...camera.models import Camera, PinholeCamera
from ...errors import PlanError
from ...model.scene import Scene
from ..poses import R_from_gimbal
from ..types import Mission, Plan
from .spacing import waypoint_spacing


def ring_poses(centre: NDArray, radius: float, z: float, n: int) -> tuple[NDArray, NDArray, NDArray]:
    """(n, 3) centres on a horizontal circle (first due north of ``centre``, then clockwise) at
    height ``z``, and the (n,) heading and pitch in degrees that aim each at ``centre``."""
    az = np.arange(n) * 2 * np.pi / n
    C = np.stack([centre[0] + radius * np.sin(az), centre[1] + radius * np.cos(az), np.full(n, float(z))], axis=1)
    return C, *_toward(C, centre)


def orbit(scene: Scene, camera: Camera, radii_m: list[float], heights_m: list[float], step_deg: float | None = None,
          overlap: float | None = 0.8, aim: Literal["centre", "surface"] = "centre") -> Plan:
    """One ring per (radius, height) pair, frames every ``step_deg`` or by ``overlap``.

    radii_m: horizontal distances from the box's centre; heights_m: camera heights (model
    frame). With ``overlap``, the step keeps that share of the horizontal field of view in
    common at the distance to the box's centre (eq. 11 with g = radius); ``step_deg``
    overrides it. Each ring is a mission. ``aim``: frames look at the box's centre, or at
    the nearest point of the model's surface (the nearest wall head-on; a ring above the
    roof looks down at it).
    """
    if aim not in ("centre", "surface"):
        raise PlanError(f"aim must be 'centre' or 'surface', got {aim!r}")
    if len(radii_m) != len(heights_m) or not radii_m:
        raise PlanError("give one height per ring radius (and at least one ring)")
    lo, hi = scene.bounds()
    centre = (lo + hi) / 2
    half_diag = float(np.hypot(*(hi - lo)[:2]) / 2)
    C, heading, pitch, missions = [], [], [], []
    for k, (r, z) in enumerate(zip(radii_m, heights_m)):
        if not r > half_diag:
            raise PlanError(f"ring {k}: radius {r} m is inside the model's footprint (half diagonal {half_diag:.1f} m)")
        if step_deg is not None:
            step = float(step_deg)
        else:
            if not isinstance(camera, PinholeCamera) or overlap is None:
                raise PlanError("a step by overlap needs a perspective camera; give step_deg instead")
            step = math.degrees(waypoint_spacing(r, camera.hfov_deg, overlap) / r)
        if not 0 < step <= 180:
            raise PlanError(f"ring {k}: the angular step must be in (0°, 180°], got {step}")
        c, h, p = ring_poses(centre, r, z, max(3, math.ceil(360.0 / step - 1e-9)))
        first = len(C)
        C.extend(c.tolist())
        heading.extend(h.tolist())
        pitch.extend(p.tolist())
        missions.append(Mission(f"ring {k + 1}", first, len(C)))
    C = np.asarray(C)
    if aim == "surface":
        heading, pitch = _toward(C, nearest_surface_points(scene, C))
    return Plan.build(camera, R_from_gimbal(heading, pitch, 0.0), C, missions=tuple(missions), waypoints=C,
                      parameters={"template": "orbit", "radii_m": list(map(float, radii_m)),
                                  "heights_m": list(map(float, heights_m)), "step_deg": step_deg, "overlap": overlap,
                                  "aim": aim})


def nearest_surface_points(scene: Scene, points: NDArray) -> NDArray[np.float64]:
    """(n, 3) the closest point of the model's triangles to each of the (n, 3) points."""
    import trimesh

    mesh = trimesh.Trimesh(scene.vertices, scene.faces, process=False)
    closest, _, _ = trimesh.proximity.closest_point(mesh, np.asarray(points, float))
    return np.asarray(closest, float)


def _toward(C: NDArray, target: NDArray) -> tuple[NDArray, NDArray]:
    """(n,) heading and pitch in degrees that aim from each of C at the matching target (or at one (3,) target)."""
    v = target - C
    return np.degrees(np.arctan2(v[:, 0], v[:, 1])), np.degrees(np.arctan2(v[:, 2], np.hypot(v[:, 0], v[:, 1])))
