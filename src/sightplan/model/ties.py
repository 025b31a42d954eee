"""Coincident surfaces (ties, METRICS.md §2): the face pairs of different elements that lie on one surface.

Two triangles of different elements are *tied* when each one's vertices lie within
:data:`TIE_TOL_M` (1 mm) of the other's plane, in either orientation, and, projected into the plane
of the pair's first face, they lie within 1 mm of each other (they overlap, or the nearest points of
their outlines are at most 1 mm apart). A pixel whose first hit lies on a tied face, within 1 mm of
the other triangle, belongs to both elements.

Finding them cannot miss a pair: if two triangles pass both tests, some point of one lies within
1 mm of the other's plane projection, and that one within 1 mm of the other triangle, so the two lie
within 2 mm of each other in space, and the point halfway lies within 1 mm of both. Space is cut
into cubic cells; each face is entered in every cell that meets its box grown by 1 mm and its plane
grown by 1 mm, so both faces of a tied pair are in the cell holding that halfway point. Inside each
cell holding faces of two elements or more, a sweep along x compares only faces whose grown boxes
overlap, with the exact tests above. Nothing depends on how the normals or plane offsets round: small
pipe facets a few degrees apart and 45° faces are found like any other.
"""

from __future__ import annotations

import math

import numba as nb
import numpy as np
from numpy.typing import NDArray

TIE_TOL_M = 1e-3
_MAX_CELLS = 2.0**31  # a cell's index and a face's fit one int64


def centred(vertices: NDArray) -> NDArray[np.float64]:
    """The vertices relative to their box centre (plane offsets keep their precision far from the origin)."""
    v = np.asarray(vertices, np.float64)
    return v - (v.min(axis=0) + v.max(axis=0)) / 2 if len(v) else v


@nb.njit(nogil=True, cache=True)
def face_planes(V, F):
    """(F, 3) unit winding normals, (F,) plane offsets n·v0 of the vertices ``V`` (:func:`centred` ones), and (F,)
    bool for faces with an area (degenerate ones have no plane)."""
    m = F.shape[0]
    n = np.zeros((m, 3))
    d = np.zeros(m)
    ok = np.zeros(m, np.bool_)
    for f in range(m):
        a, b, c = F[f, 0], F[f, 1], F[f, 2]
        ex, ey, ez = V[b, 0] - V[a, 0], V[b, 1] - V[a, 1], V[b, 2] - V[a, 2]
        gx, gy, gz = V[c, 0] - V[a, 0], V[c, 1] - V[a, 1], V[c, 2] - V[a, 2]
        nx, ny, nz = ey * gz - ez * gy, ez * gx - ex * gz, ex * gy - ey * gx
        length = math.sqrt(nx * nx + ny * ny + nz * nz)
        if length > 1e-12:
            ok[f] = True
            n[f, 0], n[f, 1], n[f, 2] = nx / length, ny / length, nz / length
            d[f] = n[f, 0] * V[a, 0] + n[f, 1] * V[a, 1] + n[f, 2] * V[a, 2]
    return n, d, ok


