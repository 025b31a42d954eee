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

Any triangle between the camera and a feature proves what it covers, so three sources
of triangles are tried, cheapest first:

- When the frame's own pixels were just cast (:meth:`Engine.observe`), a block takes the
  triangle hit by the pixel its box's centre projects into (no ray at all), and a feature
  the block's triangles leave unproven tries the triangle of its own pixel.
- A block that triangle does not hide whole also takes the first *big* triangle along the
  line to its centre (:func:`big_triangles`: walls, slabs, roofs, panes), from a second,
  small BVH of those alone. Behind a window's glazing bars the bar a ray hits is too
  narrow to hide a block of furniture; the pane behind it is not.

Per block, the facing and covering tests run first over all its features, without a
branch or a division (the compiler makes one vector loop of them), in float32 on the
features' offsets from their block's corner: eight at a time where float64 gives four.
Each test carries a slack larger than its rounding, so it keeps every feature it cannot
decide; the few whose facing it cannot call take the float64 test. Only the features
left then take the distance, the projection and the pixel's triangle, in float64 as the
brute-force test does.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass

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
COVER_FRONT_REL = 1e-6  # a triangle proves nothing from a camera nearer its plane than this × their distances from the centre
BIG_INRADIUS_M = 0.1  # a triangle this wide (its inscribed circle's radius) is a big occluder (big_triangles)
BIG_SHARE_MAX = 0.25  # an engine keeps a BVH of the big triangles when they are at most this share of all
F32_SLACK_REL = 2e-6  # the vector pass's float32 tests carry this × the block's farthest distance of slack (_block_planes)
F32_SLACK_M = 1e-30  # and this much, for a block so near C that float32 no longer holds its relative precision
SETUP_CACHE = 512  # triangles set up per frame kept (a power of 2), by id modulo this: blocks and pixels hit the same walls


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
        points = np.asarray(points, np.float64)[order]
        self.xyz = np.ascontiguousarray(points.T)  # (3, N) float64: the exact tests of the features the vector pass keeps
        self.normals = np.ascontiguousarray(normals, np.float64)  # in the set's order: the few facing tests left unsure
        length = np.linalg.norm(self.normals, axis=1) if n else np.zeros(0)
        length = length[np.isfinite(length)]
        self.normal_scale = float(length.max()) if len(length) else 0.0  # the facing slack's unit (1 for unit normals)
        starts = np.arange(0, n, BLOCK)
        self.block_start = np.r_[starts, n].astype(np.int64)
        self.block_size = np.diff(self.block_start)
        if n:
            self.block_lo = np.minimum.reduceat(points, starts, axis=0)
            self.block_hi = np.maximum.reduceat(points, starts, axis=0)
        else:
            self.block_lo = self.block_hi = np.zeros((0, 3))
        # the vector pass's float32 copies, one array per axis: each point relative to its block's lower corner (small
        # numbers, so rounding stays far below the proofs' margins however far the site lies from the origin)
        self.offsets, self.n32 = np.empty((3, n), np.float32), np.empty((3, n), np.float32)
        block_of = np.repeat(np.arange(len(starts)), self.block_size)
        for a in range(3):
            self.offsets[a] = points[:, a] - self.block_lo[block_of, a]
            self.n32[a] = self.normals[order, a]

    def __len__(self) -> int:
        return len(self.order)

    def candidates(self, C_world: NDArray, R: NDArray | None, width: int, height: int, fx: float, fy: float,
                   cx: float, cy: float, d_max: float, pool=None, threads: int = 1, cover: Occluders | None = None,
                   pixels: tuple[NDArray[np.int32], float, float] | None = None
                   ) -> tuple[NDArray[np.int32], NDArray[np.float32], NDArray[np.float64]]:
        """Features that pass every test but occlusion: (k,) indices into the feature set, in the
        index's spatial order (neighbours together, so their sight lines make coherent packets),
        (k, 3) float32 unit directions from the camera centre, (k,) float64 distances.

        R: camera-to-world rotation of a pinhole camera (its columns are the camera axes), or
        None for a camera that sees every direction (equirectangular). pool, threads: an executor and its
        size, to test the blocks in as many parts (each part in order, so the result is the same).
        cover: the engine's triangles, to leave out the features a triangle hit proves occluded (module
        docstring). pixels: with cover and a pinhole R, (prims, sx, sy): the triangle each pixel of the frame
        just cast hit ((h, w) int32, −1 for none), the image point (x, y) lying in pixel (int(x·sx), int(y·sy)).
        """
        C = np.asarray(C_world, np.float64)
        if R is None:
            planes = np.zeros((0, 3))
            pinhole = False
            R = np.eye(3)
            pixels = None
        else:
            R = np.ascontiguousarray(R, np.float64)
            # the four side planes through C, inward normals in camera coordinates, then in world
            cam_planes = np.array([[fx, 0.0, cx], [-fx, 0.0, width - cx], [0.0, fy, cy], [0.0, -fy, height - cy]])
            planes = cam_planes @ R.T
            pinhole = True
        keep = _cull_blocks(self.block_lo, self.block_hi, C, planes, d_max)
        prims, sx, sy = pixels if pixels is not None else (np.full((0, 0), -1, np.int32), 0.0, 0.0)
        if cover is None:
            vertices, faces, centre = np.zeros((0, 3)), np.zeros((0, 3), np.int32), np.zeros(3)
        else:
            vertices, faces, centre = cover.vertices, cover.faces, cover.centre
        origin = (C - centre).astype(np.float32)
        lo, hi = self.block_lo, self.block_hi

        def part(bounds: tuple[int, int]):
            b0, b1 = bounds
            blocks = np.flatnonzero(keep[b0:b1]) + b0
            first, big = np.full(b1 - b0, -1, np.int32), np.full(b1 - b0, -1, np.int32)
            tags, table = np.full(SETUP_CACHE, -1, np.int64), np.empty((SETUP_CACHE + 1, 17))
            _no_cover(table[SETUP_CACHE])  # the row of "no triangle": it proves nothing
            if cover is not None and len(blocks):
                # each block's triangle: the pixel its box's centre projects into, or a ray of its own
                if len(prims):
                    _block_pixels(blocks, b0, lo, hi, C, R, fx, fy, cx, cy, prims, sx, sy, first)
                else:
                    first[blocks - b0] = cover.first_hit(origin, _rays_to(blocks, lo, hi, C))
                # then the first big triangle behind a block not hidden whole by it
                is_open = np.empty(len(blocks), np.bool_)
                _open(blocks, b0, first, vertices, faces, C, centre, lo, hi, tags, table, is_open)
                blocks = blocks[is_open]
                if cover.big_hit is not None and len(blocks):
                    big[blocks - b0] = cover.big_hit(origin, _rays_to(blocks, lo, hi, C))
            total = int(self.block_size[blocks].sum())
            idx, dirs, dist = np.empty(total, np.int32), np.empty((total, 3), np.float32), np.empty(total)
            k = _filter(self.xyz, self.offsets, self.n32, self.normals, self.normal_scale, self.order,
                        self.block_start, blocks, b0, first, big, C, R, pinhole, float(width), float(height),
                        float(fx), float(fy), float(cx), float(cy), d_max, vertices, faces, centre, lo, hi, prims,
                        float(sx), float(sy), tags, table, np.zeros(BLOCK, np.int8), np.empty(32, np.float32), idx,
                        dirs, dist)
            return idx[:k], dirs[:k], dist[:k]

        if pool is None or threads < 2 or len(keep) < PARALLEL_BLOCKS:
            idx, dirs, dist = part((0, len(keep)))
        else:
            cut = np.linspace(0, len(keep), threads + 1).astype(int).tolist()
            parts = list(pool.map(part, zip(cut[:-1], cut[1:])))
            idx, dirs, dist = (np.concatenate([p[k] for p in parts]) for k in range(3))
        return self.order[idx], dirs, dist


