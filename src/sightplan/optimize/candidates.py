"""Candidate views: where an optimised plan may take its frames.

The target surfaces are cut into *anchors*: their triangles grouped by a voxel grid (``spacing_m``, by default a
sixth of the image's footprint at the safety distance) and by which of 26 directions their normal is nearest, each
anchor the area-weighted centre and normal of its group. From each anchor, views stand on the anchor's normal at
each distance of ``distances_m`` (by default the safety distance and a quarter more, as long as a head-on view still
meets the surface sampling target) and turned ``oblique_deg`` to either side about the vertical (for a wall) or
tilted toward the four horizontal directions (for a roof or a floor), each looking back at its anchor. A view is
kept when it stands at least the safety distance from every triangle but the terrain's (exact distances), at least
the minimum height above the ground under it (a view lower than that rises to it, still looking at its anchor), below
the altitude limit, with the gimbal within its pitch range, and
when no kept view already stands within ``spacing_m / 4`` of it looking the same way (within 10°).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from ..camera.models import Camera, PinholeCamera
from ..errors import PlanError
from ..geometry.poses import R_from_gimbal, aim_angles
from ..model.scene import Scene
from ..plan.checks.safety import point_distances
from ..plan.domain import check_work
from ..plan.ground import ground_z, without_terrain
from ..plan.types import Mission, Plan

OBLIQUE_DEG = 30.0
PITCH_RANGE_DEG = (-90.0, 30.0)  # a drone gimbal's: straight down to 30° up
MAX_CANDIDATES = 20_000
MAX_SCREENED = 50 * MAX_CANDIDATES  # candidates made before the filters keep at most MAX_CANDIDATES of them
_DIRECTIONS = np.array([(x, y, z) for x in (-1, 0, 1) for y in (-1, 0, 1) for z in (-1, 0, 1) if (x, y, z) != (0, 0, 0)],
                       float)
_DIRECTIONS /= np.linalg.norm(_DIRECTIONS, axis=1, keepdims=True)


@dataclass(frozen=True)
class Anchors:
    """(a, 3) centres and unit normals of the target surface patches views aim at, and their areas (m²)."""

    centre: NDArray[np.float64]
    normal: NDArray[np.float64]
    area: NDArray[np.float64]


STANDOFF_M = 1e-3  # views stand this much beyond their distance, so the checks' strict test holds

def footprint_m(camera: Camera, distance_m: float) -> float:
    """The width a head-on frame covers at ``distance_m`` (m)."""
    return distance_m * camera.width / camera.sampling_focal_px


def surface_anchors(scene: Scene, spacing_m: float) -> Anchors:
    """The target surfaces as patches no larger than about ``spacing_m`` (see the module docstring)."""
    mask = scene.targets[scene.face_element] if len(scene.faces) else np.zeros(0, bool)
    if not mask.any():
        raise PlanError("the model has no target surfaces to plan views of")
    tri = scene.vertices[scene.faces[mask]].astype(np.float64)
    cross = np.cross(tri[:, 1] - tri[:, 0], tri[:, 2] - tri[:, 0])
    area = 0.5 * np.linalg.norm(cross, axis=1)
    keep = area > 1e-9
    tri, cross, area = tri[keep], cross[keep], area[keep]
    normal = cross / (2 * area[:, None])
    centre = tri.mean(axis=1)
    cell = np.floor((centre - centre.min(axis=0)) / spacing_m).astype(np.int64)
    bin_ = np.argmax(normal @ _DIRECTIONS.T, axis=1)
    key = ((cell[:, 0] * 1_000_003 + cell[:, 1]) * 1_000_003 + cell[:, 2]) * 32 + bin_
    _, group = np.unique(key, return_inverse=True)
    total = np.bincount(group, weights=area)
    c = np.stack([np.bincount(group, weights=area * centre[:, j]) for j in range(3)], axis=1) / total[:, None]
    nsum = np.stack([np.bincount(group, weights=area * normal[:, j]) for j in range(3)], axis=1)
    length = np.linalg.norm(nsum, axis=1)
    flat = length > 0.5 * total  # the group's faces agree on a direction
    n = nsum[flat] / length[flat, None]
    return Anchors(c[flat], n, total[flat])


def _variants(normal: NDArray, oblique_deg: float) -> list[NDArray]:
    """(a, 3) unit directions from each anchor to its views: the normal, then turned or tilted by ``oblique_deg``."""
    out = [normal]
    if oblique_deg <= 0:
        return out
    t = math.radians(oblique_deg)
    wall = np.abs(normal[:, 2]) < 0.9
    for sign in (1, -1):  # walls: turned about the vertical
        c, s = math.cos(sign * t), math.sin(sign * t)
        turned = np.stack([c * normal[:, 0] - s * normal[:, 1], s * normal[:, 0] + c * normal[:, 1], normal[:, 2]], 1)
        out.append(np.where(wall[:, None], turned, np.nan))
    for axis in ((1, 0), (-1, 0), (0, 1), (0, -1)):  # roofs and floors: tilted toward a horizontal direction
        h = np.array([axis[0], axis[1], 0.0])
        tilted = math.cos(t) * normal + math.sin(t) * h
        tilted /= np.linalg.norm(tilted, axis=1, keepdims=True)
        out.append(np.where(wall[:, None], np.nan, tilted))
    return out


def _gimbal(C: NDArray, look_at: NDArray) -> tuple[NDArray, NDArray]:
    """(n,) heading (0…360) and pitch, degrees, from each view at C to its look_at."""
    heading, pitch = aim_angles(C, look_at)
    return heading % 360, pitch


@dataclass(frozen=True)
class CandidateSet:
    """The candidate views as a plan (one mission, frames in no particular order), the anchor each aims at, and
    how many positions each filter removed."""

    plan: Plan
    anchor: NDArray[np.int64]
    anchors: Anchors
    dropped: dict[str, int]


def candidate_views(scene: Scene, camera: Camera, safety_distance_m: float, *, distances_m: list[float] | None = None,
                    max_ssd_m_px: float | None = None, spacing_m: float | None = None,
                    oblique_deg: float = OBLIQUE_DEG, min_height_m: float | None = 2.0,
                    altitude_limit_m: float | None = None) -> CandidateSet:
    """Candidate views around ``scene``'s targets (see the module docstring)."""
    if not isinstance(camera, PinholeCamera):
        raise PlanError("optimised plans need a perspective (pinhole) camera")
    g = float(safety_distance_m)
    if not (g > 0 and math.isfinite(g)):
        raise PlanError(f"the safety distance must be a positive number of metres, got {safety_distance_m!r}")
    f = camera.sampling_focal_px
    if distances_m is None:
        reach = (max_ssd_m_px * f) if max_ssd_m_px else 1.5 * g  # head-on, the farthest view that meets the SSD
        distances_m = sorted({g, min(max(g, 0.95 * reach), 1.25 * g)})
    if not distances_m or not all(d >= g and math.isfinite(d) for d in distances_m):
        raise PlanError(f"candidate distances must be at least the safety distance ({g:g} m), got {distances_m}")
    spacing = float(spacing_m) if spacing_m else footprint_m(camera, g) / 6
    anchors = surface_anchors(scene, spacing)
    dirs = _variants(anchors.normal, oblique_deg)
    check_work(len(anchors.centre) * len(dirs) * len(distances_m), MAX_SCREENED, f"a spacing of {spacing:.3g} m",
               "the spacing (or the safety distance)", "candidate views to screen")
    C, look_at, which = [], [], []
    for d in distances_m:
        for u in dirs:
            ok = np.isfinite(u).all(axis=1)
            C.append(anchors.centre[ok] + (d + STANDOFF_M) * u[ok])  # a millimetre out: clear of rounding
            look_at.append(anchors.centre[ok])
            which.append(np.flatnonzero(ok))
    C, look_at, which = np.concatenate(C), np.concatenate(look_at), np.concatenate(which)
    kept, C, look_at, dropped = _kept_views(scene, C, look_at, g, spacing, min_height_m, altitude_limit_m)
    which = which[kept]
    check_work(len(C), MAX_CANDIDATES, f"a spacing of {spacing:.3g} m", "the spacing (or the safety distance)",
               "candidate views")
    if not len(C):
        raise PlanError("no candidate view stands clear of the model at the safety distance and above the minimum "
                        "height: lower the safety distance")
    plan = _views_plan(camera, C, look_at, "candidate",
                       {"template": "candidates", "safety_distance_m": g,
                        "distances_m": [float(d) for d in distances_m], "spacing_m": spacing,
                        "oblique_deg": oblique_deg})
    return CandidateSet(plan, which.astype(np.int64), anchors, dropped)


