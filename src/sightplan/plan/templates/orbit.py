"""Orbit (circular) template: rings around the model's targets, the camera aimed at their centre."""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Literal

import numpy as np
from numpy.typing import NDArray

from ...camera.models import Camera, PinholeCamera
from ...errors import PlanError
from ...geometry.poses import R_from_gimbal, aim_angles
from ...model.scene import Scene
from ..aim import drop_blind_frames
from ..domain import MAX_DISTANCE_M, MAX_HEIGHT_M
from ..ground import MIN_HEIGHT_M, ground_z, targets_only
from ..types import Mission, Plan
from .base import Params, Template, param
from .facade import _valid_min_height, layer_heights
from .spacing import check_frame_budget, waypoint_spacing

DEFAULT_SAFETY_M = 10.0


def ring_poses(centre: NDArray, radius: float, z: float, n: int) -> tuple[NDArray, NDArray, NDArray]:
    """(n, 3) centres on a horizontal circle (first due north of ``centre``, then clockwise) at
    height ``z``, and the (n,) heading and pitch in degrees that aim each at ``centre``."""
    az = np.arange(n) * 2 * np.pi / n
    C = np.stack([centre[0] + radius * np.sin(az), centre[1] + radius * np.cos(az), np.full(n, float(z))], axis=1)
    return C, *aim_angles(C, centre)


def orbit(scene: Scene, camera: Camera, radii_m: list[float] | None = None, heights_m: list[float] | None = None,
          step_deg: float | None = None, overlap: float | None = 0.8, aim: Literal["centre", "surface"] = "centre",
          safety_distance_m: float = DEFAULT_SAFETY_M, min_height_m: float = MIN_HEIGHT_M,
          drop_blind: bool = True) -> Plan:
    """One ring per (radius, height) pair, frames every ``step_deg`` or by ``overlap``.

    radii_m: horizontal distances from the centre of the targets' box; heights_m: camera
    heights (model frame). With ``overlap``, the step keeps that share of the horizontal
    field of view in common at the distance to the box's centre (eq. 11 with g = radius);
    ``step_deg`` overrides it. Each ring is a mission. ``aim``: frames look at the box's
    centre, or at the nearest point of the targets' surface (the nearest wall head-on; a
    ring above the roof looks down at it).

    Defaults: one radius, the half-diagonal of the targets' box plus ``safety_distance_m``,
    over cos(180°/n) for n frames a ring, so the straight legs between frames keep the
    safety distance from the box's corners too;
    heights from ``min_height_m`` above the ground (or the targets' base, if higher) to
    ``safety_distance_m`` above the targets' top, no more than eq. 11's vertical spacing
    apart at the radius. Where only one of the two is given, every radius gets every
    height. A ring lower than ``min_height_m`` above the ground under it is refused.
    """
    if aim not in ("centre", "surface"):
        raise PlanError(f"aim must be 'centre' or 'surface', got {aim!r}")
    min_h = _valid_min_height(min_height_m)
    structure = targets_only(scene)
    lo, hi = structure.bounds()
    centre = (lo + hi) / 2
    half_diag = float(np.hypot(*(hi - lo)[:2]) / 2)
    if radii_m is None or heights_m is None:
        if not (safety_distance_m > 0 and math.isfinite(safety_distance_m)):
            raise PlanError(f"the safety distance must be a positive number of metres, got {safety_distance_m}")
        if radii_m is not None:
            radii = list(radii_m)
        else:  # the ring's straight legs between frames keep the safety distance from the box's corners too
            r0 = half_diag + float(safety_distance_m)
            radii = [r0 / math.cos(math.pi / _frames_per_ring(camera, r0, step_deg, overlap))]
        if heights_m is None:
            if not isinstance(camera, PinholeCamera):
                raise PlanError("default ring heights need a perspective camera; give the heights")
            heights = []
            for r in radii:
                ring, _, _ = ring_poses(centre, r, 0.0, 36)
                floor = max(float(lo[2]), float(ground_z(scene, ring).max()) + min_h)
                spacing = waypoint_spacing(r, camera.vfov_deg, 0.8 if overlap is None else overlap)
                heights.append(layer_heights(floor, float(hi[2]) + float(safety_distance_m), spacing).tolist())
            pairs = [(r, z) for r, zs in zip(radii, heights) for z in zs]
        else:
            pairs = [(r, float(z)) for r in radii for z in heights_m]
        radii_m, heights_m = [p[0] for p in pairs], [p[1] for p in pairs]
    if len(radii_m) != len(heights_m) or not radii_m:
        raise PlanError("give one height per ring radius (and at least one ring)")
    per_ring = [_frames_per_ring(camera, r, step_deg, overlap, k) for k, r in enumerate(radii_m)]
    check_frame_budget(sum(per_ring), f"{len(radii_m)} rings", "radius_m and height_m (fewer rings) or step_deg")
    C, heading, pitch, missions = [], [], [], []
    for k, (r, z) in enumerate(zip(radii_m, heights_m)):
        if not r > half_diag:
            raise PlanError(f"ring {k}: radius {r} m is inside the model's footprint (half diagonal {half_diag:.1f} m)")
        c, h, p = ring_poses(centre, r, z, per_ring[k])
        floor = float(ground_z(scene, c).max()) + min_h
        if z < floor - 1e-6:
            raise PlanError(f"ring {k}: height {z:g} m is below the minimum height, {min_h:g} m above the ground "
                            f"(z = {floor:.2f} m); raise it")
        first = len(C)
        C.extend(c.tolist())
        heading.extend(h.tolist())
        pitch.extend(p.tolist())
        missions.append(Mission(f"ring {k + 1}", first, len(C)))
    C = np.asarray(C)
    if aim == "surface":
        heading, pitch = aim_angles(C, nearest_surface_points(structure, C))
    plan = Plan.build(camera, R_from_gimbal(heading, pitch, 0.0), C, missions=tuple(missions), waypoints=C,
                      parameters={"template": "orbit", "radii_m": list(map(float, radii_m)),
                                  "heights_m": list(map(float, heights_m)), "step_deg": step_deg, "overlap": overlap,
                                  "aim": aim, "min_height_m": min_h})
    return drop_blind_frames(scene, plan, "orbit") if drop_blind else plan


