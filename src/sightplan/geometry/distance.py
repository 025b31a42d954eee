"""Exact distances from points and segments to triangles (numba kernels), the one implementation the flight
checks (clearance from the model) and the validation (points near a mesh) share."""

from __future__ import annotations

import math

import numba as nb
import numpy as np


@nb.njit(cache=True, nogil=True)
def point_triangle_sq(px, py, pz, t):
    """Squared distance from point (px, py, pz) to triangle t, (3, 3) vertices by rows (closest point by Voronoi
    regions; a degenerate triangle by its vertices). Scalar arithmetic: nothing is allocated."""
    ax, ay, az = t[0, 0], t[0, 1], t[0, 2]
    abx, aby, abz = t[1, 0] - ax, t[1, 1] - ay, t[1, 2] - az
    acx, acy, acz = t[2, 0] - ax, t[2, 1] - ay, t[2, 2] - az
    apx, apy, apz = px - ax, py - ay, pz - az
    d1 = abx * apx + aby * apy + abz * apz
    d2 = acx * apx + acy * apy + acz * apz
    if d1 <= 0.0 and d2 <= 0.0:
        return apx * apx + apy * apy + apz * apz
    bpx, bpy, bpz = px - t[1, 0], py - t[1, 1], pz - t[1, 2]
    d3 = abx * bpx + aby * bpy + abz * bpz
    d4 = acx * bpx + acy * bpy + acz * bpz
    if d3 >= 0.0 and d4 <= d3:
        return bpx * bpx + bpy * bpy + bpz * bpz
    vc = d1 * d4 - d3 * d2
    if vc <= 0.0 and d1 >= 0.0 and d3 <= 0.0:
        s = d1 / (d1 - d3)
        qx, qy, qz = ax + s * abx, ay + s * aby, az + s * abz
    else:
        cpx, cpy, cpz = px - t[2, 0], py - t[2, 1], pz - t[2, 2]
        d5 = abx * cpx + aby * cpy + abz * cpz
        d6 = acx * cpx + acy * cpy + acz * cpz
        vb = d5 * d2 - d1 * d6
        va = d3 * d6 - d5 * d4
        if d6 >= 0.0 and d5 <= d6:
            return cpx * cpx + cpy * cpy + cpz * cpz
        if vb <= 0.0 and d2 >= 0.0 and d6 <= 0.0:
            s = d2 / (d2 - d6)
            qx, qy, qz = ax + s * acx, ay + s * acy, az + s * acz
        elif va <= 0.0 and (d4 - d3) >= 0.0 and (d5 - d6) >= 0.0:
            s = (d4 - d3) / ((d4 - d3) + (d5 - d6))
            qx, qy, qz = t[1, 0] + s * (t[2, 0] - t[1, 0]), t[1, 1] + s * (t[2, 1] - t[1, 1]), t[1, 2] + s * (t[2, 2] - t[1, 2])
        else:
            den = va + vb + vc
            if den == 0.0:  # degenerate: its vertices
                return min(apx * apx + apy * apy + apz * apz, bpx * bpx + bpy * bpy + bpz * bpz,
                           cpx * cpx + cpy * cpy + cpz * cpz)
            v = vb / den
            w = vc / den
            qx, qy, qz = ax + abx * v + acx * w, ay + aby * v + acy * w, az + abz * v + acz * w
    dx, dy, dz = px - qx, py - qy, pz - qz
    return dx * dx + dy * dy + dz * dz