@dataclass(frozen=True)
class Occluders:
    """An engine's triangles, for the proofs of :class:`FeatureIndex`: vertices (V, 3) in its local frame (world −
    centre), faces (F, 3); first_hit(origins, directions): the triangle each float32 ray of the local frame hits
    first (−1 for none); big_hit: the same among the :func:`big_triangles` only (their ids in faces), or None."""

    first_hit: Callable[[NDArray[np.float32], NDArray[np.float32]], NDArray[np.int32]]
    vertices: NDArray[np.float64]
    faces: NDArray[np.int32]
    centre: NDArray[np.float64]
    big_hit: Callable[[NDArray[np.float32], NDArray[np.float32]], NDArray[np.int32]] | None = None


@per_ray
def _is_big(vertices, faces, f, inradius):
    """Whether triangle f's inscribed circle has a radius of at least ``inradius`` (r = 2·area / perimeter)."""
    i, j, k = faces[f, 0], faces[f, 1], faces[f, 2]
    u0, u1, u2 = vertices[j, 0] - vertices[i, 0], vertices[j, 1] - vertices[i, 1], vertices[j, 2] - vertices[i, 2]
    w0, w1, w2 = vertices[k, 0] - vertices[i, 0], vertices[k, 1] - vertices[i, 1], vertices[k, 2] - vertices[i, 2]
    n0, n1, n2 = u1 * w2 - u2 * w1, u2 * w0 - u0 * w2, u0 * w1 - u1 * w0
    twice_area = math.sqrt(n0 * n0 + n1 * n1 + n2 * n2)
    v0, v1, v2 = w0 - u0, w1 - u1, w2 - u2
    perimeter = (math.sqrt(u0 * u0 + u1 * u1 + u2 * u2) + math.sqrt(w0 * w0 + w1 * w1 + w2 * w2)
                 + math.sqrt(v0 * v0 + v1 * v1 + v2 * v2))
    return twice_area >= inradius * perimeter and twice_area > 0.0


