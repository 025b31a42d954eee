"""Which image pairs the SfM matches: views that see the same surface points at angles SIFT can match.

Each frame's depth map (the renders' ``depth.npz``) is thinned to a coarse grid of about :data:`SAMPLES_ACROSS`
cells across; every cell that shows a surface gives one sample, the world point its centre ray meets. Frame j
*shares* a sample of frame i when the point projects inside j's image, in front of it, is not hidden there (its
distance from j is at most j's coarse depth at that pixel plus :data:`DEPTH_TOLERANCE` of it) and the two rays to it
differ by at most :data:`MAX_RAY_ANGLE_DEG`. ``shared[i, j]`` is the share of i's samples that j shares; the
overlap of a pair is the geometric mean of ``shared[i, j]`` and ``shared[j, i]``.

Each frame is paired with its :data:`OVERLAP_NEIGHBOURS` best partners by overlap, and with its
:data:`TURNED_NEIGHBOURS` best partners among those whose optical axis is turned by more than :data:`TURNED_DEG`
from its own (the views round a corner, a top row looking down, another mission's pass), any partner needing an
overlap of at least :data:`MIN_OVERLAP`. Nearness of camera centres or plan order plays no part, so the sides of a
building are linked wherever their views see the same corner.
"""

from __future__ import annotations

import math
from collections.abc import Iterable, Sequence

import numpy as np
from numpy.typing import NDArray

from ..camera.models import PinholeCamera

SAMPLES_ACROSS = 32
DEPTH_TOLERANCE = 0.03
MAX_RAY_ANGLE_DEG = 50.0
OVERLAP_NEIGHBOURS = 20
TURNED_NEIGHBOURS = 8
TURNED_DEG = 30.0
MIN_OVERLAP = 0.05


def coarse_step(cam: PinholeCamera, across: int = SAMPLES_ACROSS) -> int:
    """The pixel step that leaves about ``across`` cells across the image."""
    return max(1, math.ceil(cam.width / across))


def coarse_depth(depth: NDArray, step: int) -> NDArray[np.float32]:
    """(h, w) the depth at the centre pixel of each step × step cell of an (H, W) depth map (inf: sky)."""
    return np.ascontiguousarray(np.asarray(depth, np.float32)[step // 2::step, step // 2::step])


def frame_samples(cam: PinholeCamera, R: NDArray, C: NDArray, depth_small: NDArray, step: int) -> NDArray[np.float64]:
    """(m, 3) world points seen by the centre pixels of the cells of a coarse depth map (:func:`coarse_depth`)."""
    h, w = depth_small.shape
    u = np.arange(w) * step + step // 2 + 0.5
    v = np.arange(h) * step + step // 2 + 0.5
    uu, vv = np.meshgrid(u, v)
    hit = np.isfinite(depth_small)
    d = np.column_stack([(uu[hit] - cam.cx) / cam.fx, (vv[hit] - cam.cy) / cam.fy, np.ones(int(hit.sum()))])
    d /= np.linalg.norm(d, axis=1, keepdims=True)
    return np.asarray(C, float) + depth_small[hit].astype(np.float64)[:, None] * (d @ np.asarray(R, float).T)


def shared_samples(cameras: Sequence[PinholeCamera], R: NDArray, C: NDArray, depths: Iterable[NDArray],
                   across: int = SAMPLES_ACROSS, max_ray_angle_deg: float = MAX_RAY_ANGLE_DEG,
                   depth_tolerance: float = DEPTH_TOLERANCE) -> NDArray[np.float64]:
    """(n, n) share of frame i's samples that frame j sees too (module docstring); ``cameras[i]``, ``R[i]``
    (world from camera), ``C[i]`` and the (H, W) distance map ``depths[i]`` (inf: sky) describe frame i."""
    R, C = np.asarray(R, float), np.asarray(C, float)
    n = len(cameras)
    steps = [coarse_step(cam, across) for cam in cameras]
    small = [coarse_depth(dm, s) for dm, s in zip(depths, steps, strict=True)]
    pts = [frame_samples(cameras[i], R[i], C[i], small[i], steps[i]) for i in range(n)]
    counts = np.array([len(p) for p in pts])
    shared = np.zeros((n, n))
    if counts.sum() == 0:
        return shared
    P = np.concatenate(pts)
    owner = np.repeat(np.arange(n), counts)
    to_owner = P - C[owner]
    to_owner /= np.linalg.norm(to_owner, axis=1, keepdims=True)
    cos_max = math.cos(math.radians(max_ray_angle_deg))
    for j in range(n):
        cam, s, dj = cameras[j], steps[j], small[j]
        rel = P - C[j]
        x = rel @ R[j]  # camera coordinates
        z = x[:, 2]
        front = z > 1e-9
        with np.errstate(divide="ignore", invalid="ignore"):
            u = np.where(front, cam.fx * x[:, 0] / z + cam.cx, -1.0)
            v = np.where(front, cam.fy * x[:, 1] / z + cam.cy, -1.0)
        inside = front & (u >= 0) & (u < cam.width) & (v >= 0) & (v < cam.height)
        k = np.flatnonzero(inside)
        cu = np.minimum((u[k] // s).astype(np.int64), dj.shape[1] - 1)
        cv = np.minimum((v[k] // s).astype(np.int64), dj.shape[0] - 1)
        dist = np.linalg.norm(rel[k], axis=1)
        seen = dist <= dj[cv, cu] * (1 + depth_tolerance)
        k = k[seen]
        ray = rel[k] / dist[seen][:, None]
        k = k[np.einsum("ij,ij->i", ray, to_owner[k]) >= cos_max]
        shared[:, j] = np.bincount(owner[k], minlength=n) / np.maximum(counts, 1)
    np.fill_diagonal(shared, 0.0)
    return shared


def overlap_pairs(shared: NDArray, axes: NDArray, k: int = OVERLAP_NEIGHBOURS, k_turned: int = TURNED_NEIGHBOURS,
                  turned_deg: float = TURNED_DEG, min_overlap: float = MIN_OVERLAP) -> list[tuple[int, int]]:
    """Image pairs (i < j) to match from ``shared`` (:func:`shared_samples`) and the (n, 3) unit optical axes: each
    frame with its ``k`` best partners by overlap and its ``k_turned`` best among those turned by more than
    ``turned_deg``, every partner with an overlap of at least ``min_overlap``."""
    shared = np.asarray(shared, float)
    overlap = np.sqrt(shared * shared.T)
    np.fill_diagonal(overlap, 0.0)
    axes = np.asarray(axes, float)
    turned = axes @ axes.T < math.cos(math.radians(turned_deg))
    pairs: set[tuple[int, int]] = set()
    for i in range(len(overlap)):
        for pool, count in ((overlap[i], k), (np.where(turned[i], overlap[i], 0.0), k_turned)):
            best = np.argsort(-pool, kind="stable")[:count]
            for j in best[pool[best] >= min_overlap]:
                pairs.add((min(i, int(j)), max(i, int(j))))
    return sorted(pairs)
