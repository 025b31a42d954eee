"""Which simulated features can a frame observe, before any ray is cast (METRICS.md §5.2).

A feature is observed iff it projects inside the image, lies within d_max, faces the
camera, and is not occluded. The first three tests are geometry; only the last needs a
ray. Testing them on every feature of the scene for every frame costs as much as the
cast on a large model, so the features are indexed once per engine: sorted along a
Morton curve and cut into blocks of :data:`BLOCK` with their bounding boxes. A frame
then skips every block that lies outside its view frustum (or beyond d_max) and tests
only the features of the others, exactly as the brute-force test does, in one compiled
loop. The result is the same set: culling a block only skips features that would fail.

Most features that pass those tests on a large building are hidden: the furniture behind
its walls and roof. An occlusion ray costs as much as the geometry tests of ten features,
so each kept block first casts one ray, toward its box's centre. Where the triangle it
hits lies between the camera and a feature, with the feature at least
:data:`COVER_BEHIND_M` beyond the triangle's plane and the sight line crossing the
triangle at least :data:`COVER_INSIDE_M` inside its edges, the feature's own ray could
only report that triangle or something nearer: it is occluded, and needs no ray. The
margins are many times the float32 rounding of a ray, so the set stays the same.
"""

from __future__ import annotations

import math

import numba as nb
import numpy as np
from numpy.typing import NDArray

from .kernels import no_refs, per_ray

