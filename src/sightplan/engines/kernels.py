"""Numba kernels shared by every ray-casting engine.

They release the GIL, so chunks of one frame run on a thread pool while Embree (which
releases it too) casts the next chunk. No Python loop ever runs per pixel.

Camera conventions are those of :mod:`sightplan.camera.models`.
"""

from __future__ import annotations

import math

import numba as nb
import numpy as np

from ..model.ties import TIE_TOL_M

MODE_PINHOLE = 0
MODE_EQUIRECT = 1
TIE_ROWS = 7  # rows of 4 per tie entry (:func:`tie_table`)


@nb.njit(nogil=True, cache=True)
def direction_tables(mode, width, height, fx, fy, cx, cy):
    """Per-column and per-row terms of the pixels' ray directions, so a frame computes each once.

    Rays pass through pixel centres (u + 0.5, v + 0.5). Pinhole: columns (u + 0.5 − cx)/fx,
    rows (v + 0.5 − cy)/fy. Equirectangular: columns sin and cos of the longitude
    2π(u + 0.5)/W − π, rows cos and sin of the latitude π/2 − π(v + 0.5)/H.
    """
    cols = np.empty((width, 2))
    rows = np.empty((height, 2))
    for u in range(width):
        if mode == MODE_EQUIRECT:
            lon = 2.0 * math.pi * (u + 0.5) / width - math.pi
            cols[u, 0] = math.sin(lon)
            cols[u, 1] = math.cos(lon)
        else:
            cols[u, 0] = (u + 0.5 - cx) / fx
    for v in range(height):
        if mode == MODE_EQUIRECT:
            lat = 0.5 * math.pi - math.pi * (v + 0.5) / height
            rows[v, 0] = math.cos(lat)
            rows[v, 1] = math.sin(lat)
        else:
            rows[v, 0] = (v + 0.5 - cy) / fy
    return cols, rows


@nb.njit(nogil=True, cache=True, inline="always")
def table_direction(mode, p, width, cols, rows, R):
    """Unit world direction (float64 x, y, z) of pixel p (row-major), from :func:`direction_tables`; R: camera to world."""
    u = p % width
    v = p // width
    if mode == MODE_EQUIRECT:
        cl = rows[v, 0]
        x = cl * cols[u, 0]
        y = -rows[v, 1]
        z = cl * cols[u, 1]
    else:
        x = cols[u, 0]
        y = rows[v, 0]
        inv = 1.0 / math.sqrt(x * x + y * y + 1.0)
        x *= inv
        y *= inv
        z = inv
    return (R[0, 0] * x + R[0, 1] * y + R[0, 2] * z,
            R[1, 0] * x + R[1, 1] * y + R[1, 2] * z,
            R[2, 0] * x + R[2, 1] * y + R[2, 2] * z)


@nb.njit(nogil=True, cache=True)
def _directions(mode, p0, p1, width, height, fx, fy, cx, cy, R, out):
    cols, rows = direction_tables(mode, width, height, fx, fy, cx, cy)
    for k in range(p1 - p0):
        out[k, 0], out[k, 1], out[k, 2] = table_direction(mode, p0 + k, width, cols, rows, R)


def pinhole_directions(p0, p1, width, fx, fy, cx, cy, R, out):
    """World ray directions (unit, float32) of pixels p0..p1 (row-major) of a pinhole camera into ``out``."""
    height = (p1 - 1) // width + 1 if p1 > 0 else 1  # the rows these pixels reach
    _directions(MODE_PINHOLE, p0, p1, width, height, float(fx), float(fy), float(cx), float(cy), R, out)


def equirect_directions(p0, p1, width, height, R, out):
    """World ray directions (unit, float32) of pixels p0..p1 of an equirectangular camera into ``out``."""
    _directions(MODE_EQUIRECT, p0, p1, width, height, 1.0, 1.0, 0.0, 0.0, R, out)


