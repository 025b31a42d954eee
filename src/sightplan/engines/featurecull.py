"""Which simulated features can a frame observe, before any ray is cast (METRICS.md §5.2).

A feature is observed iff it projects inside the image, lies within d_max, faces the
camera, and is not occluded. The first three tests are geometry; only the last needs a
ray. Testing them on every feature of the scene for every frame costs as much as the
cast on a large model, so the features are indexed once per engine: sorted along a
Morton curve and cut into blocks of :data:`BLOCK` with their bounding boxes. A frame
then skips every block that lies outside its view frustum (or beyond d_max) and tests
only the features of the others, exactly as the brute-force test does, in one compiled
loop. The result is the same set: culling a block only skips features that would fail.
"""

from __future__ import annotations

import math

import numba as nb
import numpy as np
from numpy.typing import NDArray

BLOCK = 64
_MORTON_BITS = 21
PARALLEL_BLOCKS = 2048  # blocks above which their tests are split over the engine's threads


def _spread(v: NDArray[np.uint64]) -> NDArray[np.uint64]:
    """Insert two zero bits between the low 21 bits of each value (3D Morton interleave)."""
    v = v & np.uint64(0x1FFFFF)
    v = (v | (v << np.uint64(32))) & np.uint64(0x1F00000000FFFF)
    v = (v | (v << np.uint64(16))) & np.uint64(0x1F0000FF0000FF)
    v = (v | (v << np.uint64(8))) & np.uint64(0x100F00F00F00F00F)
    v = (v | (v << np.uint64(4))) & np.uint64(0x10C30C30C30C30C3)
    v = (v | (v << np.uint64(2))) & np.uint64(0x1249249249249249)
    return v


class FeatureIndex:
    """Features in Morton order, cut into blocks with bounding boxes.

    points, normals: (N, 3) float64 in the order of the feature set (world metres).
    """

    def __init__(self, points: NDArray[np.float64], normals: NDArray[np.float64]) -> None:
        n = len(points)
        if n:
            lo = points.min(axis=0)
            span = np.maximum(points.max(axis=0) - lo, 1e-9)
            q = ((points - lo) / span * ((1 << _MORTON_BITS) - 1)).astype(np.uint64)
            code = _spread(q[:, 0]) | (_spread(q[:, 1]) << np.uint64(1)) | (_spread(q[:, 2]) << np.uint64(2))
            order = np.argsort(code, kind="stable")
        else:
            order = np.zeros(0, np.int64)
        self.order = order.astype(np.int32)
        self.points = np.ascontiguousarray(points[order])
        self.normals = np.ascontiguousarray(normals[order])
        starts = np.arange(0, n, BLOCK)
        self.block_start = np.r_[starts, n].astype(np.int64)
        if n:
            self.block_lo = np.minimum.reduceat(self.points, starts, axis=0)
            self.block_hi = np.maximum.reduceat(self.points, starts, axis=0)
        else:
            self.block_lo = self.block_hi = np.zeros((0, 3))

    def __len__(self) -> int:
        return len(self.points)

    def candidates(self, C_world: NDArray, R: NDArray | None, width: int, height: int, fx: float, fy: float,
                   cx: float, cy: float, d_max: float, pool=None, threads: int = 1
                   ) -> tuple[NDArray[np.int32], NDArray[np.float32], NDArray[np.float64]]:
        """Features that pass every test but occlusion: (k,) indices into the feature set, in the
        index's spatial order (neighbours together, so their sight lines make coherent packets),
        (k, 3) float32 unit directions from the camera centre, (k,) float64 distances.

        R: camera-to-world rotation of a pinhole camera (its columns are the camera axes), or
        None for a camera that sees every direction (equirectangular). pool, threads: an executor and its
        size, to test the blocks in as many parts (each part in order, so the result is the same).
        """
        C = np.asarray(C_world, np.float64)
        if R is None:
            planes = np.zeros((0, 3))
            pinhole = False
            R = np.eye(3)
        else:
            R = np.ascontiguousarray(R, np.float64)
            # the four side planes through C, inward normals in camera coordinates, then in world
            cam_planes = np.array([[fx, 0.0, cx], [-fx, 0.0, width - cx], [0.0, fy, cy], [0.0, -fy, height - cy]])
            planes = cam_planes @ R.T
            pinhole = True
        keep = _cull_blocks(self.block_lo, self.block_hi, C, planes, d_max)

        def part(bounds: tuple[int, int]):
            return _filter(self.points, self.normals, self.block_start, keep, C, R, pinhole, float(width),
                           float(height), float(fx), float(fy), float(cx), float(cy), d_max, *bounds)

        if pool is None or threads < 2 or len(keep) < PARALLEL_BLOCKS:
            idx, dirs, dist = part((0, len(keep)))
        else:
            cut = np.linspace(0, len(keep), threads + 1).astype(int).tolist()
            parts = list(pool.map(part, zip(cut[:-1], cut[1:])))
            idx, dirs, dist = (np.concatenate([p[k] for p in parts]) for k in range(3))
        return self.order[idx], dirs, dist


