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

# The loops over pixels, hits and features, and the helpers they call once per item, allocate nothing: they are
# compiled without numba's reference counting (``_nrt=False``), the helpers inlined into them. With it, every call
# that passes arrays added and dropped a reference to each (atomic operations, inlined or not), and the per-hit sums
# of a frame cost as much as casting its rays.
per_ray = nb.njit(nogil=True, cache=True, _nrt=False, inline="always")  # a small helper called per item
no_refs = nb.njit(nogil=True, cache=True, _nrt=False)  # a loop that allocates nothing, or a larger helper: called,
# not inlined, so the ties' tests are compiled once rather than into every loop that uses them (minutes on a fresh
# install otherwise)


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


@per_ray
def table_direction(mode, p, width, cols, rows, R):
    """Unit world direction (float64 x, y, z) of pixel p (row-major), from :func:`direction_tables`; R: camera to world."""
    return pixel_direction(mode, p % width, p // width, cols, rows, R)


@per_ray
def pixel_direction(mode, u, v, cols, rows, R):
    """:func:`table_direction` of the pixel in column u of row v."""
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
    frame. A face f with ties has the entries ``tie_ptr[f]:tie_ptr[f + 1]`` (most faces have none):

    - a header (element −1): row 0 the unit axis u along f's longest edge; row 1 the in-plane axis v ⟂ u and, in
      its fourth column, the number of grid rows nv; row 2 the grid's origin (u0, v0) and its inverse cell sizes;
      row 3 the number of grid columns nu. From its row 4 on, spilling into as many further entries (element −1)
      as it needs, the cell directory: per cell its first entry (relative to the header) and the longest span
      along u of its entries, then the end of the last cell;
    - per cell of the face's nu × nv grid in (u, v), the tied triangles that overlap it, sorted by where they
      start along u. A triangle spanning several cells is in each. An entry is: its element; rows 0–2 its three
      edges (vertex k to k + 1) as in-plane inward unit normals m and offsets m·a (m·X − offset is X's distance
      inside the edge's line); row 3 its span [lo, hi] along u, widened by the tolerance; rows 4–6 its vertices,
      and in their fourth column its unit normal, for the distance to a corner (:func:`inside_tied`).

    A hit X then tests only the entries of its cell with s − span ≤ lo ≤ s, s = u·X (:func:`tie_window`): a floor
    tied to thousands of chair legs, or a long flange tied to many small plates, costs a few tests per hit, not
    one per tied triangle. Faces with few ties have one cell.
    """
    n_faces = len(faces)
    faces = np.asarray(faces)
    pairs = np.asarray(pairs, np.int64).reshape(-1, 2)
    src = np.r_[pairs[:, 0], pairs[:, 1]]
    dst = np.r_[pairs[:, 1], pairs[:, 0]]
    elem = np.asarray(face_element, np.int64)
    if len(src) == 0:
        return np.zeros(n_faces + 1, np.int64), np.zeros(0, np.int32), np.zeros((0, TIE_ROWS, 4))
    own = np.asarray(local_vertices, np.float64)[faces[src]]  # the hit face's axes: u along its longest edge
    edges = np.stack([own[:, 1] - own[:, 0], own[:, 2] - own[:, 1], own[:, 0] - own[:, 2]], axis=1)
    longest = np.argmax(np.linalg.norm(edges, axis=2), axis=1)
    axis_u = _unit(edges[np.arange(len(src)), longest])
    axis_v = _unit(np.cross(np.cross(edges[:, 0], -edges[:, 2]), axis_u))
    tri = np.asarray(local_vertices, np.float64)[faces[dst]]  # (k, 3, 3)
    along = np.einsum("kvc,kc->kv", tri, axis_u)
    across = np.einsum("kvc,kc->kv", tri, axis_v)
    own_u = np.einsum("kvc,kc->kv", own, axis_u)
    own_v = np.einsum("kvc,kc->kv", own, axis_v)
    lo, hi = along.min(axis=1) - TIE_TOL_M, along.max(axis=1) + TIE_TOL_M
    order = np.lexsort((lo, src))
    src, dst, tri, lo, hi = src[order], dst[order], tri[order], lo[order], hi[order]
    axis_u, axis_v, own_u, own_v, across = axis_u[order], axis_v[order], own_u[order], own_v[order], across[order]
    first = np.flatnonzero(np.r_[True, src[1:] != src[:-1]])
    counts = np.diff(np.r_[first, len(src)])
    vlo, vhi = across.min(axis=1) - TIE_TOL_M, across.max(axis=1) + TIE_TOL_M
    umin = own_u[first].min(axis=1) - TIE_TOL_M
    vmin = own_v[first].min(axis=1) - TIE_TOL_M
    group = np.repeat(np.arange(len(first)), counts)
    nu, nv, iu, iv, cells = _tie_grids(counts, group, lo, hi, vlo, vhi, umin, own_u[first].max(axis=1) + TIE_TOL_M,
                                       vmin, own_v[first].max(axis=1) + TIE_TOL_M)
    n_cells = nu * nv
    spill = np.maximum(0, -(-(TIE_DIRECTORY + 2 * n_cells + 1 - 4 * TIE_ROWS) // (4 * TIE_ROWS)))
    copies = np.bincount(group, weights=(cells[1] - cells[0] + 1) * (cells[3] - cells[2] + 1),
                         minlength=len(first)).astype(np.int64)
    per_face = np.zeros(n_faces, np.int64)
    per_face[src[first]] = 1 + spill + copies
    ptr = np.zeros(n_faces + 1, np.int64)
    np.cumsum(per_face, out=ptr[1:])
    rows = np.zeros((len(src), TIE_ROWS, 4))
    normal = _unit(np.cross(tri[:, 1] - tri[:, 0], tri[:, 2] - tri[:, 0]))
    for j in range(3):
        a, b = tri[:, j], tri[:, (j + 1) % 3]
        m = _unit(np.cross(normal, b - a))  # toward the third vertex
        rows[:, j, :3] = m
        rows[:, j, 3] = np.einsum("ij,ij->i", m, a)
        rows[:, 4 + j, :3] = a
        rows[:, 4 + j, 3] = normal[:, j]
    rows[:, 3, 0] = lo
    rows[:, 3, 1] = hi
    out_elem = np.full(ptr[-1], -1, np.int32)
    out_edge = np.zeros((ptr[-1], TIE_ROWS, 4))
    head = ptr[src[first]]
    # every (triangle, cell) copy, in the order of group, cell, then lo (the entries are sorted by lo already)
    wide = cells[1] - cells[0] + 1
    n_copy = wide * (cells[3] - cells[2] + 1)
    entry = np.repeat(np.arange(len(src)), n_copy)
    k = np.arange(len(entry)) - np.repeat(np.cumsum(n_copy) - n_copy, n_copy)
    cell = (cells[2][entry] + k // wide[entry]) * nu[group[entry]] + cells[0][entry] + k % wide[entry]
    order = np.lexsort((entry, cell, group[entry]))
    entry, cell = entry[order], cell[order]
    g = group[entry]
    cell_base = np.cumsum(n_cells) - n_cells  # each group's first cell among all groups' cells
    in_cell = np.bincount(cell_base[g] + cell, minlength=int(n_cells.sum()))
    before = np.cumsum(in_cell) - in_cell  # copies in the earlier cells of every group
    group_start = before[cell_base]
    slot = head[g] + 1 + spill[g] + np.arange(len(entry)) - (np.cumsum(copies) - copies)[g]
    out_elem[slot] = elem[dst][entry]
    out_edge[slot] = rows[entry]
    out_edge[head, 0, :3] = axis_u[first]
    out_edge[head, 1, :3] = axis_v[first]
    out_edge[head, 1, 3] = nv
    out_edge[head, 2, 0] = umin
    out_edge[head, 2, 1] = vmin
    out_edge[head, 2, 2] = iu
    out_edge[head, 2, 3] = iv
    out_edge[head, 3, 0] = nu
    # the directory: per cell its first entry after the header and the longest span of its entries, then the end
    span = np.zeros(len(in_cell))
    np.maximum.at(span, cell_base[g] + cell, hi[entry] - lo[entry])
    cell_group = np.repeat(np.arange(len(first)), n_cells)
    at = head[cell_group] * 4 * TIE_ROWS + TIE_DIRECTORY + 2 * (np.arange(len(in_cell)) - cell_base[cell_group])
    flat = out_edge.reshape(-1)
    flat[at] = 1 + spill[cell_group] + before - group_start[cell_group]
    flat[at + 1] = span
    flat[head * 4 * TIE_ROWS + TIE_DIRECTORY + 2 * n_cells] = 1 + spill + copies
    return ptr, out_elem, out_edge


TIE_DIRECTORY = 16  # a header's cell directory starts at its row 4: float 16 of the 28 an entry holds
TIE_GRID_FROM = 9  # faces with this many tied triangles or more get a grid of cells
TIE_PER_CELL = 8  # tied triangles per cell a grid aims at
TIE_COPIES = 2  # a grid holds at most this many copies of each tied triangle on average (else it coarsens)
TIE_CELL_MARGIN_M = 5e-4  # triangles also join the cells this near, for a hit rounded in float32 (the GL engine)


def _unit(v: np.ndarray) -> np.ndarray:
    return v / np.maximum(np.linalg.norm(v, axis=-1, keepdims=True), 1e-300)


@per_ray
def _cell(x, origin, inverse, n):
    """The cell (0..n − 1) of coordinate x along a grid axis; beyond the grid, its border cell."""
    q = (x - origin) * inverse
    if not q > 0.0:  # also NaN
        return 0
    if q >= n - 1:
        return n - 1
    return int(q)


def _cells(x, origin, inverse, n):
    """:func:`_cell` over arrays: the cell of each coordinate, beyond the grid its border cell."""
    q = (x - origin) * inverse
    return np.where(q > 0.0, np.minimum(np.floor(np.where(q > 0.0, q, 0.0)), n - 1), 0).astype(np.int64)


def _tie_grids(counts, group, lo, hi, vlo, vhi, umin, umax, vmin, vmax):
    """Per face with ties, its grid: (nu, nv, 1/cell u, 1/cell v) and per tied triangle the range of cells it
    overlaps, (u0, u1, v0, v1). About TIE_PER_CELL triangles a cell; a grid whose triangles would be copied more than
    TIE_COPIES times on average is halved until they are not."""
    lu = np.maximum(umax - umin, 1e-9)
    lv = np.maximum(vmax - vmin, 1e-9)
    many = counts >= TIE_GRID_FROM
    want = np.maximum(1, counts // TIE_PER_CELL)
    nu = np.where(many, np.clip(np.round(np.sqrt(want * lu / lv)), 1, 1024), 1).astype(np.int64)
    nv = np.where(many, np.clip(-(-want // nu), 1, 1024), 1).astype(np.int64)
    while True:
        iu = np.where(nu > 1, nu / lu, 0.0)
        iv = np.where(nv > 1, nv / lv, 0.0)
        cells = (_cells(lo - TIE_CELL_MARGIN_M, umin[group], iu[group], nu[group]),
                 _cells(hi + TIE_CELL_MARGIN_M, umin[group], iu[group], nu[group]),
                 _cells(vlo - TIE_CELL_MARGIN_M, vmin[group], iv[group], nv[group]),
                 _cells(vhi + TIE_CELL_MARGIN_M, vmin[group], iv[group], nv[group]))
        copies = np.bincount(group, weights=(cells[1] - cells[0] + 1) * (cells[3] - cells[2] + 1),
                             minlength=len(counts))
        coarsen = (copies > TIE_COPIES * counts) & ((nu > 1) | (nv > 1))
        if not coarsen.any():
            return nu, nv, iu, iv, cells
        nu = np.where(coarsen, (nu + 1) // 2, nu)
        nv = np.where(coarsen, (nv + 1) // 2, nv)


@per_ray
def _tie_float(tie_edge, i):
    """Float i of the table read as one flat run (28 per entry): the cell directory's values."""
    e = i // (4 * TIE_ROWS)
    r = i - e * 4 * TIE_ROWS
    return tie_edge[e, r >> 2, r & 3]


@per_ray
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


@no_refs
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


@per_ray
def tie_window(tie_ptr, tie_edge, f, x0, x1, x2):
    """(start, stop, s): the entries of face f that may hold the point x, s its coordinate along f's axis u: those of
    x's cell that start along u between s − the cell's longest span and s (:func:`tie_table`)."""
    h, s, i = tie_cell(tie_ptr, tie_edge, f, x0, x1, x2)
    first, end, span = tie_directory(tie_edge, h, i)
    start, stop = tie_search(tie_edge, first, end, s - span, s)
    return start, stop, s


@per_ray
def tie_cell(tie_ptr, tie_edge, f, x0, x1, x2):
    """(h, s, i): face f's header entry, x's coordinate s along f's axis u, and where the directory of f's grid
    holds x's cell (:func:`tie_table`)."""
    h = tie_ptr[f]
    s = tie_edge[h, 0, 0] * x0 + tie_edge[h, 0, 1] * x1 + tie_edge[h, 0, 2] * x2
    nu = int(tie_edge[h, 3, 0])
    nv = int(tie_edge[h, 1, 3])
    c = 0
    if nu > 1:
        c = _cell(s, tie_edge[h, 2, 0], tie_edge[h, 2, 2], nu)
    if nv > 1:
        t = tie_edge[h, 1, 0] * x0 + tie_edge[h, 1, 1] * x1 + tie_edge[h, 1, 2] * x2
        c += nu * _cell(t, tie_edge[h, 2, 1], tie_edge[h, 2, 3], nv)
    return h, s, h * 4 * TIE_ROWS + TIE_DIRECTORY + 2 * c


@per_ray
def tie_directory(tie_edge, h, i):
    """(first, end, span): the entries of the cell at directory place i of header h, and their longest span along u."""
    return h + int(_tie_float(tie_edge, i)), h + int(_tie_float(tie_edge, i + 2)), _tie_float(tie_edge, i + 1)


@per_ray
def tie_search(tie_edge, first, end, lo_bound, s):
    """(start, stop): the entries first..end (sorted by where they start along u, lo) with lo_bound ≤ lo ≤ s."""
    a = first
    b = end
    while a < b:  # the first entry starting at or after s − span
        mid = (a + b) // 2
        if tie_edge[mid, 3, 0] < lo_bound:
            a = mid + 1
        else:
            b = mid
    stop = a
    while stop < end and tie_edge[stop, 3, 0] <= s:
        stop += 1
    return a, stop


@per_ray
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


def angle_memo() -> np.ndarray:
    """A fresh ``memo`` for :func:`hit_sums`: no cosine yet (NaN equals none)."""
    return np.array([np.nan, 0.0])


@per_ray
def hit_sums(f, d0, d1, d2, origin, R, mode, face_normal, face_offset, face_element, d_max, count, depth_sum,
             angle_sum, memo):
    """Add one ray's first hit (triangle f, float64 unit direction d) to the sums of the hit face's element; return
    its distance t and angle (t = −1 where the hit does not count: beyond d_max, behind, or along the plane).

    The hit distance is recomputed in float64 from the hit triangle's plane
    (face_normal · X = face_offset), so engines that return only triangle ids give the
    same distances as those that return t.
    θ_p = arccos(clamp(n_p · (−a), 0, 1)), n_p the flat normal turned toward the camera,
    a the optical axis (pinhole) or the axis of the cube face the ray falls in (equirect).
    memo: (2,) float64, the last cosine and its angle (a cosine of NaN to start): neighbouring pixels mostly hit the
    same face at the same cosine, so most pixels skip the arc cosine (4 % of a restaurant frame's time at scale 0.25
    otherwise); the angle is the same number either way.
    """
    n0 = face_normal[f, 0]
    n1 = face_normal[f, 1]
    n2 = face_normal[f, 2]
    dn = n0 * d0 + n1 * d1 + n2 * d2
    if dn == 0.0:
        return -1.0, 0.0
    t = (face_offset[f] - (n0 * origin[0] + n1 * origin[1] + n2 * origin[2])) / dn
    if t > d_max or t < 0.0:
        return -1.0, 0.0
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
    if c != memo[0]:
        memo[0] = c
        memo[1] = math.acos(c) * (180.0 / math.pi)
    a = memo[1]
    count[e] += 1
    depth_sum[e] += t
    angle_sum[e] += a
    return t, a


@per_ray
def add_hit(f, d0, d1, d2, origin, R, mode, face_normal, face_offset, face_element, tie_ptr, tie_elem, tie_edge,
            d_max, count, depth_sum, angle_sum, memo):
    """Add one ray's first hit (triangle f, float64 unit direction d) to the per-element sums (:func:`hit_sums`).

    The pixel counts for the hit face's element and, where the hit lies on a surface it shares with other
    elements (the tie entries of f, :func:`tie_table`: inside the other triangle within 1 mm of its edges), for
    each of those elements too, with the same distance and angle (METRICS.md §2, coincident surfaces).
    """
    t, a = hit_sums(f, d0, d1, d2, origin, R, mode, face_normal, face_offset, face_element, d_max, count, depth_sum,
                    angle_sum, memo)
    if t >= 0.0 and tie_ptr[f] != tie_ptr[f + 1]:
        add_ties(f, face_element[f], origin[0] + t * d0, origin[1] + t * d1, origin[2] + t * d2, t, a, tie_ptr,
                 tie_elem, tie_edge, count, depth_sum, angle_sum)


@per_ray
def add_ties(f, e, x0, x1, x2, t, a, tie_ptr, tie_elem, tie_edge, count, depth_sum, angle_sum):
    """The tail of :func:`add_hit` for a hit X on a face with ties: count the pixel for each other element whose tied
    triangle holds X."""
    start, stop, s = tie_window(tie_ptr, tie_edge, f, x0, x1, x2)
    add_owners(start, stop, s, e, x0, x1, x2, t, a, tie_elem, tie_edge, count, depth_sum, angle_sum)


@per_ray
def add_owners(start, stop, s, e, x0, x1, x2, t, a, tie_elem, tie_edge, count, depth_sum, angle_sum):
    """Count hit X (distance t, angle a) for each element but e that owns it among the tie entries start..stop."""
    for j in range(start, stop):
        eg = tied_owner(tie_elem, tie_edge, j, start, s, x0, x1, x2)
        if eg >= 0 and eg != e:
            count[eg] += 1
            depth_sum[eg] += t
            angle_sum[eg] += a


@no_refs
def add_pending_ties(pending, n, face_element, tie_ptr, tie_elem, tie_edge, count, depth_sum, angle_sum):
    """:func:`add_ties` for the n hits in ``pending`` (rows: face, x, y, z, t, angle), as the Embree caster collects
    them: one call for many hits. Not inlined into the caster, which cannot be cached (it calls Embree
    by its address in the process): compiled once and cached here, the ties' code is not compiled again by every
    process."""
    # Neighbouring pixels mostly fall in the same cell of the same face, between the same entries: the window found
    # last is kept with the four starts that bound it, and a hit whose bound and s fall between them takes it without
    # the search (whose branches a predictor cannot learn). The same comparisons decide either way, so the same window.
    cell = -1
    first = end = start = stop = 0
    span = 0.0
    below = above = reach = beyond = 0.0  # lo of entries start − 1, start, stop − 1 and stop (±inf past the ends)
    for k in range(n):
        f = np.int64(pending[k, 0])
        x0, x1, x2 = pending[k, 1], pending[k, 2], pending[k, 3]
        h, s, i = tie_cell(tie_ptr, tie_edge, f, x0, x1, x2)
        if i != cell:
            cell = i
            first, end, span = tie_directory(tie_edge, h, i)
            below = np.inf  # no window kept
        lo_bound = s - span
        if not (below < lo_bound and not above < lo_bound and reach <= s and not beyond <= s):
            start, stop = tie_search(tie_edge, first, end, lo_bound, s)
            below = tie_edge[start - 1, 3, 0] if start > first else -np.inf
            above = tie_edge[start, 3, 0] if start < end else np.inf
            reach = tie_edge[stop - 1, 3, 0] if stop > start else -np.inf
            beyond = tie_edge[stop, 3, 0] if stop < end else np.inf
        add_owners(start, stop, s, face_element[f], x0, x1, x2, pending[k, 4], pending[k, 5], tie_elem, tie_edge, count,
                   depth_sum, angle_sum)


@no_refs
def accumulate_hits(prim, dirs, origin, R, mode, face_normal, face_offset, face_element, tie_ptr, tie_elem, tie_edge,
                    d_max, count, depth_sum, angle_sum, memo):
    """Add each ray's first hit to per-element sums (see :func:`add_hit`).

    prim: (n,) int32 first-hit triangle (−1 on a miss). dirs: (n, 3) float32 unit world
    directions. origin: (3,) float64 camera centre.
    count (z,) int64, depth_sum (z,) float64 metres, angle_sum (z,) float64 degrees. memo: :func:`hit_sums`'.
    """
    for k in range(prim.shape[0]):
        f = prim[k]
        if f >= 0:
            add_hit(f, np.float64(dirs[k, 0]), np.float64(dirs[k, 1]), np.float64(dirs[k, 2]), origin, R, mode,
                    face_normal, face_offset, face_element, tie_ptr, tie_elem, tie_edge, d_max, count, depth_sum,
                    angle_sum, memo)


@no_refs
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


@no_refs
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
