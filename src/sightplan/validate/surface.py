"""Surfaces for the validation: points sampled on a mesh, and which points lie near one (exact distances)."""

from __future__ import annotations

import math

import numba as nb
import numpy as np
from numpy.typing import ArrayLike, NDArray

from ..geometry.distance import point_triangle_sq

CT_DENSITY_PER_M2 = 100.0

CT_MIN_SAMPLES = 20_000

CT_MAX_SAMPLES = 1_000_000

_MAX_PIECES = 1_000_000

_PIECE_LIMIT = 4_000_000

_QUERY_BATCH = 100_000

# =========================================================================== geometry kernels
@nb.njit(cache=True, nogil=True)
def _any_within(points, idx, tri, r2):  # pragma: no cover - compiled
    """(n,) whether any candidate triangle idx[i, :] (index ≥ len(tri): none) lies within √r2 of points[i]."""
    n, k = idx.shape
    m = tri.shape[0]
    out = np.zeros(n, np.bool_)
    for i in range(n):
        for j in range(k):
            f = idx[i, j]
            if f >= m:
                break
            if point_triangle_sq(points[i, 0], points[i, 1], points[i, 2], tri[f]) <= r2:
                out[i] = True
                break
    return out

@nb.njit(cache=True, nogil=True)
def _nearest_within(points, idx, tri, r2, best, best_sq):  # pragma: no cover - compiled
    """For each point i, the candidate triangle idx[i, :] (index ≥ len(tri): none) nearest to it if closer than
    best_sq[i] (and within √r2): its index into ``best`` and its squared distance into ``best_sq``."""
    n, k = idx.shape
    m = tri.shape[0]
    for i in range(n):
        for j in range(k):
            f = idx[i, j]
            if f >= m:
                break
            d = point_triangle_sq(points[i, 0], points[i, 1], points[i, 2], tri[f])
            if d <= r2 and d < best_sq[i]:
                best_sq[i] = d
                best[i] = f


def _bisect(tri: NDArray[np.float64], ids: NDArray[np.int64], max_edge: float, limit: int | None = None
            ) -> tuple[NDArray[np.float64], NDArray[np.int64]] | None:
    """Triangles (m, 3, 3) split at the midpoint of their longest edge until no edge exceeds ``max_edge``, each piece
    with the id (of ``ids``) of the triangle it came from.

    The pieces cover exactly the same surface. None once there would be more than ``limit`` pieces.
    """
    done = []
    done_ids = []
    n_done = 0
    while len(tri):
        e = np.stack([np.linalg.norm(tri[:, 1] - tri[:, 0], axis=1), np.linalg.norm(tri[:, 2] - tri[:, 1], axis=1),
                      np.linalg.norm(tri[:, 0] - tri[:, 2], axis=1)], axis=1)
        longest = np.argmax(e, axis=1)
        split = e[np.arange(len(tri)), longest] > max_edge
        done.append(tri[~split])
        done_ids.append(ids[~split])
        n_done += len(done[-1])
        s, k = tri[split], longest[split]
        if len(s) == 0:
            break
        if limit is not None and n_done + 2 * len(s) > limit:
            return None
        order = (np.arange(3)[None, :] + k[:, None]) % 3  # rotate so that the longest edge is v0–v1
        s = np.take_along_axis(s, order[:, :, None], axis=1)
        a, b, c = s[:, 0], s[:, 1], s[:, 2]
        m = 0.5 * (a + b)
        tri = np.concatenate([np.stack([a, m, c], axis=1), np.stack([m, b, c], axis=1)])
        ids = np.concatenate([ids[split], ids[split]])
    if not done:
        return np.zeros((0, 3, 3)), np.zeros(0, np.int64)
    return np.concatenate(done), np.concatenate(done_ids)

