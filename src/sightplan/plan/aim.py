"""Frames that look at nothing: a pure-geometry test of each frame's view against the model's targets.

A frame of a perspective camera sees a target only if some target triangle lies in its
view frustum (in front of the camera, within the image's four edges, nearer than
``VIEW_DISTANCE_M``). The test is conservative: a triangle counts as in view unless all
three of its corners lie outside one of the frustum's planes, and it ignores occlusion. So
a frame it rejects sees no target for certain; one it keeps may still see little. Element
bounding boxes are tested first, so only the triangles of elements that may be in view are
tested one by one. A 360° camera sees every direction: its frames are kept.
"""

from __future__ import annotations

from dataclasses import replace

import numpy as np
from numpy.typing import NDArray

from ..camera.models import PinholeCamera
from ..errors import PlanError
from ..model.scene import Scene
from .types import Mission, Plan

VIEW_DISTANCE_M = 1000.0  # as far as the engines see (their d_max)
BLIND_REASON = "no target element in view"
_TRIANGLE_CAP = 2_000_000  # more candidate triangles than this: taken as seen without testing each
_CHUNK = 4096  # triangles tested at once


def _outcodes(P: NDArray, R: NDArray, C: NDArray, cam: PinholeCamera, far: float) -> NDArray[np.uint8]:
    """(k,) bit per frustum plane that each (k, 3) world point lies outside of (0: inside all six)."""
    q = (P - C) @ R  # camera frame: x right, y down, z forward
    x, y, z = q[:, 0], q[:, 1], q[:, 2]
    left, right = -cam.cx / cam.fx, (cam.width - cam.cx) / cam.fx
    top, bottom = -cam.cy / cam.fy, (cam.height - cam.cy) / cam.fy
    code = np.zeros(len(q), np.uint8)
    code |= (x < left * z).astype(np.uint8)
    code |= (x > right * z).astype(np.uint8) << 1
    code |= (y < top * z).astype(np.uint8) << 2
    code |= (y > bottom * z).astype(np.uint8) << 3
    code |= (z <= 0).astype(np.uint8) << 4
    code |= (z > far).astype(np.uint8) << 5
    return code


def frames_in_view(scene: Scene, plan: Plan, view_distance_m: float = VIEW_DISTANCE_M) -> NDArray[np.bool_]:
    """(n,) whether some target triangle may lie in each frame's view (see the module docstring)."""
    n = len(plan)
    seen = np.ones(n, bool)
    mask = scene.targets[scene.face_element] if len(scene.faces) else np.zeros(0, bool)
    if not mask.any():
        return np.zeros(n, bool)
    faces = scene.faces[mask]
    elem = scene.face_element[mask]
    order = np.argsort(elem, kind="stable")
    faces, elem = faces[order], elem[order]
    starts = np.flatnonzero(np.r_[True, elem[1:] != elem[:-1]])
    stops = np.r_[starts[1:], len(elem)]
    tri = scene.vertices[faces]  # (F, 3, 3)
    lo = np.minimum.reduceat(tri.min(axis=1), starts)
    hi = np.maximum.reduceat(tri.max(axis=1), starts)
    corners = np.stack([np.where(np.array([(k >> a) & 1 for a in range(3)], bool), hi, lo) for k in range(8)], axis=1)
    for i in range(n):
        cam = plan.camera_of(i)
        if not isinstance(cam, PinholeCamera):
            continue
        R, C = plan.R_world_camera[i], plan.C_world[i]
        box_code = np.bitwise_and.reduce(_outcodes(corners.reshape(-1, 3), R, C, cam, view_distance_m).reshape(-1, 8),
                                         axis=1)
        cand = np.flatnonzero(box_code == 0)
        if not len(cand):
            seen[i] = False
            continue
        counts = stops[cand] - starts[cand]
        if counts.sum() > _TRIANGLE_CAP:
            continue
        seen[i] = False
        ends = np.cumsum(counts)
        first = 0
        while first < len(cand) and not seen[i]:  # elements in chunks of about _CHUNK triangles, until one is in view
            last = int(np.searchsorted(ends, (ends[first - 1] if first else 0) + _CHUNK, side="right"))
            last = max(last, first + 1)
            rows = np.concatenate([np.arange(starts[k], stops[k]) for k in cand[first:last]])
            code = _outcodes(tri[rows].reshape(-1, 3), R, C, cam, view_distance_m).reshape(-1, 3)
            seen[i] = bool((np.bitwise_and.reduce(code, axis=1) == 0).any())
            first = last
    return seen


def keep_frames(plan: Plan, keep: NDArray) -> Plan:
    """The plan with only the frames ``keep`` (sorted indices), missions cut to match (empty ones left out),
    frames renamed in order. Waypoints go with their frames when the plan has one per frame."""
    keep = np.asarray(keep, int)
    count = np.zeros(len(plan) + 1, int)
    count[keep + 1] = 1
    before = np.cumsum(count)  # before[i]: frames kept among 0..i−1
    missions = tuple(Mission(m.name, int(before[m.start]), int(before[m.stop]), m.ground_station)
                     for m in plan.missions if before[m.stop] > before[m.start])
    waypoints = plan.waypoints[keep] if len(plan.waypoints) == len(plan) else plan.waypoints
    sub = plan.subset(keep)
    names = np.array([f"frame_{i:05d}" for i in range(len(keep))] + [None], dtype=object)[:-1]
    return replace(sub, missions=missions, waypoints=waypoints, frame_names=names)


def drop_blind_frames(scene: Scene, plan: Plan, what: str = "plan") -> Plan:
    """The plan without the frames that see no target (:func:`frames_in_view`); the count and the reason are
    recorded in its parameters (``dropped_frames``, ``dropped_reason``). A plan none of whose frames sees a target
    is refused."""
    seen = frames_in_view(scene, plan)
    if len(plan) and not seen.any():
        raise PlanError(f"no frame of the {what} has a target element of the model in view")
    out = plan if seen.all() else keep_frames(plan, np.flatnonzero(seen))
    params = {**plan.parameters, "dropped_frames": int((~seen).sum())}
    if not seen.all():
        params["dropped_reason"] = BLIND_REASON
    return replace(out, parameters=params)