def tie_table(pairs: np.ndarray, local_vertices: np.ndarray, faces: np.ndarray, face_element: np.ndarray
              ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Per face, the faces of other elements it is tied to (coincident surfaces, METRICS.md §2), for :func:`add_hit`.

    Returns ``tie_ptr`` (F + 1,) int64, ``tie_elem`` (k,) int32 and ``tie_edge`` (k, 7, 4) float64, in the engine
    frame. A face f with ties has the entries ``tie_ptr[f]:tie_ptr[f + 1]`` (most faces have none): first a header
    (element −1; row 0: the unit axis u along f's longest edge and the longest span of its tied triangles along u),
    then one entry per tied face, sorted by where it starts along u: its element; rows 0–2 its three edges (vertex k
    to k + 1) as in-plane inward unit normals m and offsets m·a (m·X − offset is X's distance inside the edge's
    line); row 3 its span [lo, hi] along u, widened by the tolerance; rows 4–6 its vertices, and in their fourth
    column its unit normal, for the distance to a corner (:func:`inside_tied`). A hit at u·X = s then tests only the
    entries with s − span ≤ lo ≤ s (:func:`tie_window`): a long flange tied to many small plates costs a few tests
    per hit, not one per plate.
    """
    n_faces = len(faces)
    faces = np.asarray(faces)
    pairs = np.asarray(pairs, np.int64).reshape(-1, 2)
    src = np.r_[pairs[:, 0], pairs[:, 1]]
    dst = np.r_[pairs[:, 1], pairs[:, 0]]
    elem = np.asarray(face_element, np.int64)
    if len(src) == 0:
        return np.zeros(n_faces + 1, np.int64), np.zeros(0, np.int32), np.zeros((0, TIE_ROWS, 4))
    own = local_vertices[faces[src]]  # the hit face's axis: its longest edge
    edges = np.stack([own[:, 1] - own[:, 0], own[:, 2] - own[:, 1], own[:, 0] - own[:, 2]], axis=1)
    longest = np.argmax(np.linalg.norm(edges, axis=2), axis=1)
    axis = edges[np.arange(len(src)), longest]
    axis /= np.maximum(np.linalg.norm(axis, axis=1, keepdims=True), 1e-300)
    tri = local_vertices[faces[dst]]  # (k, 3, 3)
    along = np.einsum("kvc,kc->kv", tri, axis)
    lo, hi = along.min(axis=1) - TIE_TOL_M, along.max(axis=1) + TIE_TOL_M
    order = np.lexsort((lo, src))
    src, dst, tri, lo, hi, axis = src[order], dst[order], tri[order], lo[order], hi[order], axis[order]
    first = np.r_[True, src[1:] != src[:-1]]
    counts = np.bincount(src, minlength=n_faces)
    counts[counts > 0] += 1  # the header
    ptr = np.zeros(n_faces + 1, np.int64)
    np.cumsum(counts, out=ptr[1:])
    slot = np.arange(len(src)) + np.cumsum(first)  # each entry after its own face's header and every earlier one
    out_elem = np.full(ptr[-1], -1, np.int32)
    out_edge = np.zeros((ptr[-1], TIE_ROWS, 4))
    out_elem[slot] = elem[dst]
    normal = np.cross(tri[:, 1] - tri[:, 0], tri[:, 2] - tri[:, 0])
    normal /= np.maximum(np.linalg.norm(normal, axis=1, keepdims=True), 1e-300)
    for j in range(3):
        a, b = tri[:, j], tri[:, (j + 1) % 3]
        m = np.cross(normal, b - a)  # toward the third vertex
        m /= np.maximum(np.linalg.norm(m, axis=1, keepdims=True), 1e-300)
        out_edge[slot, j, :3] = m
        out_edge[slot, j, 3] = np.einsum("ij,ij->i", m, a)
        out_edge[slot, 4 + j, :3] = a
        out_edge[slot, 4 + j, 3] = normal[:, j]
    out_edge[slot, 3, 0] = lo
    out_edge[slot, 3, 1] = hi
    head = ptr[src[first]]
    out_edge[head, 0, :3] = axis[first]
    out_edge[head, 0, 3] = np.maximum.reduceat(hi - lo, np.flatnonzero(first))
    return ptr, out_elem, out_edge


@nb.njit(nogil=True, cache=True, inline="always")
def inside_tied(edge, j, x0, x1, x2):
    """Whether point x, projected into the plane of tie entry j's triangle, lies within :data:`TIE_TOL_M` of the
    triangle (METRICS.md §2): inside its three edges, or no farther than that from its nearest edge or corner (never
    the wedge beyond a sharp corner that widening each edge would add)."""
    s0 = edge[j, 0, 0] * x0 + edge[j, 0, 1] * x1 + edge[j, 0, 2] * x2 - edge[j, 0, 3]
    s1 = edge[j, 1, 0] * x0 + edge[j, 1, 1] * x1 + edge[j, 1, 2] * x2 - edge[j, 1, 3]
    s2 = edge[j, 2, 0] * x0 + edge[j, 2, 1] * x1 + edge[j, 2, 2] * x2 - edge[j, 2, 3]
    if s0 < -TIE_TOL_M or s1 < -TIE_TOL_M or s2 < -TIE_TOL_M:
        return False
    if s0 >= 0.0 and s1 >= 0.0 and s2 >= 0.0:
        return True
    return corner_distance(edge, j, x0, x1, x2, s0, s1, s2) <= TIE_TOL_M


@nb.njit(nogil=True, cache=True)
def corner_distance(edge, j, x0, x1, x2, s0, s1, s2):
    """In-plane distance from x to tie entry j's triangle, for a point outside some edge (s_k < 0): the nearest
    point lies on one of those edges."""
    n0, n1, n2 = edge[j, 4, 3], edge[j, 5, 3], edge[j, 6, 3]
    best = np.inf
    for k in range(3):
        sk = s0 if k == 0 else (s1 if k == 1 else s2)
        if sk >= 0.0:
            continue
        a0, a1, a2 = edge[j, 4 + k, 0], edge[j, 4 + k, 1], edge[j, 4 + k, 2]
        b = 4 + (k + 1) % 3
        e0, e1, e2 = edge[j, b, 0] - a0, edge[j, b, 1] - a1, edge[j, b, 2] - a2
        w0, w1, w2 = x0 - a0, x1 - a1, x2 - a2
        h = n0 * w0 + n1 * w1 + n2 * w2  # out of the plane: not part of the in-plane distance
        w0, w1, w2 = w0 - h * n0, w1 - h * n1, w2 - h * n2
        ee = e0 * e0 + e1 * e1 + e2 * e2
        t = 0.0 if ee == 0.0 else min(1.0, max(0.0, (w0 * e0 + w1 * e1 + w2 * e2) / ee))
        d0, d1, d2 = w0 - t * e0, w1 - t * e1, w2 - t * e2
        best = min(best, math.sqrt(d0 * d0 + d1 * d1 + d2 * d2))
    return best


@nb.njit(nogil=True, cache=True, inline="always")
def tie_window(tie_ptr, tie_edge, f, x0, x1, x2):
    """(start, stop, s): the entries of face f that may hold the point x, s its coordinate along f's axis."""
    h = tie_ptr[f]
    s = tie_edge[h, 0, 0] * x0 + tie_edge[h, 0, 1] * x1 + tie_edge[h, 0, 2] * x2
    lo_bound = s - tie_edge[h, 0, 3]
    a = h + 1
    b = tie_ptr[f + 1]
    while a < b:  # the first entry starting at or after s − span
        mid = (a + b) // 2
        if tie_edge[mid, 3, 0] < lo_bound:
            a = mid + 1
        else:
            b = mid
    stop = a
    end = tie_ptr[f + 1]
    while stop < end and tie_edge[stop, 3, 0] <= s:
        stop += 1
    return a, stop, s


@nb.njit(nogil=True, cache=True, inline="always")
def tied_owner(tie_elem, tie_edge, j, start, s, x0, x1, x2):
    """Entry j's element when its triangle holds x and no earlier entry of the window (from ``start``) of the same
    element does (each element counts once per pixel); else −1."""
    if tie_edge[j, 3, 1] < s or not inside_tied(tie_edge, j, x0, x1, x2):
        return -1
    e = tie_elem[j]
    for i in range(start, j):
        if tie_elem[i] == e and tie_edge[i, 3, 1] >= s and inside_tied(tie_edge, i, x0, x1, x2):
            return -1
    return e


@nb.njit(nogil=True, cache=True, inline="always")
def add_hit(f, d0, d1, d2, origin, R, mode, face_normal, face_offset, face_element, tie_ptr, tie_elem, tie_edge,
            d_max, count, depth_sum, angle_sum):
    """Add one ray's first hit (triangle f, float64 unit direction d) to the per-element sums.

    The pixel counts for the hit face's element and, where the hit lies on a surface it shares with other
    elements (the tie entries of f, :func:`tie_table`: inside the other triangle within 1 mm of its edges), for
    each of those elements too, with the same distance and angle (METRICS.md §2, coincident surfaces).

    The hit distance is recomputed in float64 from the hit triangle's plane
    (face_normal · X = face_offset), so engines that return only triangle ids give the
    same distances as those that return t.
    θ_p = arccos(clamp(n_p · (−a), 0, 1)), n_p the flat normal turned toward the camera,
    a the optical axis (pinhole) or the axis of the cube face the ray falls in (equirect).
    """
    n0 = face_normal[f, 0]
    n1 = face_normal[f, 1]
    n2 = face_normal[f, 2]
    dn = n0 * d0 + n1 * d1 + n2 * d2
    if dn == 0.0:
        return
    t = (face_offset[f] - (n0 * origin[0] + n1 * origin[1] + n2 * origin[2])) / dn
    if t > d_max or t < 0.0:
        return
    if dn > 0.0:  # turn the normal toward the camera
        n0 = -n0
        n1 = -n1
        n2 = -n2
    ax0 = R[0, 2]
    ax1 = R[1, 2]
    ax2 = R[2, 2]
    if mode == MODE_EQUIRECT:
        # camera-frame direction = Rᵀ d; the cube face is its largest |component|
        c0 = R[0, 0] * d0 + R[1, 0] * d1 + R[2, 0] * d2
        c1 = R[0, 1] * d0 + R[1, 1] * d1 + R[2, 1] * d2
        c2 = R[0, 2] * d0 + R[1, 2] * d1 + R[2, 2] * d2
        a0, a1, a2 = abs(c0), abs(c1), abs(c2)
        if a0 >= a1 and a0 >= a2:
            j = 0
            s = 1.0 if c0 > 0 else -1.0
        elif a1 >= a2:
            j = 1
            s = 1.0 if c1 > 0 else -1.0
        else:
            j = 2
            s = 1.0 if c2 > 0 else -1.0
        ax0 = s * R[0, j]
        ax1 = s * R[1, j]
        ax2 = s * R[2, j]
    c = -(n0 * ax0 + n1 * ax1 + n2 * ax2)
    if c > 1.0:
        c = 1.0
    elif c < 0.0:
        c = 0.0
    e = face_element[f]
    a = math.acos(c) * (180.0 / math.pi)
    count[e] += 1
    depth_sum[e] += t
    angle_sum[e] += a
    if tie_ptr[f] == tie_ptr[f + 1]:
        return
    x0 = origin[0] + t * d0
    x1 = origin[1] + t * d1
    x2 = origin[2] + t * d2
    start, stop, s = tie_window(tie_ptr, tie_edge, f, x0, x1, x2)
    for j in range(start, stop):
        eg = tied_owner(tie_elem, tie_edge, j, start, s, x0, x1, x2)
        if eg >= 0 and eg != e:
            count[eg] += 1
            depth_sum[eg] += t
            angle_sum[eg] += a


@nb.njit(nogil=True, cache=True, fastmath=False)
def accumulate_hits(prim, dirs, origin, R, mode, face_normal, face_offset, face_element, tie_ptr, tie_elem, tie_edge,
                    d_max, count, depth_sum, angle_sum):
    """Add each ray's first hit to per-element sums (see :func:`add_hit`).

    prim: (n,) int32 first-hit triangle (−1 on a miss). dirs: (n, 3) float32 unit world
    directions. origin: (3,) float64 camera centre.
    count (z,) int64, depth_sum (z,) float64 metres, angle_sum (z,) float64 degrees.
    """
    for k in range(prim.shape[0]):
        f = prim[k]
        if f >= 0:
            add_hit(f, np.float64(dirs[k, 0]), np.float64(dirs[k, 1]), np.float64(dirs[k, 2]), origin, R, mode,
                    face_normal, face_offset, face_element, tie_ptr, tie_elem, tie_edge, d_max, count, depth_sum,
                    angle_sum)


@nb.njit(nogil=True, cache=True)
def smallest_owners(prim, t, dirs, origin, face_element, tie_ptr, tie_elem, tie_edge, ids):
    """Where a ray's hit (triangle prim, distance t, float32 unit direction) lies on a coincident surface, set its
    ``ids`` entry to the smallest element that owns the pixel (METRICS.md §2), so element maps do not depend on
    which of the coincident faces the caster reported. Pixels with ``ids`` < 0 are left alone."""
    for k in range(prim.shape[0]):
        f = prim[k]
        if f < 0 or ids[k] < 0 or tie_ptr[f] == tie_ptr[f + 1]:
            continue
        x0 = origin[0] + t[k] * np.float64(dirs[k, 0])
        x1 = origin[1] + t[k] * np.float64(dirs[k, 1])
        x2 = origin[2] + t[k] * np.float64(dirs[k, 2])
        start, stop, s = tie_window(tie_ptr, tie_edge, f, x0, x1, x2)
        for j in range(start, stop):
            if tie_elem[j] < ids[k] and tie_edge[j, 3, 1] >= s and inside_tied(tie_edge, j, x0, x1, x2):
                ids[k] = tie_elem[j]


@nb.njit(nogil=True, cache=True)
def plane_distances(prim, dirs, origin, face_normal, face_offset, out):
    """Distance along each ray (float32 unit direction) from ``origin`` to its hit triangle's plane; inf on a miss
    (prim < 0), a ray parallel to the plane or a plane behind the origin."""
    for i in range(len(prim)):
        p = prim[i]
        out[i] = np.inf
        if p < 0:
            continue
        dn = face_normal[p, 0] * dirs[i, 0] + face_normal[p, 1] * dirs[i, 1] + face_normal[p, 2] * dirs[i, 2]
        if dn == 0.0:
            continue
        t = (face_offset[p] - (face_normal[p, 0] * origin[0] + face_normal[p, 1] * origin[1]
                               + face_normal[p, 2] * origin[2])) / dn
        if t >= 0.0:
            out[i] = t