@nb.njit(nogil=True, cache=True)
def big_triangles(vertices, faces, inradius):
    """The ids of the triangles whose inscribed circle's radius is at least ``inradius``: the walls, slabs, roofs
    and panes that hide most of what a frame does not see, few enough for a BVH of their own."""
    out = np.empty(faces.shape[0], np.int64)
    n = 0
    for f in range(faces.shape[0]):
        if _is_big(vertices, faces, f, inradius):
            out[n] = f
            n += 1
    return out[:n].copy()


@nb.njit(nogil=True, cache=True)
def _rays_to(blocks, lo, hi, C):
    """(m, 3) float32 unit directions from C to the centres of the boxes of ``blocks`` (straight up for a centre at
    C: any ray's triangle is only a candidate, proven or not by :func:`_covers`)."""
    rays = np.empty((blocks.shape[0], 3), np.float32)
    for n in range(blocks.shape[0]):
        b = blocks[n]
        r0 = 0.5 * (lo[b, 0] + hi[b, 0]) - C[0]
        r1 = 0.5 * (lo[b, 1] + hi[b, 1]) - C[1]
        r2 = 0.5 * (lo[b, 2] + hi[b, 2]) - C[2]
        length = math.sqrt(r0 * r0 + r1 * r1 + r2 * r2)
        if length > 0.0:
            rays[n, 0], rays[n, 1], rays[n, 2] = r0 / length, r1 / length, r2 / length
        else:
            rays[n, 0], rays[n, 1], rays[n, 2] = 0.0, 0.0, 1.0
    return rays


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
def _block_pixels(blocks, b0, lo, hi, C, R, fx, fy, cx, cy, prims, sx, sy, out):
    """out[b − b0] = the triangle hit by the pixel the centre of block b's box projects into (the nearest pixel
    where it projects outside the image; left as it is where the centre lies behind the camera)."""
    h, w = prims.shape
    for b in blocks:
        r0 = 0.5 * (lo[b, 0] + hi[b, 0]) - C[0]
        r1 = 0.5 * (lo[b, 1] + hi[b, 1]) - C[1]
        r2 = 0.5 * (lo[b, 2] + hi[b, 2]) - C[2]
        zc = r0 * R[0, 2] + r1 * R[1, 2] + r2 * R[2, 2]
        if not zc > 0.0:
            continue
        x = (fx * (r0 * R[0, 0] + r1 * R[1, 0] + r2 * R[2, 0]) / zc + cx) * sx
        y = (fy * (r0 * R[0, 1] + r1 * R[1, 1] + r2 * R[2, 1]) / zc + cy) * sy
        out[b - b0] = prims[int(min(max(y, 0.0), h - 1.0)), int(min(max(x, 0.0), w - 1.0))]


