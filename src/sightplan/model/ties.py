"""Coincident surfaces (ties, METRICS.md §2): the face pairs of different elements that lie on one surface.

Two triangles of different elements are *tied* when each one's vertices lie within
:data:`TIE_TOL_M` (1 mm) of the other's plane, in either orientation, and they overlap in that
plane once each is grown by 1 mm. A pixel whose first hit lies on a tied face, inside the other
triangle within 1 mm of its edges, belongs to both elements.

Finding them is O(F log F): faces are grouped by their plane (unit normal turned to a canonical
sign, quantised finely, and the plane offset in 1 mm bins, each face entered in its own bin and
the next so that offsets 1 mm apart meet), then inside each plane group a sweep along one in-plane
axis compares only faces whose extents overlap, with the exact tests above. Memory is a few
arrays of F entries.
"""

from __future__ import annotations

import numba as nb
import numpy as np
from numpy.typing import NDArray

TIE_TOL_M = 1e-3
_NORMAL_BIN = 1e-3  # quantum of the canonical unit normal's components in the plane key
_MIX = np.array([0x9E3779B97F4A7C15, 0xC2B2AE3D27D4EB4F, 0x165667B19E3779F9, 0xD6E8FEB86659FD93],
                dtype=np.uint64).astype(np.int64)  # odd 64-bit constants


def centred(vertices: NDArray) -> NDArray[np.float64]:
    """The vertices relative to their box centre (plane offsets keep their precision far from the origin)."""
    v = np.asarray(vertices, np.float64)
    return v - (v.min(axis=0) + v.max(axis=0)) / 2 if len(v) else v


def canonical_planes(v: NDArray, faces: NDArray) -> tuple[NDArray, NDArray, NDArray]:
    """(F, 3) unit normals turned so that their largest component is positive, (F,) plane offsets n·v0 of the
    vertices ``v`` (:func:`centred` ones), and (F,) bool for faces with an area (degenerate ones have no plane)."""
    if len(faces) == 0:
        return np.zeros((0, 3)), np.zeros(0), np.zeros(0, bool)
    a, b, c = v[faces[:, 0]], v[faces[:, 1]], v[faces[:, 2]]
    n = np.cross(b - a, c - a)
    length = np.linalg.norm(n, axis=1)
    ok = length > 1e-12
    n = n / np.where(ok, length, 1.0)[:, None]
    big = np.argmax(np.abs(n), axis=1)
    sign = np.where(n[np.arange(len(n)), big] < 0, -1.0, 1.0)
    n *= sign[:, None]
    return n, np.einsum("ij,ij->i", n, a), ok


def coincident_face_pairs(vertices: NDArray, faces: NDArray, face_element: NDArray,
                          tol: float = TIE_TOL_M) -> NDArray[np.int32]:
    """(k, 2) int32 face index pairs (i < j) of different elements that are coplanar within ``tol`` and overlap
    in their plane within ``tol``; each pair once, sorted."""
    faces = np.asarray(faces)
    if len(faces) < 2:
        return np.zeros((0, 2), np.int32)
    v = centred(vertices)
    n, d, ok = canonical_planes(v, faces)
    idx = np.flatnonzero(ok)
    if len(idx) < 2:
        return np.zeros((0, 2), np.int32)
    qn = np.round(n[idx] / _NORMAL_BIN).astype(np.int64)
    qd = np.floor(d[idx] / tol).astype(np.int64)
    # each face in its own offset bin and in the one below, so two faces ≤ tol apart share a bin; the four integers
    # of a bin mixed into one 64-bit key (one sort, not four; a collision of two bins only adds candidates, which the
    # exact tests then refuse)
    face = np.r_[idx, idx]
    with np.errstate(over="ignore"):
        base = qn[:, 0] * _MIX[0] + qn[:, 1] * _MIX[1] + qn[:, 2] * _MIX[2]
        key = np.r_[base + qd * _MIX[3], base + (qd - 1) * _MIX[3]]
    order = np.argsort(key)
    key, face = key[order], face[order]
    new = np.r_[True, key[1:] != key[:-1]]
    starts = np.flatnonzero(new)
    sizes = np.diff(np.r_[starts, len(face)])
    el = np.asarray(face_element, np.int64)[face]
    # only groups holding faces of two elements or more can hold a tie (most hold the triangles of one quad)
    multi = (sizes > 1) & (np.minimum.reduceat(el, starts) != np.maximum.reduceat(el, starts))
    if not multi.any():
        return np.zeros((0, 2), np.int32)
    pairs = _pairs_in_groups(starts[multi], sizes[multi], face.astype(np.int64), v, np.asarray(faces, np.int64),
                             np.asarray(face_element, np.int64), n, d, float(tol))
    if len(pairs) == 0:
        return np.zeros((0, 2), np.int32)
    pairs = np.unique(pairs, axis=0)  # a pair met in both offset bins once
    return pairs.astype(np.int32)


