"""A point cloud Ψ splatted into a frame: per pixel, the distance to the nearest point covering it (see the
package docstring for the footprint rule)."""

from __future__ import annotations

import math

import numba as nb
import numpy as np
from numpy.typing import NDArray

from ..camera.models import Camera, EquirectangularCamera

MAX_SPLAT_PX = 32

SPACING_NEIGHBOUR = 8

# =========================================================================== splatting
@nb.njit(cache=True, nogil=True)
def _splat_pinhole(points, C, R, fx, fy, cx, cy, W, H, spacing, max_r, zbuf):  # pragma: no cover - compiled
    """Nearest depth z per pixel of a pinhole frame; every point covers a disc of radius max(1, s·f/z) px."""
    for i in range(points.shape[0]):
        rx = points[i, 0] - C[0]
        ry = points[i, 1] - C[1]
        rz = points[i, 2] - C[2]
        x = R[0, 0] * rx + R[1, 0] * ry + R[2, 0] * rz
        y = R[0, 1] * rx + R[1, 1] * ry + R[2, 1] * rz
        z = R[0, 2] * rx + R[1, 2] * ry + R[2, 2] * rz
        if z <= 1e-9:
            continue
        u = fx * x / z + cx
        v = fy * y / z + cy
        ru = min(max(1.0, spacing * fx / z), max_r)
        rv = min(max(1.0, spacing * fy / z), max_r)
        if u < -ru or u > W + ru or v < -rv or v > H + rv:
            continue
        u0 = max(0, int(math.ceil(u - ru - 0.5)))
        u1 = min(W - 1, int(math.floor(u + ru - 0.5)))
        v0 = max(0, int(math.ceil(v - rv - 0.5)))
        v1 = min(H - 1, int(math.floor(v + rv - 0.5)))
        for py in range(v0, v1 + 1):
            dy = (py + 0.5 - v) / rv
            for px in range(u0, u1 + 1):
                dx = (px + 0.5 - u) / ru
                if dx * dx + dy * dy <= 1.0 and z < zbuf[py, px]:
                    zbuf[py, px] = z

@nb.njit(cache=True, nogil=True)
def _splat_equirect(points, C, R, W, H, spacing, max_r, dbuf):  # pragma: no cover - compiled
    """Nearest distance per pixel of an equirectangular frame; discs of max(1, s/(d·π/H)) px, wider by 1/cos(lat)."""
    for i in range(points.shape[0]):
        rx = points[i, 0] - C[0]
        ry = points[i, 1] - C[1]
        rz = points[i, 2] - C[2]
        d = math.sqrt(rx * rx + ry * ry + rz * rz)
        if d <= 1e-9:
            continue
        x = (R[0, 0] * rx + R[1, 0] * ry + R[2, 0] * rz) / d
        y = (R[0, 1] * rx + R[1, 1] * ry + R[2, 1] * rz) / d
        z = (R[0, 2] * rx + R[1, 2] * ry + R[2, 2] * rz) / d
        lon = math.atan2(x, z)
        lat = math.asin(min(1.0, max(-1.0, -y)))
        u = (lon + math.pi) / (2.0 * math.pi) * W
        v = (0.5 * math.pi - lat) / math.pi * H
        rv = min(max(1.0, spacing / d * H / math.pi), max_r)
        ru = min(rv / max(math.cos(lat), 1e-3), W / 2.0)
        v0 = max(0, int(math.ceil(v - rv - 0.5)))
        v1 = min(H - 1, int(math.floor(v + rv - 0.5)))
        a0 = int(math.ceil(u - ru - 0.5))
        a1 = int(math.floor(u + ru - 0.5))
        if a1 - a0 >= W:
            a1 = a0 + W - 1
        for py in range(v0, v1 + 1):
            dy = (py + 0.5 - v) / rv
            for a in range(a0, a1 + 1):
                dx = (a + 0.5 - u) / ru
                if dx * dx + dy * dy <= 1.0:
                    px = a % W
                    if d < dbuf[py, px]:
                        dbuf[py, px] = d

def splat_distances(points: NDArray[np.float64], camera: Camera, R_world_camera: NDArray, C_world: NDArray,
                    spacing_m: float, max_px: float = MAX_SPLAT_PX) -> NDArray[np.float64]:
    """(H, W) distance along each pixel's ray to the nearest splatted point (inf where none); see the module docstring."""
    R = np.ascontiguousarray(R_world_camera, np.float64)
    C = np.asarray(C_world, np.float64)
    W, H = camera.width, camera.height
    buf = np.full((H, W), np.inf)
    if isinstance(camera, EquirectangularCamera):
        _splat_equirect(points, C, R, W, H, float(spacing_m), float(max_px), buf)
        return buf
    _splat_pinhole(points, C, R, camera.fx, camera.fy, camera.cx, camera.cy, W, H, float(spacing_m), float(max_px), buf)
    x = (np.arange(W) + 0.5 - camera.cx) / camera.fx
    y = (np.arange(H) + 0.5 - camera.cy) / camera.fy
    return buf * np.sqrt(1.0 + x[None, :] ** 2 + y[:, None] ** 2)

def point_spacing(points: NDArray[np.float64], tree=None, sample: int = 20_000, seed: int = 0) -> float:
    """s = r₈·√(π/8), r₈ the median distance to the 8th nearest neighbour of up to ``sample`` points (1/√density)."""
    from scipy.spatial import cKDTree

    n = len(points)
    if n < 2:
        return 0.0
    tree = tree if tree is not None else cKDTree(points)
    k = min(SPACING_NEIGHBOUR, n - 1)
    idx = np.random.default_rng(seed).choice(n, size=min(sample, n), replace=False)
    d, _ = tree.query(points[idx], k=k + 1, workers=-1)
    return float(np.median(d[:, -1]) * math.sqrt(math.pi / k))
