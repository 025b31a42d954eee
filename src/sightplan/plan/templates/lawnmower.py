"""Top-down lawn-mower: a nadir grid over the model's footprint, optionally crossed by oblique lines."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ...camera.models import Camera, PinholeCamera
from ...errors import PlanError
from ...geometry.poses import R_from_gimbal
from ...model.scene import Scene
from ..aim import drop_blind_frames
from ..domain import MAX_GSD_M_PX, MAX_HEIGHT_M
from ..ground import MIN_HEIGHT_M, ground_z, targets_only
from ..types import Mission, Plan
from .base import Params, Template, param
from .facade import _positions, _valid_min_height
from .spacing import check_frame_budget, waypoint_spacing


def lawnmower(scene: Scene, camera: Camera, altitude_m: float | None = None, gsd_m: float | None = None,
              front_overlap: float = 0.8, side_overlap: float = 0.7, margin_m: float = 0.0,
              oblique_pitch_deg: float | None = None, min_height_m: float = MIN_HEIGHT_M,
              drop_blind: bool = True, safety_distance_m: float | None = None) -> Plan:
    """Nadir frames on north–south lines over the targets' footprint (plus ``margin_m``), flown as a snake.

    altitude_m: height of the camera above the targets' base (their lowest point); or
    ``gsd_m``, the ground sampling distance wanted on the targets' top (m/px), which sets
    the altitude; with neither, the lowest grid that clears the targets' top by ``safety_distance_m``.
    A grid less than ``min_height_m`` above the ground under it is refused.
    Frames that see no target are dropped unless ``drop_blind`` is False.
    Spacing follows eq. 11 at the distance to the model's top, where overlap is least:
    along a line with the vertical field of view (the image's height lies along the line),
    between lines with the horizontal one. The image's top points north.

    oblique_pitch_deg: for a photogrammetry "double grid", a second mission after the nadir
    lines: east–west lines over the same area, flown as a snake from the south, the camera
    at this pitch (−90 to 0, e.g. −60) looking in the flight direction (east on the first
    line, west on the next, …). They reuse the nadir spacings (frames every
    ``spacing_along_m`` along a line, lines ``spacing_across_m`` apart): an oblique view
    reaches farther than a nadir one, so the overlaps are at least those asked for.
    """
    if not isinstance(camera, PinholeCamera):
        raise PlanError("a lawn-mower grid needs a perspective (pinhole) camera")
    if oblique_pitch_deg is not None and not -90 <= oblique_pitch_deg < 0:
        raise PlanError(f"the oblique pitch must look down, between -90° and 0°, got {oblique_pitch_deg}")
    if altitude_m is not None and gsd_m is not None:
        raise PlanError("give either an altitude or a ground sampling distance, not both")
    if altitude_m is None and gsd_m is None:
        if safety_distance_m is None or not (safety_distance_m > 0 and np.isfinite(safety_distance_m)):
            raise PlanError("give an altitude, a ground sampling distance or a safety distance to clear the model by")
    min_h = _valid_min_height(min_height_m)
    structure = targets_only(scene)
    lo, hi = structure.bounds()
    lo, hi = lo.copy(), hi.copy()
    base = float(lo[2])
    lo[:2] -= margin_m
    hi[:2] += margin_m
    if altitude_m is None and gsd_m is None:
        altitude_m = hi[2] - lo[2] + float(safety_distance_m)
    elif altitude_m is None:
        if not gsd_m > 0:
            raise PlanError(f"the ground sampling distance must be positive, got {gsd_m}")
        clearance = gsd_m * camera.sampling_focal_px
        altitude_m = hi[2] - lo[2] + clearance
    clearance = altitude_m - (hi[2] - base)
    given = "gsd_m_px" if gsd_m is not None else "altitude_m"
    if not clearance > 0:
        raise PlanError(f"altitude {altitude_m:.1f} m does not clear the model's top "
                        f"({hi[2] - base:.1f} m above its base)")
    if safety_distance_m is not None and clearance < safety_distance_m - 1e-9:
        least = (f"at least {safety_distance_m / camera.sampling_focal_px:.3g} m/px" if gsd_m is not None
                 else f"at least {hi[2] - base + safety_distance_m:.1f} m")
        raise PlanError(f"{given}: {gsd_m if gsd_m is not None else altitude_m:g} puts the camera {clearance:.2f} m "
                        f"above the model's top, closer than the {safety_distance_m:.3g} m it keeps from the model "
                        f"(the safety distance); give {least}")
    along = waypoint_spacing(clearance, camera.vfov_deg, front_overlap)
    across = waypoint_spacing(clearance, camera.hfov_deg, side_overlap)
    lines, per_line = (hi[0] - lo[0]) / across + 2, (hi[1] - lo[1]) / along + 2
    check_frame_budget(lines * per_line * (2 if oblique_pitch_deg is not None else 1),
                       f"a lawn-mower grid {clearance:.2f} m above the model's top",
                       f"{given} (a coarser grid) or the overlaps")
    xs = lo[0] + _positions(hi[0] - lo[0], across)
    ys = lo[1] + _positions(hi[1] - lo[1], along)
    z = base + altitude_m
    C = np.array([[x, y, z] for j, x in enumerate(xs) for y in (ys if j % 2 == 0 else ys[::-1])])
    floor = float(ground_z(scene, np.array([[x, y] for x in (lo[0], hi[0]) for y in (lo[1], hi[1])] + list(C[:, :2]))).max())
    if z < floor + min_h - 1e-6:
        raise PlanError(f"altitude {altitude_m:.1f} m is below the minimum height, {min_h:g} m above the ground "
                        f"(z = {floor + min_h:.2f} m); raise it")
    R = R_from_gimbal(np.zeros(len(C)), np.full(len(C), -90.0), 0.0)
    missions = [Mission("lawn-mower", 0, len(C))]
    parameters = {"template": "lawnmower", "altitude_m": float(altitude_m), "clearance_m": float(clearance),
                  "gsd_on_top_m": clearance / camera.sampling_focal_px, "spacing_along_m": along, "spacing_across_m": across,
                  "front_overlap": front_overlap, "side_overlap": side_overlap, "min_height_m": min_h}
    if oblique_pitch_deg is not None:
        # crossed lines: east–west, ``across`` apart in y; frames ``along`` apart in x, looking along the flight
        cross_y = lo[1] + _positions(hi[1] - lo[1], across)
        cross_x = lo[0] + _positions(hi[0] - lo[0], along)
        Cx = np.array([[x, y, z] for j, y in enumerate(cross_y) for x in (cross_x if j % 2 == 0 else cross_x[::-1])])
        heading = np.repeat(np.where(np.arange(len(cross_y)) % 2 == 0, 90.0, 270.0), len(cross_x))
        missions.append(Mission("lawn-mower crossed", len(C), len(C) + len(Cx)))
        C = np.concatenate([C, Cx])
        R = np.concatenate([R, R_from_gimbal(heading, np.full(len(Cx), float(oblique_pitch_deg)), 0.0)])
        parameters["oblique_pitch_deg"] = float(oblique_pitch_deg)
    plan = Plan.build(camera, R, C, missions=tuple(missions), waypoints=C, parameters=parameters)
    return drop_blind_frames(scene, plan, "lawn-mower grid") if drop_blind else plan


@dataclass(frozen=True)
class LawnmowerParams(Params):
    overlap: float = param(0.8, "image overlap along a line", ge=0, le=0.95)
    altitude_m: float | None = param(None, "camera height above the model's base (default: the safety distance above "
                                     "its top)", gt=0, le=MAX_HEIGHT_M, label="Altitude")
    gsd_m_px: float | None = param(None, "ground sampling distance on the model's top (instead of the altitude)",
                                   gt=0, le=MAX_GSD_M_PX, cli="gsd", label="GSD")
    side_overlap: float = param(0.7, "overlap between lines", ge=0, le=0.95)
    oblique_pitch_deg: float | None = param(None, "add crossed east–west lines with the gimbal at this pitch "
                                            "(e.g. -60): a double grid", ge=-90, lt=0, label="Oblique pitch")


def _build(scene: Scene, camera: Camera, p: LawnmowerParams, safety_distance_m: float, min_height_m: float) -> Plan:
    return lawnmower(scene, camera, altitude_m=p.altitude_m, gsd_m=p.gsd_m_px, front_overlap=p.overlap,
                     side_overlap=p.side_overlap, oblique_pitch_deg=p.oblique_pitch_deg, min_height_m=min_height_m,
                     safety_distance_m=safety_distance_m)


TEMPLATE = Template("lawnmower", "nadir grid", LawnmowerParams, _build, order=2)
