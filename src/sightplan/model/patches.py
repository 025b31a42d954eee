"""Surface patches: the elements of a reconstruction, which has no objects of its own.

:func:`patch_faces` cuts a mesh into connected pieces of roughly equal area whose normals stay within an angle of
each other, so per-element metrics keep a meaning on a reality mesh or a meshed point cloud.
"""

from __future__ import annotations

import math

import numba as nb
import numpy as np
from numpy.typing import ArrayLike, NDArray
from scipy.sparse import coo_matrix
from scipy.sparse.csgraph import connected_components

from ..errors import ModelError
from .scene import ElementTable

#: Default patch area (m²): about a wall panel, so reality patches compare with BIM elements.
PATCH_AREA_M2 = 10.0

#: Default largest angle (°) between a face's normal and its patch seed's normal.
NORMAL_ANGLE_DEG = 30.0

#: Smooth regions and pieces below this share of the patch area join a neighbour (see :func:`patch_faces`).
SMALL_PATCH_SHARE = 0.25

PATCH_CLASS = "RealityPatch"

_VERTEX_QUANTUM_M = 1e-6  # coincident vertices (to a micrometre) are merged for face adjacency

_COS_MERGE = 1e-6  # small regions join neighbours whose mean normal is less than 90° away

def patch_ids(n: int) -> list[str]:
    """Element ids of ``n`` patches: 'patch 00001', 'patch 00002', ... (1-based)."""
    return [f"patch {i + 1:05d}" for i in range(n)]

def patch_table(n: int) -> ElementTable:
    """The element table of ``n`` reality patches: all targets, class RealityPatch, no discipline or dates."""
    ids = patch_ids(n)
    return ElementTable.build(global_id=ids, name=ids, ifc_class=[PATCH_CLASS] * n)

# =========================================================================== patches
def _face_adjacency(vertices: NDArray, faces: NDArray) -> tuple[NDArray[np.int64], NDArray[np.float64]]:
    """(k, 2) pairs of faces sharing an edge (coincident vertices merged) and (k,) the shared edge's length.

    An edge shared by more than two faces links them in a chain (all end up connected).
    """
    if len(faces) == 0:
        return np.zeros((0, 2), np.int64), np.zeros(0)
    q = np.round(vertices / _VERTEX_QUANTUM_M).astype(np.int64)
    _, vid = np.unique(q, axis=0, return_inverse=True)
    vid = vid.reshape(-1)
    f = vid[faces]
    edges = np.concatenate([f[:, [0, 1]], f[:, [1, 2]], f[:, [2, 0]]])
    ends = np.concatenate([faces[:, [0, 1]], faces[:, [1, 2]], faces[:, [2, 0]]])
    owner = np.tile(np.arange(len(faces), dtype=np.int64), 3)
    edges.sort(axis=1)
    ok = edges[:, 0] != edges[:, 1]
    edges, ends, owner = edges[ok], ends[ok], owner[ok]
    key = edges[:, 0] * (int(vid.max()) + 1) + edges[:, 1]
    order = np.argsort(key, kind="stable")
    key, owner, ends = key[order], owner[order], ends[order]
    same = (key[1:] == key[:-1]) & (owner[1:] != owner[:-1])
    pairs = np.column_stack([owner[:-1][same], owner[1:][same]])
    e = ends[:-1][same]
    length = np.linalg.norm(vertices[e[:, 1]] - vertices[e[:, 0]], axis=1)
    return pairs, length

def _csr(pairs: NDArray[np.int64], n: int) -> tuple[NDArray[np.int64], NDArray[np.int64]]:
    """Symmetric adjacency lists of ``n`` nodes as (indptr, indices), neighbours in ascending order."""
    src = np.concatenate([pairs[:, 0], pairs[:, 1]])
    dst = np.concatenate([pairs[:, 1], pairs[:, 0]])
    order = np.lexsort((dst, src))
    indptr = np.zeros(n + 1, np.int64)
    np.cumsum(np.bincount(src, minlength=n), out=indptr[1:])
    return indptr, dst[order].astype(np.int64)

@nb.njit(cache=True)
def _grow_regions(indptr, indices, normals, valid, cos_limit):  # pragma: no cover - compiled
    """Label faces by region growing: seeds in face order; a neighbour joins when its normal is within
    the angle of the seed's. Degenerate faces (``valid`` False) join any region and seed only at the end."""
    n = len(indptr) - 1
    label = np.full(n, -1, np.int32)
    stack = np.empty(max(n, 1), np.int64)
    regions = 0
    for second_pass in range(2):
        for seed in range(n):
            if label[seed] >= 0 or (second_pass == 0 and not valid[seed]):
                continue
            seed_ok = valid[seed]
            label[seed] = regions
            stack[0] = seed
            top = 1
            while top > 0:
                top -= 1
                f = stack[top]
                for k in range(indptr[f], indptr[f + 1]):
                    g = indices[k]
                    if label[g] >= 0:
                        continue
                    if valid[g]:
                        if not seed_ok:
                            continue
                        d = normals[seed, 0] * normals[g, 0] + normals[seed, 1] * normals[g, 1] + normals[seed, 2] * normals[g, 2]
                        if d < cos_limit:
                            continue
                    label[g] = regions
                    stack[top] = g
                    top += 1
            regions += 1
    return label, regions