def _kept_views(scene: Scene, C: NDArray, look_at: NDArray, g: float, spacing: float, min_height_m: float | None,
                altitude_limit_m: float | None) -> tuple[NDArray, NDArray, NDArray, dict[str, int]]:
    """The views at ``C`` looking at ``look_at`` that pass the filters of the module docstring: the indices kept,
    their (possibly raised) positions, their targets, and how many each filter removed."""
    C = np.array(C, np.float64).reshape(-1, 3)
    look_at = np.asarray(look_at, np.float64).reshape(-1, 3)
    idx = np.arange(len(C))
    dropped: dict[str, int] = {}

    def keep(mask: NDArray, why: str) -> None:
        nonlocal C, look_at, idx, ground
        dropped[why] = dropped.get(why, 0) + int((~mask).sum())
        C, look_at, idx, ground = C[mask], look_at[mask], idx[mask], ground[mask]

    ground = ground_z(scene, C) if len(C) else np.zeros(0)
    if min_height_m is not None:  # a view below the minimum height rises to it, still looking at its anchor
        C[:, 2] = np.maximum(C[:, 2], ground + min_height_m)
    pitch = _gimbal(C, look_at)[1]
    keep((pitch >= PITCH_RANGE_DEG[0]) & (pitch <= PITCH_RANGE_DEG[1]), "beyond the gimbal's pitch range")
    if altitude_limit_m is not None:
        keep(C[:, 2] - ground <= altitude_limit_m, "above the altitude limit")
    if len(C):
        keep(point_distances(without_terrain(scene), C) >= g, "nearer the model than the safety distance")
    if len(C):  # near-duplicates: one view per (position cell, direction bin)
        heading, pitch = _gimbal(C, look_at)
        cell = np.floor(C / (spacing / 4)).astype(np.int64)
        key = np.stack([*cell.T, np.floor(heading / 10).astype(np.int64), np.floor((pitch + 90) / 10).astype(np.int64)], 1)
        _, first = np.unique(key, axis=0, return_index=True)
        mask = np.zeros(len(C), bool)
        mask[first] = True
        keep(mask, "duplicates")
    return idx, C, look_at, dropped