def cell_size(v: NDArray, faces: NDArray, ok: NDArray, tol: float) -> float:
    """The grid's cell edge (m): four times the median face's largest box extent (over a sample of the faces), at
    least 2 cm, and large enough that the cells number fewer than 2³¹."""
    if not ok.any() or len(v) == 0:
        return 1.0
    idx = np.flatnonzero(ok)
    tri = v[faces[idx[:: max(1, len(idx) // 65536)]]]
    extent = float(np.median((tri.max(axis=1) - tri.min(axis=1)).max(axis=1)))
    span = v.max(axis=0) - v.min(axis=0) + 4 * tol
    size = max(4.0 * extent, 0.02)
    while float(np.prod(np.floor(span / size) + 1)) >= _MAX_CELLS:
        size *= 1.5
    return size


def coincident_face_pairs(vertices: NDArray, faces: NDArray, face_element: NDArray,
                          tol: float = TIE_TOL_M) -> NDArray[np.int32]:
    """(k, 2) int32 face index pairs (i < j) of different elements that are coplanar within ``tol`` and lie within
    ``tol`` of each other in the plane of face i (see the module docstring); each pair once, sorted."""
    faces = np.asarray(faces)
    if len(faces) < 2:
        return np.zeros((0, 2), np.int32)
    v = centred(vertices)
    F = np.ascontiguousarray(faces, np.int32)
    E = np.ascontiguousarray(face_element, np.int32)
    n, d, ok = face_planes(v, F)
    if ok.sum() < 2 or len(np.unique(E[ok])) < 2:
        return np.zeros((0, 2), np.int32)
    size = cell_size(v, F, ok, tol)
    origin = v.min(axis=0) - 2 * tol
    dims = np.floor((v.max(axis=0) + 2 * tol - origin) / size).astype(np.int64) + 1
    ptr = np.zeros(len(F) + 1, np.int64)
    np.cumsum(_cell_counts(v, F, ok, n, d, origin, size, dims, tol), out=ptr[1:])
    keys = _cell_keys(v, F, ok, n, d, origin, size, dims, tol, ptr)  # cell << 32 | face
    del ptr
    keys.sort()
    pairs = _pairs_in_cells(keys, v, F, E, n, d, float(tol))
    del keys
    if len(pairs) == 0:
        return np.zeros((0, 2), np.int32)
    key = np.unique(pairs[:, 0] * len(F) + pairs[:, 1])  # a pair met in several cells once
    return np.stack([key // len(F), key % len(F)], axis=1).astype(np.int32)


@nb.njit(nogil=True, cache=True)
def _face_cells(V, F, f, n, d, origin, size, dims, tol, out, at):
    """The cells face f is entered in (its box grown by tol, cells its plane grown by tol meets): their count, and
    their keys (cell << 32 | f) written into ``out`` from ``at`` when ``out`` has room."""
    lo = np.empty(3, np.int64)
    hi = np.empty(3, np.int64)
    for c in range(3):
        a = min(V[F[f, 0], c], V[F[f, 1], c], V[F[f, 2], c]) - tol
        b = max(V[F[f, 0], c], V[F[f, 1], c], V[F[f, 2], c]) + tol
        lo[c] = max(0, min(dims[c] - 1, int(math.floor((a - origin[c]) / size))))
        hi[c] = max(0, min(dims[c] - 1, int(math.floor((b - origin[c]) / size))))
    reach = tol + 0.5 * size * (abs(n[f, 0]) + abs(n[f, 1]) + abs(n[f, 2])) + 1e-9 * size
    k = 0
    for ix in range(lo[0], hi[0] + 1):
        cx = origin[0] + (ix + 0.5) * size
        for iy in range(lo[1], hi[1] + 1):
            cy = origin[1] + (iy + 0.5) * size
            for iz in range(lo[2], hi[2] + 1):
                cz = origin[2] + (iz + 0.5) * size
                if abs(n[f, 0] * cx + n[f, 1] * cy + n[f, 2] * cz - d[f]) > reach:
                    continue
                if out.shape[0] > 0:
                    out[at + k] = (((ix * dims[1] + iy) * dims[2] + iz) << 32) | f
                k += 1
    return k


@nb.njit(nogil=True, cache=True)
def _cell_counts(V, F, ok, n, d, origin, size, dims, tol):
    out = np.zeros(F.shape[0], np.int64)
    none = np.empty(0, np.int64)
    for f in range(F.shape[0]):
        if ok[f]:
            out[f] = _face_cells(V, F, f, n, d, origin, size, dims, tol, none, 0)
    return out


@nb.njit(nogil=True, cache=True)
def _cell_keys(V, F, ok, n, d, origin, size, dims, tol, ptr):
    out = np.empty(ptr[-1], np.int64)
    for f in range(F.shape[0]):
        if ok[f]:
            _face_cells(V, F, f, n, d, origin, size, dims, tol, out, ptr[f])
    return out


@nb.njit(nogil=True, cache=True)
def _in_plane_basis(nx, ny, nz):
    """Two unit vectors spanning the plane of unit normal n."""
    if abs(nx) < 0.9:
        ux, uy, uz = 0.0, nz, -ny  # n × x̂
    else:
        ux, uy, uz = -nz, 0.0, nx  # n × ŷ
    s = np.sqrt(ux * ux + uy * uy + uz * uz)
    ux, uy, uz = ux / s, uy / s, uz / s
    return ux, uy, uz, ny * uz - nz * uy, nz * ux - nx * uz, nx * uy - ny * ux


@nb.njit(nogil=True, cache=True)
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


@nb.njit(nogil=True, cache=True)
def _segment_distance(px, py, ax, ay, bx, by):
    """Distance from point p to segment ab (2D)."""
    ex, ey = bx - ax, by - ay
    ll = ex * ex + ey * ey
    t = 0.0 if ll == 0.0 else ((px - ax) * ex + (py - ay) * ey) / ll
    t = min(1.0, max(0.0, t))
    dx, dy = px - (ax + t * ex), py - (ay + t * ey)
    return np.sqrt(dx * dx + dy * dy)


@nb.njit(nogil=True, cache=True)
def _separates(ua, va, ub, vb):
    """Whether the line of an edge of triangle a leaves every vertex of triangle b strictly outside."""
    area = (ua[1] - ua[0]) * (va[2] - va[0]) - (ua[2] - ua[0]) * (va[1] - va[0])
    orient = 1.0 if area > 0 else -1.0
    for k in range(3):
        x0, y0 = ua[k], va[k]
        ex, ey = ua[(k + 1) % 3] - x0, va[(k + 1) % 3] - y0
        far = True
        for j in range(3):
            if ((ub[j] - x0) * -ey + (vb[j] - y0) * ex) * orient >= 0.0:  # on or inside the edge's line
                far = False
                break
        if far:
            return True
    return False


@nb.njit(nogil=True, cache=True)
def triangle_distance_2d(ua, va, ub, vb):
    """Distance between two triangles in a plane (0 when they overlap): the nearest vertex–edge pair otherwise."""
    if not (_separates(ua, va, ub, vb) or _separates(ub, vb, ua, va)):
        return 0.0
    best = np.inf
    for i in range(3):
        for k in range(3):
            j = (k + 1) % 3
            best = min(best, _segment_distance(ua[i], va[i], ub[k], vb[k], ub[j], vb[j]),
                       _segment_distance(ub[i], vb[i], ua[k], va[k], ua[j], va[j]))
    return best


@nb.njit(nogil=True, cache=True)
def _near_in_plane(fa, fb, V, F, n, tol):
    """Triangles fa and fb, projected into fa's plane, within tol of each other."""
    ux, uy, uz, wx, wy, wz = _in_plane_basis(n[fa, 0], n[fa, 1], n[fa, 2])
    ua, va, ub, vb = np.empty(3), np.empty(3), np.empty(3), np.empty(3)
    for k in range(3):
        p, q = F[fa, k], F[fb, k]
        ua[k] = ux * V[p, 0] + uy * V[p, 1] + uz * V[p, 2]
        va[k] = wx * V[p, 0] + wy * V[p, 1] + wz * V[p, 2]
        ub[k] = ux * V[q, 0] + uy * V[q, 1] + uz * V[q, 2]
        vb[k] = wx * V[q, 0] + wy * V[q, 1] + wz * V[q, 2]
    return triangle_distance_2d(ua, va, ub, vb) <= tol


@nb.njit(nogil=True, cache=True)
def _pairs_in_cells(keys, V, F, E, n, d, tol):
    """The tied pairs among the faces of each cell (``keys`` sorted, cell << 32 | face) that hold faces of two
    elements or more: a sweep along x over the faces' boxes grown by tol, then the exact tests."""
    out = []
    low = np.int64(0xFFFFFFFF)
    most = 1
    g0 = 0
    while g0 < keys.shape[0]:  # the largest cell, for the buffers
        g1 = g0 + 1
        while g1 < keys.shape[0] and (keys[g1] >> 32) == (keys[g0] >> 32):
            g1 += 1
        most = max(most, g1 - g0)
        g0 = g1
    box_ = np.empty((most, 6))
    members_ = np.empty(most, np.int64)
    g0 = 0
    while g0 < keys.shape[0]:
        g1 = g0 + 1
        mixed = False
        while g1 < keys.shape[0] and (keys[g1] >> 32) == (keys[g0] >> 32):
            if E[keys[g1] & low] != E[keys[g0] & low]:
                mixed = True
            g1 += 1
        m = g1 - g0
        if not mixed:
            g0 = g1
            continue
        members = members_[:m]
        box = box_[:m]
        for i in range(m):
            f = keys[g0 + i] & low
            members[i] = f
            for c in range(3):
                a = min(V[F[f, 0], c], V[F[f, 1], c], V[F[f, 2], c])
                b = max(V[F[f, 0], c], V[F[f, 1], c], V[F[f, 2], c])
                box[i, c] = a - tol
                box[i, 3 + c] = b + tol
        g0 = g1
        order = np.argsort(box[:, 0])
        for a in range(m):
            i = order[a]
            fi = members[i]
            for b in range(a + 1, m):
                j = order[b]
                if box[j, 0] > box[i, 3]:
                    break
                fj = members[j]
                if E[fi] == E[fj] or box[j, 1] > box[i, 4] or box[i, 1] > box[j, 4] or box[j, 2] > box[i, 5] \
                        or box[i, 2] > box[j, 5]:
                    continue
                lo, hi = min(fi, fj), max(fi, fj)
                if _coplanar(lo, hi, V, F, n, d, tol) and _near_in_plane(lo, hi, V, F, n, tol):
                    out.append((lo, hi))
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
