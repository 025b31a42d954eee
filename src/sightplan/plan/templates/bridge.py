"""Bridge / linear structure: passes along an axis on both sides, and one under the deck.

The axis is a polyline in the model frame (x, y; a third column is ignored). Each side
pass runs parallel to it at the horizontal distance ``offset_m`` (mitred at the bends, so
every point of a piece is ``offset_m`` from its axis segment), the camera level and
looking perpendicular at the axis; frames are spread evenly along the pass no more than
s_h apart (eq. 11 with the horizontal field of view at distance ``offset_m``, measured
from the axis: the structure's near edge is closer, where the overlap is lower). The side
passes are at ``heights_m``, by default layers no more than s_v apart (eq. 11, vertical
field of view, distance ``offset_m``) from ``min_height_m`` above the highest ground under
the passes (or the targets' base, if higher) to the targets' top. A pass lower than
``min_height_m`` above the ground is refused, the under-deck pass included. Frames that
see no target are dropped unless ``drop_blind`` is False.

The under-deck pass runs along the axis itself at ``deck_z − clearance_below_m``, the
camera looking straight up (pitch +90°, heading the flight direction: tilted up from
level, the image's bottom points ahead), frames no more than eq. 11 apart with the
vertical field of view at the clearance. Without
``deck_z``, the underside is found on vertical lines through the pass's frames: the
highest downward-facing model surface with at least twice the clearance of open space
below it (down to the next surface or the model's base); ``deck_z`` is the lowest such
underside along the axis. The pass is refused (PlanError) where some frame has no such
surface (a pier or the ground under the axis) or where, by exact distances, it comes
closer to the model than the clearance.

Missions, in flight order: the left side (left of the axis's direction) bottom to top,
the right side top to bottom, then the under-deck pass; directions alternate from pass
to pass (a snake), the first pass from the axis's first point.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike, NDArray

from ...camera.models import Camera, PinholeCamera
from ...errors import PlanError
from ...geometry.poses import R_from_gimbal
from ...model.scene import Scene
from ..aim import drop_blind_frames
from ..checks.safety import point_distances, segment_distances
from ..domain import MAX_HEIGHT_M
from ..ground import MIN_HEIGHT_M, ground_z, targets_only
from ..types import Mission, Plan
from .base import Params, Template, param
from .facade import _positions, _valid_min_height, layer_heights
from .spacing import check_frame_budget, waypoint_spacing

CLEARANCE_BELOW_M = 3.0
MAX_TURN_DEG = 90.0


def _axis(axis_xy: ArrayLike) -> tuple[NDArray, NDArray]:
    """(k, 2) axis points and (k − 1, 2) unit directions of its segments, validated."""
    try:
        P = np.asarray(axis_xy, float)
    except (TypeError, ValueError):
        raise PlanError("a bridge axis must be a list of (x, y) or (x, y, z) points of one length") from None
    if P.ndim != 2 or P.shape[1] not in (2, 3) or len(P) < 2 or not np.isfinite(P).all():
        raise PlanError("a bridge axis needs at least two finite (x, y) or (x, y, z) points")
    P = P[:, :2]
    seg = np.diff(P, axis=0)
    seg_len = np.linalg.norm(seg, axis=1)
    if (seg_len == 0).any():
        raise PlanError(f"bridge axis point {int(np.flatnonzero(seg_len == 0)[0]) + 1} repeats the one before it (in x, y)")
    u = seg / seg_len[:, None]
    turn = np.degrees(np.arccos(np.clip(np.einsum("ij,ij->i", u[:-1], u[1:]), -1, 1)))
    if (turn > MAX_TURN_DEG).any():
        k = int(np.argmax(turn))
        raise PlanError(f"the bridge axis turns by {turn[k]:.0f}° at point {k + 1}; at most {MAX_TURN_DEG:g}° is supported")
    return P, u


def _offset(P: NDArray, u: NDArray, d: float) -> NDArray:
    """(k, 2) polyline ``d`` to the left of the axis (negative: right), mitred at the bends."""
    n = np.stack([-u[:, 1], u[:, 0]], axis=1)
    mitre = (n[:-1] + n[1:]) / (1 + np.einsum("ij,ij->i", n[:-1], n[1:]))[:, None]
    V = P + d * np.concatenate([n[:1], mitre, n[-1:]])
    back = np.einsum("ij,ij->i", np.diff(V, axis=0), u) <= 0
    if back.any():
        k = int(np.flatnonzero(back)[0])
        raise PlanError(f"bridge axis segment {k + 1} is too short for an offset of {abs(d):g} m on the inside of its bends")
    return V


def _sample(V: NDArray, step: float) -> tuple[NDArray, NDArray, NDArray]:
    """Points evenly along polyline ``V`` no more than ``step`` apart, ends included: (n, 2) points,
    (n,) index of the segment each lies on, (n,) distance along the polyline."""
    seg = np.diff(V, axis=0)
    seg_len = np.linalg.norm(seg, axis=1)
    ends = np.cumsum(seg_len)
    s = _positions(float(ends[-1]), step)
    k = np.minimum(np.searchsorted(ends, s, side="left"), len(seg) - 1)
    return V[k] + seg[k] * ((s - (ends[k] - seg_len[k])) / seg_len[k])[:, None], k, s


def deck_underside(scene: Scene, xy: NDArray, clearance_m: float) -> NDArray[np.float64]:
    """(n,) z of the deck's underside above each (n, 2) point: the highest downward-facing surface
    crossed by the vertical line with at least 2·clearance of open space below it (to the next
    surface crossed, or the model's base). NaN where the line crosses nothing; −inf where it
    crosses the model but no surface qualifies (a pier or the ground under the point)."""
    tri = scene.vertices[scene.faces].astype(float)
    nz = scene.face_normals()[:, 2]
    base = scene.bounds()[0][2]
    xy = np.asarray(xy, float).reshape(-1, 2)
    tol = 1e-9
    lo2, hi2 = tri[:, :, :2].min(axis=1), tri[:, :, :2].max(axis=1)
    keep = (nz != 0) & (lo2 <= xy.max(axis=0) + tol).all(axis=1) & (hi2 >= xy.min(axis=0) - tol).all(axis=1)
    tri, nz, lo2, hi2 = tri[keep], nz[keep], lo2[keep], hi2[keep]  # vertical faces are met only along their edges
    out = np.full(len(xy), np.nan)
    for i, p in enumerate(xy):
        cand = np.flatnonzero(((lo2 <= p + tol) & (hi2 >= p - tol)).all(axis=1))
        if not len(cand):
            continue
        t = tri[cand]
        v0, v1, v2 = t[:, 1, :2] - t[:, 0, :2], t[:, 2, :2] - t[:, 0, :2], p - t[:, 0, :2]
        den = v0[:, 0] * v1[:, 1] - v1[:, 0] * v0[:, 1]
        with np.errstate(divide="ignore", invalid="ignore"):
            l1 = (v2[:, 0] * v1[:, 1] - v1[:, 0] * v2[:, 1]) / den
            l2 = (v0[:, 0] * v2[:, 1] - v2[:, 0] * v0[:, 1]) / den
        l0 = 1 - l1 - l2
        hit = (den != 0) & (l0 >= -tol) & (l1 >= -tol) & (l2 >= -tol)
        if not hit.any():
            continue
        z = (l0[:, None] * t[:, 0] + l1[:, None] * t[:, 1] + l2[:, None] * t[:, 2])[hit, 2]
        down = nz[cand][hit] < 0
        # a line through a shared edge meets both triangles: one crossing per height and facing
        zd = np.unique(np.stack([np.round(z, 6), down], axis=1), axis=0)
        z, down = zd[:, 0], zd[:, 1].astype(bool)
        below = np.where(z[None, :] <= z[:, None], z[None, :], -np.inf)
        np.fill_diagonal(below, -np.inf)
        space = z - np.maximum(below.max(axis=1), base)
        ok = down & (space >= 2 * clearance_m)
        out[i] = z[ok].max() if ok.any() else -np.inf
    return out


def bridge(scene: Scene, camera: Camera, axis_xy: ArrayLike, offset_m: float, heights_m: list[float] | None = None,
           under_deck: bool = True, overlap: float = 0.8, deck_z: float | None = None,
           clearance_below_m: float = CLEARANCE_BELOW_M, min_height_m: float = MIN_HEIGHT_M,
           drop_blind: bool = True) -> Plan:
    """Side passes along ``axis_xy`` at ``offset_m`` and ``heights_m``, plus an under-deck pass; see the module docstring."""
    if not isinstance(camera, PinholeCamera):
        raise PlanError("a bridge plan needs a perspective (pinhole) camera")
    if not (offset_m > 0 and math.isfinite(offset_m)):
        raise PlanError(f"the offset from the bridge axis must be a positive number of metres, got {offset_m}")
    P, u = _axis(axis_xy)
    d = float(offset_m)
    min_h = _valid_min_height(min_height_m)
    lo, hi = targets_only(scene).bounds()
    s_h = waypoint_spacing(d, camera.hfov_deg, overlap)
    s_v = waypoint_spacing(d, camera.vfov_deg, overlap)
    length = float(np.linalg.norm(np.diff(P, axis=0), axis=1).sum()) + 2 * d * len(P)  # a pass is no longer
    layers = len(heights_m) if heights_m is not None else max(float(hi[2] - lo[2]), 0.0) / s_v + 2
    under = (length / waypoint_spacing(clearance_below_m, camera.vfov_deg, overlap) + 2
             if under_deck and clearance_below_m > 0 and math.isfinite(clearance_below_m) else 0)
    check_frame_budget(2 * (length / s_h + 2) * layers + under, f"a bridge plan along {length:,.0f} m of axis",
                       "the axis, height_m or the overlap")
    sides = [(side, sign, *_sample(_offset(P, u, sign * d), s_h)) for side, sign in (("left", 1.0), ("right", -1.0))]
    floor = float(ground_z(scene, np.concatenate([xy for _, _, xy, _, _ in sides])).max()) + min_h
    if heights_m is None:
        heights = layer_heights(max(float(lo[2]), floor), float(hi[2]), s_v)
    else:
        heights = np.asarray(heights_m, float).reshape(-1)
        if not len(heights) or not np.isfinite(heights).all():
            raise PlanError("give at least one finite height for the bridge's side passes")
        if heights.min() < floor - 1e-6:
            raise PlanError(f"bridge pass height {heights.min():g} m is below the minimum height, {min_h:g} m above "
                            f"the ground (z = {floor:.2f} m); raise it")
    passes = []  # (name, (n, 3) centres in the axis's direction, (n,) heading, (n,) pitch, (n,) heading if reversed)
    for side, sign, xy, k, _ in sides:
        zs = heights if sign > 0 else heights[::-1]
        look = -sign * np.stack([-u[k, 1], u[k, 0]], axis=1)
        h = np.degrees(np.arctan2(look[:, 0], look[:, 1])) % 360.0
        for z in zs:
            passes.append((f"bridge {side} {z:.1f} m", np.column_stack([xy, np.full(len(xy), z)]), h, np.zeros(len(xy)), h))
    params = {"template": "bridge", "axis_xy": P.tolist(), "offset_m": d, "heights_m": [float(z) for z in heights],
              "under_deck": bool(under_deck), "overlap": overlap, "spacing_along_m": s_h, "spacing_vertical_m": s_v,
              "min_height_m": min_h}
    if under_deck:
        passes.append(_under_deck(scene, camera, P, u, overlap, deck_z, clearance_below_m, params))
        under = passes[-1][1]
        low = float(ground_z(scene, under).max()) + min_h
        if under[0, 2] < low - 1e-6:
            raise PlanError(f"the under-deck pass at z = {under[0, 2]:.2f} m is below the minimum height, {min_h:g} m "
                            f"above the ground (z = {low:.2f} m); give another deck_z, or under_deck=False")
    C, heading, pitch, missions = [], [], [], []
    for j, (name, c, h, p, h_back) in enumerate(passes):
        if j % 2:  # snake: every other pass flown from the axis's last point back to its first
            c, h, p = c[::-1], h_back[::-1], p[::-1]
        missions.append(Mission(name, len(C), len(C) + len(c)))
        C.extend(c.tolist())
        heading.extend(h.tolist())
        pitch.extend(p.tolist())
    C = np.asarray(C)
    plan = Plan.build(camera, R_from_gimbal(np.asarray(heading), np.asarray(pitch), 0.0), C, missions=tuple(missions),
                      waypoints=C, parameters=params)
    return drop_blind_frames(scene, plan, "bridge plan") if drop_blind else plan


def _under_deck(scene: Scene, camera: PinholeCamera, P: NDArray, u: NDArray, overlap: float, deck_z: float | None,
                clearance: float, params: dict) -> tuple:
    """The under-deck pass (as a side pass's tuple); records its height and spacing in ``params``."""
    if not (clearance > 0 and math.isfinite(clearance)):
        raise PlanError(f"the clearance below the deck must be a positive number of metres, got {clearance}")
    step = waypoint_spacing(clearance, camera.vfov_deg, overlap)
    xy, k, s = _sample(P, step)
    if deck_z is None:
        under = deck_underside(scene, xy, clearance)
        if np.isnan(under).all():
            raise PlanError("the under-deck pass has nothing of the model above the axis to fly under")
        if (under == -np.inf).any():
            i = int(np.flatnonzero(under == -np.inf)[0])
            raise PlanError(f"no room for the under-deck pass {s[i]:.1f} m along the axis: no underside with "
                            f"{2 * clearance:g} m of open space below it (a pier or the ground?); give deck_z, "
                            "a shorter axis, or under_deck=False")
        deck_z = float(np.nanmin(under))
    elif not math.isfinite(deck_z):
        raise PlanError(f"the deck's underside must be a finite height, got {deck_z}")
    z = float(deck_z) - clearance
    C = np.column_stack([xy, np.full(len(xy), z)])
    dist = segment_distances(scene, C[:-1], C[1:]) if len(C) > 1 else point_distances(scene, C)
    if (dist < clearance * (1 - 1e-9)).any():
        i = int(np.argmin(dist))
        raise PlanError(f"the under-deck pass at z = {z:.2f} m comes {dist[i]:.2f} m from the model {s[i]:.1f} m along "
                        f"the axis (clearance {clearance:g} m); give another deck_z, a shorter axis, or under_deck=False")
    h = np.degrees(np.arctan2(u[k, 0], u[k, 1])) % 360.0
    params.update({"deck_z": float(deck_z), "under_deck_z": z, "clearance_below_m": float(clearance), "spacing_under_m": step})
    return "bridge under deck", C, h, np.full(len(C), 90.0), (h + 180.0) % 360.0


@dataclass(frozen=True)
class BridgeParams(Params):
    axis: tuple[tuple[float, float], ...] = param((), "the axis, in order", kind="points2",
                                                  cli="point", label="Axis")
    overlap: float = param(0.8, "image overlap l between neighbouring frames", ge=0, le=0.95)
    height_m: tuple[float, ...] = param((), "height of a side pass, once per pass (default: layers by overlap)",
                                        kind="numbers", label="Pass heights", ge=-MAX_HEIGHT_M, le=MAX_HEIGHT_M)
    under_deck: bool = param(True, "add a pass under the deck, looking up")
    deck_z_m: float | None = param(None, "height of the deck's underside (default: found)", label="Deck underside z",
                                   ge=-MAX_HEIGHT_M, le=MAX_HEIGHT_M)


def _build(scene: Scene, camera: Camera, p: BridgeParams, safety_distance_m: float, min_height_m: float) -> Plan:
    if len(p.axis) < 2:
        raise PlanError("a bridge needs its axis: at least two points (x, y), in order")
    return bridge(scene, camera, [list(a) for a in p.axis], safety_distance_m, heights_m=list(p.height_m) or None,
                  under_deck=p.under_deck, overlap=p.overlap, deck_z=p.deck_z_m, min_height_m=min_height_m)


TEMPLATE = Template("bridge", "passes along an axis", BridgeParams, _build, order=3)