@nb.njit(nogil=True, cache=True)
def _cull_blocks(lo, hi, C, planes, d_max):
    """(B,) bool: blocks whose box may hold a point in the frustum (inside every plane) within d_max of C."""
    n_blocks = lo.shape[0]
    keep = np.zeros(n_blocks, np.bool_)
    for b in range(n_blocks):
        # distance from C to the box
        d2 = 0.0
        for a in range(3):
            if C[a] < lo[b, a]:
                d2 += (lo[b, a] - C[a]) ** 2
            elif C[a] > hi[b, a]:
                d2 += (C[a] - hi[b, a]) ** 2
        if d2 > d_max * d_max * (1.0 + 1e-9) + 1e-9:
            continue
        inside = True
        for j in range(planes.shape[0]):
            # the box's corner farthest along the plane's normal
            s = 0.0
            scale = 0.0
            for a in range(3):
                na = planes[j, a]
                corner = hi[b, a] if na > 0 else lo[b, a]
                s += na * (corner - C[a])
                scale += abs(na) * (abs(corner - C[a]) + 1.0)
            if s < -1e-9 * scale:
                inside = False
                break
        keep[b] = inside
    return keep


@nb.njit(nogil=True, cache=True)
def _filter(points, normals, block_start, keep, C, R, pinhole, width, height, fx, fy, cx, cy, d_max, b0, b1):
    """The tests of METRICS.md §5.2 but occlusion, in float64 as the brute-force test does them, on the kept blocks
    among b0..b1."""
    total = 0
    for b in range(b0, b1):
        if keep[b]:
            total += block_start[b + 1] - block_start[b]
    idx = np.empty(total, np.int32)
    dirs = np.empty((total, 3), np.float32)
    dist = np.empty(total, np.float64)
    k = 0
    for b in range(b0, b1):
        if not keep[b]:
            continue
        for i in range(block_start[b], block_start[b + 1]):
            r0 = points[i, 0] - C[0]
            r1 = points[i, 1] - C[1]
            r2 = points[i, 2] - C[2]
            if normals[i, 0] * r0 + normals[i, 1] * r1 + normals[i, 2] * r2 >= 0.0:
                continue  # faces away from the camera
            d = math.sqrt(r0 * r0 + r1 * r1 + r2 * r2)
            if not (d <= d_max and d > 0.0):
                continue
            if pinhole:
                zc = r0 * R[0, 2] + r1 * R[1, 2] + r2 * R[2, 2]
                if not zc > 0.0:
                    continue
                x = fx * (r0 * R[0, 0] + r1 * R[1, 0] + r2 * R[2, 0]) / zc + cx
                y = fy * (r0 * R[0, 1] + r1 * R[1, 1] + r2 * R[2, 1]) / zc + cy
                if not (x >= 0.0 and x < width and y >= 0.0 and y < height):
                    continue
            idx[k] = i
            dirs[k, 0] = r0 / d
            dirs[k, 1] = r1 / d
            dirs[k, 2] = r2 / d
            dist[k] = d
            k += 1
    return idx[:k], dirs[:k], dist[:k]