@no_refs
def _open(blocks, b0, first, vertices, faces, C, centre, lo, hi, tags, table, out):
    """out[n] = whether the triangle first[b − b0] leaves block b = blocks[n] open: does not prove it hidden whole
    (:func:`_box_covers`)."""
    for n in range(blocks.shape[0]):
        b = blocks[n]
        cover = table[_cover_row(vertices, faces, first[b - b0], C, centre, tags, table)]
        out[n] = not _box_covers(cover, lo[b], hi[b], C, _box_inside(lo[b], hi[b], C))


@no_refs
def _filter(xyz, offsets, n32, normals, normal_scale, order, block_start, blocks, b0, first, big, C, R, pinhole, width,
            height, fx, fy, cx, cy, d_max, vertices, faces, centre, block_lo, block_hi, prims, sx, sy, tags, table, mask,
            plane, idx, dirs, dist):
    """The tests of METRICS.md §5.2 but occlusion on the features of ``blocks``, leaving out those a triangle hit proves
    occluded (:func:`_covers`): their block's (first[b − b0], big[b − b0]), then, where prims is not empty, their own
    pixel's. Writes the features that pass into idx, dirs and dist (room for every feature of those blocks) and
    returns how many. Scratch: mask (BLOCK,) int8, plane (32,) float32 and the cache of
    :func:`_cover_row`.

    Two passes. The vector pass runs over all the blocks' features in float32 (:func:`_block_planes`) and keeps
    those that face the camera and that neither block triangle proves hidden; its slack makes it keep, never drop,
    a feature its rounding cannot decide, and a feature whose facing it cannot call takes the brute-force test's
    own. The second pass tests those kept in float64 as the brute-force test does: distance and projection, and
    their pixel's triangle."""
    C0, C1, C2 = C[0], C[1], C[2]
    ox, oy, oz = offsets[0], offsets[1], offsets[2]
    mx, my, mz = n32[0], n32[1], n32[2]
    k = 0
    for b in blocks:
        lo, hi = block_lo[b], block_hi[b]
        far = _box_far(lo, hi, C)
        inside = _inside_at(far)  # for every feature of the block
        big_row = _cover_row(vertices, faces, big[b - b0], C, centre, tags, table)
        if _box_covers(table[big_row], lo, hi, C, inside):
            continue  # every sight line into the block's box crosses the big triangle: all its features are hidden
        # the big triangle's planes before the first one is fetched, which may take its row of the cache
        _block_planes(table[big_row], inside, far, plane, 0)
        _block_planes(table[_cover_row(vertices, faces, first[b - b0], C, centre, tags, table)], inside, far, plane, 16)
        u0, u1, u2, u3 = plane[0], plane[1], plane[2], plane[3]
        g00, g01, g02, t0 = plane[4], plane[5], plane[6], plane[7]
        g10, g11, g12, t1 = plane[8], plane[9], plane[10], plane[11]
        g20, g21, g22, t2 = plane[12], plane[13], plane[14], plane[15]
        v0, v1, v2, v3 = plane[16], plane[17], plane[18], plane[19]
        h00, h01, h02, s0 = plane[20], plane[21], plane[22], plane[23]
        h10, h11, h12, s1 = plane[24], plane[25], plane[26], plane[27]
        h20, h21, h22, s2 = plane[28], plane[29], plane[30], plane[31]
        facing = np.float32((F32_SLACK_REL * far + F32_SLACK_M) * normal_scale)
        q0, q1, q2 = np.float32(lo[0] - C0), np.float32(lo[1] - C1), np.float32(lo[2] - C2)
        s = block_start[b]
        n = block_start[b + 1] - s
        for j in range(n):  # one vector loop: no branch, no division (a missing triangle's row proves nothing)
            i = np.uint64(s + j)  # unsigned: no wraparound test, so contiguous loads
            r0 = q0 + ox[i]
            r1 = q1 + oy[i]
            r2 = q2 + oz[i]
            hidden = ((u0 * r0 + u1 * r1 + u2 * r2 >= u3) & (g00 * r0 + g01 * r1 + g02 * r2 >= t0)
                      & (g10 * r0 + g11 * r1 + g12 * r2 >= t1) & (g20 * r0 + g21 * r1 + g22 * r2 >= t2))
            hidden2 = ((v0 * r0 + v1 * r1 + v2 * r2 >= v3) & (h00 * r0 + h01 * r1 + h02 * r2 >= s0)
                       & (h10 * r0 + h11 * r1 + h12 * r2 >= s1) & (h20 * r0 + h21 * r1 + h22 * r2 >= s2))
            along = mx[i] * r0 + my[i] * r1 + mz[i] * r2
            shown = not (hidden | hidden2)
            near = (along < facing) & (along >= -facing) & shown  # its float32 facing test too close to call
            mask[j] = ((along < -facing) & shown) + 2 * near
        seen = 0
        k0 = k
        for j in range(n):
            idx[k] = s + j
            k += mask[j] & 1
            seen |= mask[j]
        if seen & 2:  # rare: a feature whose float32 facing test is too close to call, decided as the brute force does
            k = k0
            for j in range(n):
                i = np.uint64(s + j)
                if mask[j] == 2:
                    o = order[i]
                    r0, r1, r2 = xyz[0, i] - C0, xyz[1, i] - C1, xyz[2, i] - C2
                    mask[j] = normals[o, 0] * r0 + normals[o, 1] * r1 + normals[o, 2] * r2 < 0.0
                idx[k] = s + j
                k += mask[j]
    # the features left: distance and projection, exactly as the reference tests them, and their pixel's triangle
    px, py, pz = xyz[0], xyz[1], xyz[2]
    h, w = prims.shape
    last = -1
    cover = table[tags.shape[0]]
    q = 0
    for t in range(k):
        i = idx[t]
        r0 = px[i] - C0
        r1 = py[i] - C1
        r2 = pz[i] - C2
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
            if h:
                f = prims[min(int(y * sy), h - 1), min(int(x * sx), w - 1)]
                if f != last:
                    last = f
                    cover = table[_cover_row(vertices, faces, f, C, centre, tags, table)]
                if _covers(cover, r0, r1, r2, _inside_at(d)):
                    continue  # hidden behind the triangle its pixel hit
        idx[q] = i
        dirs[q, 0] = r0 / d
        dirs[q, 1] = r1 / d
        dirs[q, 2] = r2 / d
        dist[q] = d
        q += 1
    return q