@nb.njit(cache=True)
def _in_plane_basis(nx, ny, nz):
    """Two unit vectors spanning the plane of unit normal n."""
    if abs(nx) < 0.9:
        ux, uy, uz = 0.0, nz, -ny  # n × x̂
    else:
        ux, uy, uz = -nz, 0.0, nx  # n × ŷ
    s = np.sqrt(ux * ux + uy * uy + uz * uz)
    ux, uy, uz = ux / s, uy / s, uz / s
    return ux, uy, uz, ny * uz - nz * uy, nz * ux - nx * uz, nx * uy - ny * ux


@nb.njit(cache=True)
def _coplanar(fa, fb, V, F, n, d, tol):
    """Every vertex of each triangle within tol of the other's plane."""
    for k in range(3):
        p = F[fb, k]
        if abs(n[fa, 0] * V[p, 0] + n[fa, 1] * V[p, 1] + n[fa, 2] * V[p, 2] - d[fa]) > tol:
            return False
        q = F[fa, k]
        if abs(n[fb, 0] * V[q, 0] + n[fb, 1] * V[q, 1] + n[fb, 2] * V[q, 2] - d[fb]) > tol:
            return False
    return True


@nb.njit(cache=True)
def _separated(ua, va, ub, vb, tol):
    """Whether an edge of triangle a (2D, counter-clockwise or not) separates triangle b by more than tol."""
    area = (ua[1] - ua[0]) * (va[2] - va[0]) - (ua[2] - ua[0]) * (va[1] - va[0])
    orient = 1.0 if area > 0 else -1.0
    for k in range(3):
        x0, y0 = ua[k], va[k]
        x1, y1 = ua[(k + 1) % 3], va[(k + 1) % 3]
        ex, ey = x1 - x0, y1 - y0
        length = np.sqrt(ex * ex + ey * ey)
        if length == 0.0:
            continue
        # inward normal of the edge
        mx, my = -ey * orient / length, ex * orient / length
        far = True
        for j in range(3):
            if (ub[j] - x0) * mx + (vb[j] - y0) * my >= -tol:
                far = False
                break
        if far:
            return True
    return False


@nb.njit(cache=True)
def _pairs_in_groups(starts, sizes, face, V, F, E, n, d, tol):
    out = []
    most = sizes.max()
    umin_, umax_, vmin_, vmax_ = np.empty(most), np.empty(most), np.empty(most), np.empty(most)
    tu_, tv_ = np.empty((most, 3)), np.empty((most, 3))
    for g in range(starts.shape[0]):
        s0, m = starts[g], sizes[g]
        members = face[s0:s0 + m]
        f0 = members[0]
        ux, uy, uz, wx, wy, wz = _in_plane_basis(n[f0, 0], n[f0, 1], n[f0, 2])
        umin, umax, vmin, vmax, tu, tv = umin_[:m], umax_[:m], vmin_[:m], vmax_[:m], tu_[:m], tv_[:m]
        for i in range(m):
            f = members[i]
            for k in range(3):
                p = F[f, k]
                tu[i, k] = ux * V[p, 0] + uy * V[p, 1] + uz * V[p, 2]
                tv[i, k] = wx * V[p, 0] + wy * V[p, 1] + wz * V[p, 2]
            umin[i] = tu[i].min()
            umax[i] = tu[i].max()
            vmin[i] = tv[i].min()
            vmax[i] = tv[i].max()
        order = np.argsort(umin)
        for a in range(m):
            i = order[a]
            fi = members[i]
            for b in range(a + 1, m):
                j = order[b]
                if umin[j] > umax[i] + tol:
                    break
                fj = members[j]
                if E[fi] == E[fj] or vmin[j] > vmax[i] + tol or vmin[i] > vmax[j] + tol:
                    continue
                if not _coplanar(fi, fj, V, F, n, d, tol):
                    continue
                if _separated(tu[i], tv[i], tu[j], tv[j], tol) or _separated(tu[j], tv[j], tu[i], tv[i], tol):
                    continue
                out.append((min(fi, fj), max(fi, fj)))
    res = np.empty((len(out), 2), np.int64)
    for k in range(len(out)):
        res[k, 0] = out[k][0]
        res[k, 1] = out[k][1]
    return res


def tie_summary(pairs: NDArray, face_element: NDArray) -> tuple[int, int]:
    """(faces, elements) that take part in a tie."""
    if len(pairs) == 0:
        return 0, 0
    tied = np.unique(pairs)
    return len(tied), len(np.unique(np.asarray(face_element)[tied]))


def remap_pairs(pairs: NDArray, keep: NDArray[np.bool_]) -> NDArray[np.int32]:
    """The pairs among the faces kept by ``keep`` (F,) bool, in the kept faces' new indices."""
    if len(pairs) == 0:
        return np.zeros((0, 2), np.int32)
    new = np.cumsum(keep) - 1
    both = keep[pairs[:, 0]] & keep[pairs[:, 1]]
    return new[pairs[both]].astype(np.int32)