def _pieces_near(pts: NDArray[np.float64], vertices: ArrayLike, faces: NDArray, radius: float, edge_per_radius: float
                 ) -> tuple[NDArray[np.float64], NDArray[np.int64], NDArray[np.float64], NDArray[np.float64]] | None:
    """The triangles that reach the points' box grown by ``radius``, bisected until no edge exceeds
    max(edge_per_radius·radius, √(4·area/10⁶)) (doubled while that makes over 4·10⁶ pieces, as slivers can):
    (m, 3, 3) pieces, (m,) the face each came from, (m, 3) their centroids and (m,) their largest centroid–vertex
    distances; None when no triangle is near."""
    tri = np.asarray(vertices, np.float64)[faces]
    lo, hi = pts.min(axis=0) - radius, pts.max(axis=0) + radius
    keep = np.flatnonzero((tri.max(axis=1) >= lo).all(axis=1) & (tri.min(axis=1) <= hi).all(axis=1))
    if len(keep) == 0:
        return None
    tri = tri[keep]
    area = 0.5 * np.linalg.norm(np.cross(tri[:, 1] - tri[:, 0], tri[:, 2] - tri[:, 0]), axis=1).sum()
    edge = max(edge_per_radius * radius, math.sqrt(4.0 * area / _MAX_PIECES), 1e-6)
    cut = _bisect(tri, keep.astype(np.int64), edge, _PIECE_LIMIT)
    while cut is None:
        edge *= 2.0
        cut = _bisect(tri, keep.astype(np.int64), edge, _PIECE_LIMIT)
    pieces = np.ascontiguousarray(cut[0])
    centroid = pieces.mean(axis=1)
    reach = np.sqrt(np.max([((pieces[:, j] - centroid) ** 2).sum(axis=1) for j in range(3)], axis=0))
    return pieces, cut[1], centroid, reach


def points_near_mesh(points: ArrayLike, vertices: ArrayLike, faces: ArrayLike, radius: float) -> NDArray[np.bool_]:
    """(n,) whether each point lies within ``radius`` (m) of the triangle mesh — exact point–triangle distances.

    Triangles are bisected until no edge exceeds L = max(4·radius, √(4·area/10⁶)) (L doubled
    while that makes over 4·10⁶ pieces, as slivers can); a point's candidates are the pieces
    whose centroid lies within radius + (largest centroid–vertex distance), found nearest
    first in a k-d tree (k grows until none is left out).
    """
    from scipy.spatial import cKDTree

    pts = np.ascontiguousarray(points, np.float64).reshape(-1, 3)
    out = np.zeros(len(pts), bool)
    faces = np.asarray(faces)
    if len(pts) == 0 or len(faces) == 0:
        return out
    cut = _pieces_near(pts, vertices, faces, radius, 4.0)
    if cut is None:
        return out
    pieces, _, centroid, reach_each = cut
    reach = float(reach_each.max())
    bound = radius + reach + 1e-9 * (1.0 + float(np.abs(centroid).max()))
    tree = cKDTree(centroid)
    m = len(pieces)
    r2 = radius * radius
    for b0 in range(0, len(pts), _QUERY_BATCH):
        todo = np.arange(b0, min(b0 + _QUERY_BATCH, len(pts)))
        k = 8
        while len(todo):
            kk = min(k, m)
            dist, idx = tree.query(pts[todo], k=kk, distance_upper_bound=bound, workers=-1)
            dist, idx = dist.reshape(len(todo), kk), idx.reshape(len(todo), kk)
            hit = _any_within(pts[todo], idx.astype(np.int64), pieces, r2)
            out[todo[hit]] = True
            if kk == m:
                break
            todo = todo[~hit & np.isfinite(dist[:, -1])]  # all kk within reach: there may be more
            k *= 4
    return out