def _dense(labels: NDArray) -> tuple[NDArray[np.int32], int]:
    """Labels renumbered 0..n-1 in the order of their first face."""
    _, first, inverse = np.unique(labels, return_index=True, return_inverse=True)
    rank = np.empty(len(first), np.int64)
    rank[np.argsort(first, kind="stable")] = np.arange(len(first))
    return rank[inverse.reshape(-1)].astype(np.int32), len(first)

def _merge_small(labels: NDArray, pairs: NDArray, length: NDArray, area: NDArray, normal_sum: NDArray,
                 min_area: float, cos_merge: float, group: NDArray | None = None,
                 kept: NDArray | None = None) -> NDArray[np.int32]:
    """Merge regions smaller than ``min_area`` into the neighbour they share the longest boundary with.

    With ``kept`` (per face), a region without a kept face is merged whatever its area.
    Only into a neighbour of higher rank (holding a kept face, then larger, then lower
    label), whose mean normal has a dot product above ``cos_merge`` with its own and, when
    ``group`` is given, of the same group; repeated until stable.
    """
    labels, n = _dense(labels)
    for _ in range(32):
        region_area = np.bincount(labels, area, n)
        has_kept = np.ones(n, bool) if kept is None else np.bincount(labels, kept, n) > 0
        mean = np.stack([np.bincount(labels, normal_sum[:, i], n) for i in range(3)], axis=1)
        norm = np.linalg.norm(mean, axis=1, keepdims=True)
        mean = np.divide(mean, norm, out=np.zeros_like(mean), where=norm > 0)
        ra, rb = labels[pairs[:, 0]], labels[pairs[:, 1]]
        cross = ra != rb
        if not cross.any():
            break
        a = np.concatenate([ra[cross], rb[cross]]).astype(np.int64)
        b = np.concatenate([rb[cross], ra[cross]]).astype(np.int64)
        shared = np.concatenate([length[cross], length[cross]])
        keys, inverse = np.unique(a * n + b, return_inverse=True)
        total = np.bincount(inverse.reshape(-1), shared)
        a, b = keys // n, keys % n
        ka, kb = has_kept[a], has_kept[b]
        higher = (kb & ~ka) | ((kb == ka) & ((region_area[b] > region_area[a]) | ((region_area[b] == region_area[a]) & (b < a))))
        small = (region_area[a] < min_area) | ~ka
        ok = small & higher & (np.einsum("ij,ij->i", mean[a], mean[b]) > cos_merge)
        if group is not None:
            region_group = np.zeros(n, np.int64)
            region_group[labels] = group
            ok &= region_group[a] == region_group[b]
        if not ok.any():
            break
        a, b, total = a[ok], b[ok], total[ok]
        order = np.lexsort((b, -total, a))
        a, b = a[order], b[order]
        first = np.r_[True, a[1:] != a[:-1]]
        target = np.arange(n)
        target[a[first]] = b[first]
        for _ in range(64):  # targets are strictly larger, so following them ends
            nxt = target[target]
            if (nxt == target).all():
                break
            target = nxt
        labels, n = _dense(target[labels])
    return labels

def _bisect(idx: NDArray[np.int64], centroid: NDArray, area: NDArray, k: int, out: list[NDArray[np.int64]]) -> None:
    """Split faces ``idx`` into ``k`` parts of equal area by cuts across the longest extent of their centroids."""
    if k <= 1 or len(idx) < 2:
        out.append(idx)
        return
    c = centroid[idx]
    axis = int(np.argmax(np.ptp(c, axis=0)))
    o1, o2 = (a for a in range(3) if a != axis)
    order = np.lexsort((idx, c[:, o2], c[:, o1], c[:, axis]))
    cum = np.cumsum(area[idx][order])
    k1 = k // 2
    target = cum[-1] * k1 / k
    i = min(int(np.searchsorted(cum, target)), len(cum) - 1)
    if i > 0 and target - cum[i - 1] < cum[i] - target:
        i -= 1
    i = min(i, len(cum) - 2)
    _bisect(idx[order[: i + 1]], centroid, area, k1, out)
    _bisect(idx[order[i + 1:]], centroid, area, k - k1, out)