@per_ray
def _block_planes(cover, inside, far, out, o):
    """The tests of :func:`_covers` with margin ``inside`` for the points of a box at most ``far`` from C, as the
    float32 vector pass runs them, into out[o:o + 16]: the plane's normal and the least distance along it (0–3), then
    per edge k a vector g and a bound t (4k + 4 … 4k + 7) such that g·r ≥ t implies that edge's test holds.

    The edge test m·r·front ≥ (offset + inside)·along is (m − f·n)·r ≥ 0 with f = (offset + inside) / front. In float32,
    a point r taken relative to its block's corner, and a dot product with a vector of length at most 1 + |f|, are each
    within 11·2⁻²⁴·far of their exact values (times 1 + |f|), so every bound carries F32_SLACK_REL·far, three times that:
    a float32 test that holds implies the exact one; F32_SLACK_M more keeps that true where float32 loses its relative
    precision. A "no triangle" row (front infinite), and an edge whose vector would leave float32's range, give tests
    that never hold."""
    slack = F32_SLACK_REL * far + F32_SLACK_M
    out[o], out[o + 1], out[o + 2] = cover[0], cover[1], cover[2]
    out[o + 3] = cover[3] + COVER_BEHIND_M + slack
    for e in range(3):
        f = (cover[4 * e + 7] + inside) / cover[3]
        j = o + 4 * e + 4
        if abs(f) * far < 1e30:
            out[j] = cover[4 * e + 4] - f * cover[0]
            out[j + 1] = cover[4 * e + 5] - f * cover[1]
            out[j + 2] = cover[4 * e + 6] - f * cover[2]
            out[j + 3] = slack * (1.0 + abs(f))
        else:  # beyond float32's range (or NaN): a test that never holds
            out[j], out[j + 1], out[j + 2], out[j + 3] = 0.0, 0.0, 0.0, np.inf