BLOCK = 64
_MORTON_BITS = 21
PARALLEL_BLOCKS = 2048  # blocks above which their tests are split over the engine's threads
COVER_BEHIND_M = 0.001  # a feature proven occluded lies this far beyond the covering triangle's plane (2× the tolerance)
COVER_INSIDE_M = 1e-4  # and its sight line crosses the triangle this far inside its edges, plus COVER_INSIDE_REL × d
COVER_INSIDE_REL = 1e-6


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
        self.block_size = np.diff(self.block_start)
        if n:
            self.block_lo = np.minimum.reduceat(self.points, starts, axis=0)
            self.block_hi = np.maximum.reduceat(self.points, starts, axis=0)
        else:
            self.block_lo = self.block_hi = np.zeros((0, 3))

    def __len__(self) -> int:
        return len(self.points)

    def candidates(self, C_world: NDArray, R: NDArray | None, width: int, height: int, fx: float, fy: float,
                   cx: float, cy: float, d_max: float, pool=None, threads: int = 1, cover=None
                   ) -> tuple[NDArray[np.int32], NDArray[np.float32], NDArray[np.float64]]:
        """Features that pass every test but occlusion: (k,) indices into the feature set, in the
        index's spatial order (neighbours together, so their sight lines make coherent packets),
        (k, 3) float32 unit directions from the camera centre, (k,) float64 distances.

        R: camera-to-world rotation of a pinhole camera (its columns are the camera axes), or
        None for a camera that sees every direction (equirectangular). pool, threads: an executor and its
        size, to test the blocks in as many parts (each part in order, so the result is the same).
        cover: (first_hit, vertices, faces, centre) of the engine, to leave out the features a block's one ray
        proves occluded (module docstring): first_hit(origins, directions) on float32 rays in the local frame
        (world − centre), vertices in that frame.
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
        cover_prim = np.full(len(keep), -1, np.int32)
        vertices, faces, centre = np.zeros((0, 3)), np.zeros((0, 3), np.int32), np.zeros(3)
        if cover is not None and keep.any():
            first_hit, vertices, faces, centre = cover
            kept, rays = _block_rays(keep, self.block_lo, self.block_hi, C)
            origin = np.broadcast_to((C - centre).astype(np.float32), rays.shape)
            if pool is None or threads < 2 or len(rays) < PARALLEL_BLOCKS:
                cover_prim[kept] = first_hit(origin, rays)
            else:
                cut = np.linspace(0, len(rays), threads + 1).astype(int).tolist()
                cover_prim[kept] = np.concatenate(list(pool.map(lambda a, b: first_hit(origin[a:b], rays[a:b]),
                                                                    cut[:-1], cut[1:])))

        sizes = np.where(keep, self.block_size, 0)

        def part(bounds: tuple[int, int]):
            total = int(sizes[bounds[0]:bounds[1]].sum())
            idx, dirs, dist = np.empty(total, np.int32), np.empty((total, 3), np.float32), np.empty(total)
            k = _filter(self.points, self.normals, self.block_start, keep, C, R, pinhole, float(width),
                        float(height), float(fx), float(fy), float(cx), float(cy), d_max, *bounds, cover_prim,
                        vertices, faces, centre, self.block_lo, self.block_hi, np.zeros(16), idx, dirs, dist)
            return idx[:k], dirs[:k], dist[:k]

        if pool is None or threads < 2 or len(keep) < PARALLEL_BLOCKS:
            idx, dirs, dist = part((0, len(keep)))
        else:
            cut = np.linspace(0, len(keep), threads + 1).astype(int).tolist()
            parts = list(pool.map(part, zip(cut[:-1], cut[1:])))
            idx, dirs, dist = (np.concatenate([p[k] for p in parts]) for k in range(3))
        return self.order[idx], dirs, dist


@nb.njit(nogil=True, cache=True)
def _block_rays(keep, lo, hi, C):
    """The kept blocks whose box centre is not C, and the float32 unit directions from C to those centres."""
    kept = np.empty(keep.shape[0], np.int64)
    rays = np.empty((keep.shape[0], 3), np.float32)
    n = 0
    for b in range(keep.shape[0]):
        if not keep[b]:
            continue
        r0 = 0.5 * (lo[b, 0] + hi[b, 0]) - C[0]
        r1 = 0.5 * (lo[b, 1] + hi[b, 1]) - C[1]
        r2 = 0.5 * (lo[b, 2] + hi[b, 2]) - C[2]
        length = math.sqrt(r0 * r0 + r1 * r1 + r2 * r2)
        if length > 0.0:
            kept[n] = b
            rays[n, 0], rays[n, 1], rays[n, 2] = r0 / length, r1 / length, r2 / length
            n += 1
    return kept[:n], rays[:n]


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


@no_refs
def _filter(points, normals, block_start, keep, C, R, pinhole, width, height, fx, fy, cx, cy, d_max, b0, b1,
            cover_prim, vertices, faces, centre, block_lo, block_hi, cover, idx, dirs, dist):
    """The tests of METRICS.md §5.2 but occlusion, in float64 as the brute-force test does them, on the kept blocks
    among b0..b1; features their block's covering triangle proves occluded are left out (:func:`_covered`). Writes
    the features that pass into idx, dirs and dist (room for every feature of those blocks) and returns how many;
    cover (16,): scratch."""
    k = 0
    for b in range(b0, b1):
        if not keep[b]:
            continue
        covering = cover_prim[b] >= 0 and _cover_setup(vertices, faces, cover_prim[b], C, centre, cover)
        if covering and _box_covered(cover, block_lo[b], block_hi[b], C):
            continue  # every sight line into the block's box crosses the triangle: all its features are hidden
        for i in range(block_start[b], block_start[b + 1]):
            r0 = points[i, 0] - C[0]
            r1 = points[i, 1] - C[1]
            r2 = points[i, 2] - C[2]
            if normals[i, 0] * r0 + normals[i, 1] * r1 + normals[i, 2] * r2 >= 0.0:
                continue  # faces away from the camera
            d = math.sqrt(r0 * r0 + r1 * r1 + r2 * r2)
            if not (d <= d_max and d > 0.0):
                continue
            if covering and _covered(cover, r0, r1, r2, d):
                continue  # hidden whether it is in view or not
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
    return k


@no_refs
def _cover_setup(vertices, faces, f, C, centre, out):
    """Triangle f as seen from C, into ``out`` (16,), relative to C: its unit normal turned away from C (0–2), C's
    distance to its plane (3), then per edge k its inward in-plane unit normal m_k (4k + 4 … 4k + 6) and offset
    m_k·(a_k − C) (4k + 7). False where C lies in the plane or the triangle is degenerate."""
    l0, l1, l2 = C[0] - centre[0], C[1] - centre[1], C[2] - centre[2]
    i, j, k = faces[f, 0], faces[f, 1], faces[f, 2]
    a0, a1, a2 = vertices[i, 0] - l0, vertices[i, 1] - l1, vertices[i, 2] - l2  # the corners relative to C
    b0, b1, b2 = vertices[j, 0] - l0, vertices[j, 1] - l1, vertices[j, 2] - l2
    c0, c1, c2 = vertices[k, 0] - l0, vertices[k, 1] - l1, vertices[k, 2] - l2
    u0, u1, u2 = b0 - a0, b1 - a1, b2 - a2
    w0, w1, w2 = c0 - a0, c1 - a1, c2 - a2
    n0, n1, n2 = u1 * w2 - u2 * w1, u2 * w0 - u0 * w2, u0 * w1 - u1 * w0
    length = math.sqrt(n0 * n0 + n1 * n1 + n2 * n2)
    if not length > 0.0:
        return False
    n0, n1, n2 = n0 / length, n1 / length, n2 / length
    front = n0 * a0 + n1 * a1 + n2 * a2  # the plane's distance from C along n
    if front < 0.0:
        n0, n1, n2, front = -n0, -n1, -n2, -front
    if not front > 0.0:
        return False
    out[0], out[1], out[2], out[3] = n0, n1, n2, front
    for e in range(3):  # edge p → q, r the third corner
        if e == 0:
            p0, p1, p2, q0, q1, q2, r0, r1, r2 = a0, a1, a2, b0, b1, b2, c0, c1, c2
        elif e == 1:
            p0, p1, p2, q0, q1, q2, r0, r1, r2 = b0, b1, b2, c0, c1, c2, a0, a1, a2
        else:
            p0, p1, p2, q0, q1, q2, r0, r1, r2 = c0, c1, c2, a0, a1, a2, b0, b1, b2
        e0, e1, e2 = q0 - p0, q1 - p1, q2 - p2
        m0, m1, m2 = n1 * e2 - n2 * e1, n2 * e0 - n0 * e2, n0 * e1 - n1 * e0
        ml = math.sqrt(m0 * m0 + m1 * m1 + m2 * m2)
        if not ml > 0.0:
            return False
        if m0 * (r0 - p0) + m1 * (r1 - p1) + m2 * (r2 - p2) < 0.0:
            ml = -ml  # toward the third corner
        m0, m1, m2 = m0 / ml, m1 / ml, m2 / ml
        out[4 * e + 4], out[4 * e + 5], out[4 * e + 6] = m0, m1, m2
        out[4 * e + 7] = m0 * p0 + m1 * p1 + m2 * p2
    return True


@no_refs
def _box_covered(cover, lo, hi, C):
    """Whether :func:`_covered` holds for every point of the box lo..hi: it does at its eight corners, with the
    margin of the farthest. Each of its tests is a half-space (the edge tests through C, since the sight line's
    crossing of the plane is a central projection), so the corners decide."""
    far = 0.0
    for k in range(8):
        r0 = (hi[0] if k & 1 else lo[0]) - C[0]
        r1 = (hi[1] if k & 2 else lo[1]) - C[1]
        r2 = (hi[2] if k & 4 else lo[2]) - C[2]
        far = max(far, math.sqrt(r0 * r0 + r1 * r1 + r2 * r2))
    for k in range(8):
        r0 = (hi[0] if k & 1 else lo[0]) - C[0]
        r1 = (hi[1] if k & 2 else lo[1]) - C[1]
        r2 = (hi[2] if k & 4 else lo[2]) - C[2]
        if not _covered(cover, r0, r1, r2, far):
            return False
    return True


@per_ray
def _covered(cover, r0, r1, r2, d):
    """Whether the feature at r (relative to C, d = |r|) lies at least COVER_BEHIND_M beyond the triangle of
    :func:`_cover_setup` and its sight line crosses the triangle at least COVER_INSIDE_M (+ COVER_INSIDE_REL·d)
    inside each edge."""
    along = cover[0] * r0 + cover[1] * r1 + cover[2] * r2
    if not along - cover[3] >= COVER_BEHIND_M:
        return False
    t = cover[3] / along  # the sight line meets the plane at t·r
    x0, x1, x2 = t * r0, t * r1, t * r2
    inside = COVER_INSIDE_M + COVER_INSIDE_REL * d
    for k in range(3):
        j = 4 * k + 4
        if cover[j] * x0 + cover[j + 1] * x1 + cover[j + 2] * x2 - cover[j + 3] < inside:
            return False
    return True