def _views_plan(camera: Camera, C: NDArray, look_at: NDArray, prefix: str, parameters: dict) -> Plan:
    R = R_from_gimbal(*_gimbal(C, look_at), 0.0)
    return Plan.build(camera, R, C, missions=(Mission("candidates", 0, len(C)),),
                      frame_names=[f"{prefix}_{i:05d}" for i in range(len(C))], parameters=parameters)


def aimed_views(scene: Scene, camera: Camera, safety_distance_m: float, elements: NDArray, seen_from: list[NDArray],
                spacing_m: float, *, min_height_m: float | None = 2.0,
                altitude_limit_m: float | None = None) -> Plan | None:
    """More views for targets the candidates see but cannot meet: from each position in ``seen_from[j]`` (the
    centres of the views that see ``elements[j]``), and from four positions ``spacing_m`` to its sides and above
    and below it, a view aimed at the element's centre (its faces' area-weighted centroid); and two head-on views
    from in front of the element, along the area-weighted normal of its faces turned towards those positions, at the
    safety distance and a quarter beyond. The same filters as :func:`candidate_views`. None when none is left."""
    g = float(safety_distance_m)
    areas = scene.face_areas()
    normals = scene.face_normals()
    centroids = scene.vertices[scene.faces].mean(axis=1)
    elements = np.asarray(elements, np.int64)
    by_element = np.argsort(scene.face_element, kind="stable")  # each element's faces together, in face order
    bounds = np.searchsorted(scene.face_element[by_element], np.stack([elements, elements + 1]))
    C, look_at = [], []
    for (lo, hi), P in zip(bounds.T, seen_from, strict=True):
        sel = by_element[lo:hi]
        if not len(sel) or not len(P):
            continue
        a = areas[sel]
        centre = (centroids[sel] * a[:, None]).sum(axis=0) / max(a.sum(), 1e-300)
        P = np.asarray(P, np.float64).reshape(-1, 3)
        u = centre - P
        u /= np.maximum(np.linalg.norm(u, axis=1, keepdims=True), 1e-12)
        side = np.cross(u, [0.0, 0.0, 1.0])
        side /= np.maximum(np.linalg.norm(side, axis=1, keepdims=True), 1e-12)
        up = np.cross(side, u)
        for shift in (np.zeros_like(side), side, -side, up, -up):
            C.append(P + spacing_m * shift)
            look_at.append(np.broadcast_to(centre, P.shape))
        facing = normals[sel] @ (P.mean(axis=0) - centre) > 0  # the element's faces turned towards those that see it
        n = (normals[sel][facing] * a[facing, None]).sum(axis=0)
        if np.linalg.norm(n) > 1e-9:
            n /= np.linalg.norm(n)
            C.append(centre + np.outer((g + STANDOFF_M) * np.array([1.0, 1.25]), n))
            look_at.append(np.broadcast_to(centre, (2, 3)))
    if not C:
        return None
    _, C, look_at, _ = _kept_views(scene, np.concatenate(C), np.concatenate(look_at), g, spacing_m, min_height_m,
                                   altitude_limit_m)
    if not len(C):
        return None
    return _views_plan(camera, C, look_at, "aimed", {"template": "candidates", "safety_distance_m": g})