def _frames_per_ring(camera: Camera, radius: float, step_deg: float | None, overlap: float | None, ring: int = 0) -> int:
    """Frames on a ring: every ``step_deg``, or by overlap (eq. 11 with g = the radius); at least 3."""
    if step_deg is not None:
        step = float(step_deg)
    else:
        if not isinstance(camera, PinholeCamera) or overlap is None:
            raise PlanError("a step by overlap needs a perspective camera; give step_deg instead")
        step = math.degrees(waypoint_spacing(radius, camera.hfov_deg, overlap) / radius)
    if not 0 < step <= 180:
        raise PlanError(f"ring {ring}: the angular step must be in (0°, 180°], got {step}")
    check_frame_budget(360.0 / step, f"ring {ring}'s step of {step:g}°", "step_deg (or overlap)")
    return max(3, math.ceil(360.0 / step - 1e-9))


def nearest_surface_points(scene: Scene, points: NDArray) -> NDArray[np.float64]:
    """(n, 3) the closest point of the model's triangles to each of the (n, 3) points."""
    import trimesh

    mesh = trimesh.Trimesh(scene.vertices, scene.faces, process=False)
    closest, _, _ = trimesh.proximity.closest_point(mesh, np.asarray(points, float))
    return np.asarray(closest, float)


@dataclass(frozen=True)
class OrbitParams(Params):
    overlap: float = param(0.8, "image overlap l between neighbouring frames", ge=0, le=0.95)
    radius_m: tuple[float, ...] = param((), "ring radius, once per ring (default: the targets' half-diagonal + the "
                                        "safety distance)", gt=0, le=MAX_DISTANCE_M, kind="numbers", label="Radii",
                                        pair="ring")
    height_m: tuple[float, ...] = param((), "ring height, once per ring (default: layers by overlap from the minimum "
                                        "height to the safety distance above the top)", kind="numbers", label="Heights",
                                        pair="ring", ge=-MAX_HEIGHT_M, le=MAX_HEIGHT_M)
    step_deg: float | None = param(None, "degrees between frames (default: by overlap)", ge=0.01, le=180, cli="step",
                                   label="Step")
    aim: str = param("centre", "aim at the model's 'centre' or its nearest 'surface'", choices=("centre", "surface"))


def _build(scene: Scene, camera: Camera, p: OrbitParams, safety_distance_m: float, min_height_m: float) -> Plan:
    return orbit(scene, camera, list(p.radius_m) or None, list(p.height_m) or None, step_deg=p.step_deg,
                 overlap=p.overlap, aim=p.aim, safety_distance_m=safety_distance_m, min_height_m=min_height_m)


TEMPLATE = Template("orbit", "rings", OrbitParams, _build, order=1)