def sample_surface(vertices: ArrayLike, faces: ArrayLike, n: int, rng: np.random.Generator
                   ) -> tuple[NDArray[np.float64], NDArray[np.int64]]:
    """``n`` points uniformly over the triangles (probability ∝ area, uniform within each) and their face indices."""
    v = np.asarray(vertices, np.float64)
    f = np.asarray(faces)
    tri = v[f]
    areas = 0.5 * np.linalg.norm(np.cross(tri[:, 1] - tri[:, 0], tri[:, 2] - tri[:, 0]), axis=1)
    total = areas.sum()
    if n <= 0 or total <= 0:
        return np.zeros((0, 3)), np.zeros(0, np.int64)
    face = rng.choice(len(areas), size=n, p=areas / total)
    r1, r2 = rng.random(n), rng.random(n)
    s = np.sqrt(r1)
    t = tri[face]
    pts = (1 - s)[:, None] * t[:, 0] + (s * (1 - r2))[:, None] * t[:, 1] + (s * r2)[:, None] * t[:, 2]
    return pts, face

def n_samples(area: float, density: float) -> int:
    return int(np.clip(round(area * density), CT_MIN_SAMPLES, CT_MAX_SAMPLES)) if area > 0 else 0


def nearest_faces(points: ArrayLike, vertices: ArrayLike, faces: ArrayLike, radius: float
                  ) -> tuple[NDArray[np.int64], NDArray[np.float64]]:
    """(n,) the index of the triangle nearest each point among those within ``radius`` (m) — −1 where none is —
    and (n,) its exact point–triangle distance (inf where none is).

    The triangles are bisected until no edge exceeds max(radius, √(4·area/10⁶)) (doubled while that makes over
    4·10⁶ pieces) and indexed by centroid, in groups of like size; a point measures its pieces nearest first until
    the next centroid lies beyond (the nearest distance so far, at most radius) + (the group's largest
    centroid–vertex distance), so the nearest triangle is exact.
    """
    from scipy.spatial import cKDTree

    pts = np.ascontiguousarray(points, np.float64).reshape(-1, 3)
    face = np.full(len(pts), -1, np.int64)
    dist = np.full(len(pts), np.inf)
    faces = np.asarray(faces)
    if len(pts) == 0 or len(faces) == 0:
        return face, dist
    cut = _pieces_near(pts, vertices, faces, radius, 1.0)
    if cut is None:
        return face, dist
    pieces, origin, centroid, reach = cut
    # pieces grouped by their reach (factors of 2), so that small pieces are searched within a small bound
    group = np.floor(np.log2(np.maximum(reach, 1e-9) / max(float(reach.max()), 1e-9))).astype(np.int64)
    group = np.maximum(group, -6)
    r2 = radius * radius
    best = np.full(len(pts), -1, np.int64)
    best_sq = np.full(len(pts), np.inf)
    pad = 1e-9 * (1.0 + float(np.abs(centroid).max()))
    for g in np.unique(group):
        members = np.flatnonzero(group == g)
        part = np.ascontiguousarray(pieces[members])
        bound = radius + float(reach[members].max()) + pad
        tree = cKDTree(centroid[members])
        m = len(members)
        for b0 in range(0, len(pts), _QUERY_BATCH):
            todo = np.arange(b0, min(b0 + _QUERY_BATCH, len(pts)))
            k = 8
            while len(todo):
                kk = min(k, m)
                d, idx = tree.query(pts[todo], k=kk, distance_upper_bound=bound, workers=-1)
                d, idx = d.reshape(len(todo), kk), idx.reshape(len(todo), kk)
                local = np.full(len(todo), -1, np.int64)
                local_sq = best_sq[todo].copy()
                _nearest_within(pts[todo], idx.astype(np.int64), part, r2, local, local_sq)
                better = local >= 0
                best[todo[better]] = members[local[better]]
                best_sq[todo] = local_sq
                if kk == m:
                    break
                # a piece whose centroid lies farther than (the best distance so far) + reach cannot be nearer
                limit = np.minimum(np.sqrt(best_sq[todo]), radius) + float(reach[members].max()) + pad
                todo = todo[d[:, -1] <= limit]
                k *= 4
    found = best >= 0
    face[found] = origin[best[found]]
    dist[found] = np.sqrt(best_sq[found])
    return face, dist