@no_refs
def _cover_setup(vertices, faces, f, C, centre, out):
    """Triangle f as seen from C, into ``out`` (16,), relative to C: its unit normal turned away from C (0–2), C's
    distance to its plane (3), then per edge k its inward in-plane unit normal m_k (4k + 4 … 4k + 6) and offset
    m_k·(a_k − C) (4k + 7). False where the triangle is degenerate or C lies within COVER_FRONT_REL × (C's and the
    triangle's distances from the centre) of its plane."""
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
    # a camera this near the plane may lie on its other side once a ray's float32 origin and the triangle's float32
    # corners are rounded (the frame's rays and the reference's are): no proof from it
    reach = math.sqrt(l0 * l0 + l1 * l1 + l2 * l2) + max(_length(vertices[i]), _length(vertices[j]), _length(vertices[k]))
    if not front > COVER_FRONT_REL * reach:
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


@per_ray
def _length(v):
    """The length of the 3-vector v."""
    return math.sqrt(v[0] * v[0] + v[1] * v[1] + v[2] * v[2])


@per_ray
def _cover_row(vertices, faces, f, C, centre, tags, table):
    """The row of ``table`` that holds triangle f set up by :func:`_cover_setup`, through a direct-mapped cache (tags
    (2^k,) and the first 2^k rows of table (2^k + 1, 17): the set-up and whether it is valid): a set-up reads the
    triangle's corners from all over the scene's arrays, a cache miss each. For f < 0 or a triangle that cannot be
    set up, the last row, which :func:`_no_cover` filled."""
    none = tags.shape[0]
    if f < 0:
        return none
    slot = f & (none - 1)
    if tags[slot] != f:
        tags[slot] = f
        table[slot, 16] = 1.0 if _cover_setup(vertices, faces, f, C, centre, table[slot]) else 0.0
    return slot if table[slot, 16] > 0.0 else none


@per_ray
def _no_cover(cover):
    """A cover that proves nothing: no point lies beyond its plane."""
    for j in range(16):
        cover[j] = 0.0
    cover[3] = np.inf


@per_ray
def _box_far(lo, hi, C):
    """The distance from C to the box lo..hi's farthest corner."""
    s = 0.0
    for a in range(3):
        s += max(abs(lo[a] - C[a]), abs(hi[a] - C[a])) ** 2
    return math.sqrt(s)


@per_ray
def _inside_at(d):
    """The inside margin of :func:`_covers` for a point at distance d from C (and any nearer)."""
    return COVER_INSIDE_M + COVER_INSIDE_REL * d


@per_ray
def _box_inside(lo, hi, C):
    """The inside margin of :func:`_covers` for the point of the box lo..hi farthest from C."""
    return _inside_at(_box_far(lo, hi, C))


@per_ray
def _box_covers(cover, lo, hi, C, inside):
    """Whether :func:`_covers` holds for every point of the box lo..hi with margin ``inside``: it does at its eight
    corners. Each of its tests is a half-space (the edge tests through C, since the sight line's crossing of the
    plane is a central projection), so the corners decide."""
    for k in range(8):
        r0 = (hi[0] if k & 1 else lo[0]) - C[0]
        r1 = (hi[1] if k & 2 else lo[1]) - C[1]
        r2 = (hi[2] if k & 4 else lo[2]) - C[2]
        if not _covers(cover, r0, r1, r2, inside):
            return False
    return True


@per_ray
def _covers(cover, r0, r1, r2, inside):
    """Whether the point at r (relative to C) lies at least COVER_BEHIND_M beyond the triangle of
    :func:`_cover_setup` and its sight line crosses the triangle at least ``inside`` inside each edge (the crossing
    t·r, t = front / along, tested as m·r·front ≥ (offset + inside)·along, with along > 0, to avoid the division)."""
    along = cover[0] * r0 + cover[1] * r1 + cover[2] * r2
    if not along - cover[3] >= COVER_BEHIND_M:
        return False
    for k in range(3):
        j = 4 * k + 4
        if not (cover[j] * r0 + cover[j + 1] * r1 + cover[j + 2] * r2) * cover[3] >= (cover[j + 3] + inside) * along:
            return False
    return True