@nb.njit(cache=True)
def segment_segment_sq(p1, q1, p2, q2):
    """Squared distance between segments p1q1 and p2q2."""
    d1 = q1 - p1
    d2 = q2 - p2
    r = p1 - p2
    a = np.sum(d1 * d1)
    e = np.sum(d2 * d2)
    f = np.sum(d2 * r)
    eps = 1e-18
    if a <= eps and e <= eps:
        return np.sum(r * r)
    if a <= eps:
        s = 0.0
        t = min(max(f / e, 0.0), 1.0)
    else:
        c = np.sum(d1 * r)
        if e <= eps:
            t = 0.0
            s = min(max(-c / a, 0.0), 1.0)
        else:
            b = np.sum(d1 * d2)
            den = a * e - b * b
            s = min(max((b * f - c * e) / den, 0.0), 1.0) if den > eps else 0.0
            t = (b * s + f) / e
            if t < 0.0:
                t = 0.0
                s = min(max(-c / a, 0.0), 1.0)
            elif t > 1.0:
                t = 1.0
                s = min(max((b - c) / a, 0.0), 1.0)
    d = (p1 + d1 * s) - (p2 + d2 * t)
    return np.sum(d * d)


@nb.njit(cache=True)
def segment_hits_triangle(p, q, a, b, c):
    """Whether segment pq crosses triangle abc (Möller–Trumbore on the segment's parameter range)."""
    d = q - p
    e1 = b - a
    e2 = c - a
    h = np.cross(d, e2)
    det = np.sum(e1 * h)
    if abs(det) < 1e-15:
        return False
    inv = 1.0 / det
    s = p - a
    u = inv * np.sum(s * h)
    if u < 0.0 or u > 1.0:
        return False
    qv = np.cross(s, e1)
    v = inv * np.sum(d * qv)
    if v < 0.0 or u + v > 1.0:
        return False
    t = inv * np.sum(e2 * qv)
    return 0.0 <= t <= 1.0


@nb.njit(cache=True, inline="always")
def _gap_sq(lo_a, hi_a, lo_b, hi_b):
    """Squared distance between two axis-aligned boxes (0 when they overlap): a lower bound."""
    g = 0.0
    for k in range(3):
        d = max(lo_b[k] - hi_a[k], lo_a[k] - hi_b[k], 0.0)
        g += d * d
    return g


@nb.njit(cache=True, parallel=True)
def min_point_distances(points, tri, tri_lo, tri_hi, upper_sq):
    """(n,) distance from each point to the nearest of the (F, 3, 3) triangles.

    tri_lo, tri_hi: (F, 3) triangle bounding boxes; upper_sq: (n,) a known upper bound of
    each squared distance (to a vertex, say): triangles whose box lies farther are skipped.
    """
    out = np.empty(points.shape[0])
    for i in nb.prange(points.shape[0]):
        best = upper_sq[i]
        p = points[i]
        for f in range(tri.shape[0]):
            if _gap_sq(p, p, tri_lo[f], tri_hi[f]) >= best:
                continue
            dsq = point_triangle_sq(p[0], p[1], p[2], tri[f])
            if dsq < best:
                best = dsq
        out[i] = math.sqrt(best)
    return out


@nb.njit(cache=True, parallel=True)
def min_segment_distances(p, q, tri, tri_lo, tri_hi, upper_sq):
    """(m,) distance from each segment p[i]q[i] to the nearest of the (F, 3, 3) triangles (boxes as above)."""
    out = np.empty(p.shape[0])
    for i in nb.prange(p.shape[0]):
        best = upper_sq[i]
        s_lo = np.minimum(p[i], q[i])
        s_hi = np.maximum(p[i], q[i])
        for f in range(tri.shape[0]):
            if _gap_sq(s_lo, s_hi, tri_lo[f], tri_hi[f]) >= best:
                continue
            a, b, c = tri[f, 0], tri[f, 1], tri[f, 2]
            if segment_hits_triangle(p[i], q[i], a, b, c):
                best = 0.0
                break
            dsq = min(point_triangle_sq(p[i, 0], p[i, 1], p[i, 2], tri[f]), point_triangle_sq(q[i, 0], q[i, 1], q[i, 2], tri[f]),
                      segment_segment_sq(p[i], q[i], a, b), segment_segment_sq(p[i], q[i], b, c),
                      segment_segment_sq(p[i], q[i], c, a))
            if dsq < best:
                best = dsq
        out[i] = math.sqrt(best)
    return out