def patch_faces(vertices: ArrayLike, faces: ArrayLike, patch_area_m2: float = PATCH_AREA_M2,
                normal_angle_deg: float = NORMAL_ANGLE_DEG) -> tuple[NDArray[np.int32], int]:
    """Group faces into connected surface patches of about ``patch_area_m2``; returns ((F,) int32 patch, n_patches).

    1. Smooth regions: region growing over edge-adjacent faces (coincident vertices merged),
       seeds in face order; a face joins when its normal is within ``normal_angle_deg`` of
       the seed's. A region below ``SMALL_PATCH_SHARE`` × the patch area joins the larger
       neighbour it shares the longest boundary with among those whose mean normal is less
       than 90° from its own (noise, slivers and bevels merge; faces meeting at 90° or more,
       like a box's sides, never share a patch).
    2. A region of area A is cut into k = max(1, round(A / patch_area_m2)) parts of equal
       area by recursive cuts across the longest extent of its face centroids (a cut falls
       between faces, so a part is off by at most one face per cut).
    3. A part that is not connected keeps its largest connected piece; the other pieces, and
       parts below the small share, join the adjacent part of the same region they share the
       longest boundary with.

    Deterministic: patches are numbered in the order of their first face.
    """
    v = np.asarray(vertices, np.float64)
    f = np.asarray(faces, np.int64)
    patch_area_m2, normal_angle_deg = patch_options(patch_area_m2, normal_angle_deg)
    if len(f) == 0:
        return np.zeros(0, np.int32), 0
    tri = v[f]
    cross = np.cross(tri[:, 1] - tri[:, 0], tri[:, 2] - tri[:, 0])
    double_area = np.linalg.norm(cross, axis=1)
    area = 0.5 * double_area
    valid = double_area > 1e-12 * max(1.0, float(double_area.max()))
    normal = np.divide(cross, double_area[:, None], out=np.zeros_like(cross), where=valid[:, None])
    pairs, length = _face_adjacency(v, f)
    indptr, indices = _csr(pairs, len(f))
    min_area = SMALL_PATCH_SHARE * patch_area_m2

    region, _ = _grow_regions(indptr, indices, normal, valid, math.cos(math.radians(normal_angle_deg)))
    region = _merge_small(region, pairs, length, area, 0.5 * cross, min_area, _COS_MERGE)
    n_regions = int(region.max()) + 1

    centroid = tri.mean(axis=1)
    region_area = np.bincount(region, area, n_regions)
    order = np.argsort(region, kind="stable")
    starts = np.r_[0, np.cumsum(np.bincount(region, minlength=n_regions))]
    part = np.empty(len(f), np.int64)
    n_parts = 0
    for r in range(n_regions):
        idx = order[starts[r]:starts[r + 1]]
        pieces: list[NDArray[np.int64]] = []
        _bisect(idx, centroid, area, max(1, round(region_area[r] / patch_area_m2)), pieces)
        for p in pieces:
            part[p] = n_parts
            n_parts += 1

    # connected pieces of each part: the largest stays, the others join a neighbouring part of the region
    inside = part[pairs[:, 0]] == part[pairs[:, 1]]
    graph = coo_matrix((np.ones(int(inside.sum())), (pairs[inside, 0], pairs[inside, 1])), shape=(len(f), len(f)))
    n_pieces, piece = connected_components(graph, directed=False)
    piece_area = np.bincount(piece, area, n_pieces)
    piece_part = np.zeros(n_pieces, np.int64)
    piece_part[piece] = part
    by_part = np.lexsort((-piece_area, piece_part))
    largest = by_part[np.r_[True, piece_part[by_part][1:] != piece_part[by_part][:-1]]]
    kept = np.zeros(n_pieces, bool)
    kept[largest] = True
    piece = _merge_small(piece, pairs, length, area, 0.5 * cross, min_area, -2.0, group=region, kept=kept[piece])
    return _dense(piece)

def patch_options(patch_area_m2: float | None, normal_angle_deg: float | None) -> tuple[float, float]:
    """The patch area (m²) and normal angle (°), defaults filled in, or a ModelError naming the bad one."""
    area = PATCH_AREA_M2 if patch_area_m2 is None else float(patch_area_m2)
    angle = NORMAL_ANGLE_DEG if normal_angle_deg is None else float(normal_angle_deg)
    if not (math.isfinite(area) and area > 0):
        raise ModelError(f"patch area must be a positive number of m², got {patch_area_m2!r}")
    if not 0 <= angle <= 180:
        raise ModelError(f"patch normal angle must be within 0–180°, got {normal_angle_deg!r}")
    return area, angle
