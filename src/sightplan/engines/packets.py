"""Numba kernels that cast packets of 8 rays through Embree (:mod:`sightplan.engines.rtc`).

One call casts a range of a frame's pixels: the directions are generated, cast as
coherent 8-ray packets (``rtcIntersect8``: 8 neighbouring pixels of a row) and reduced
to per-element sums in the same loop, so no array of rays or hits is ever written.
The arithmetic is that of :mod:`sightplan.engines.kernels` (directions rounded to
float32 for the cast, distances and angles recomputed in float64 from the hit plane).

The kernels release the GIL; each worker thread passes its own packet buffer. They are
not cached on disk (they call the library by its address in this process).
"""

from __future__ import annotations

import math

import numba as nb
import numpy as np

from . import rtc
from .kernels import add_pending_ties, hit_sums, pixel_direction

LANES = rtc.LANES
_intersect8 = rtc.intersect8
_occluded8 = rtc.occluded8
_ORG_X, _ORG_Y, _ORG_Z, _TNEAR = rtc.ORG_X, rtc.ORG_Y, rtc.ORG_Z, rtc.TNEAR
_DIR_X, _DIR_Y, _DIR_Z, _TIME = rtc.DIR_X, rtc.DIR_Y, rtc.DIR_Z, rtc.TIME
_TFAR, _MASK, _RAY_ID, _FLAGS = rtc.TFAR, rtc.MASK, rtc.RAY_ID, rtc.FLAGS
_PRIM_ID, _GEOM_ID, _VALID = rtc.PRIM_ID, rtc.GEOM_ID, rtc.VALID
_INVALID = np.uint32(rtc.INVALID_ID)
_WORDS = rtc.PACKET_WORDS + LANES


@nb.njit(nogil=True, inline="always")
def _packet(buf):
    """Views of ``buf`` aligned to 32 bytes: (float words, uint words, int valid mask, packet address, mask address)."""
    base = buf.ctypes.data
    off = ((32 - base % 32) % 32) // 4
    f = buf[off:off + _WORDS]
    u = f.view(np.uint32)
    valid = f[_VALID:_VALID + LANES].view(np.int32)
    addr = base + off * 4
    return f, u, valid, addr, addr + _VALID * 4


@nb.njit(nogil=True, _nrt=False, inline="always")
def _reset_lanes(f, u):
    for k in range(LANES):
        f[_TNEAR + k] = 0.0
        f[_TIME + k] = 0.0
        u[_MASK + k] = 0xFFFFFFFF
        u[_RAY_ID + k] = k
        u[_FLAGS + k] = 0


@nb.njit(nogil=True, _nrt=False)
def cast_pixels(scene, p0, p1, mode, width, cols, rows, R, origin32, origin, face_normal, face_offset,
                face_element, tie_ptr, tie_elem, tie_edge, d_max, count, depth_sum, angle_sum, buf, pending, prims, memo):
    """Cast pixels p0..p1 (row-major) of one camera from ``origin`` and add their first hits to the sums; where
    ``prims`` is not empty, prims[p] = the triangle pixel p hits (left as it is on a miss).

    cols, rows: the frame's :func:`sightplan.engines.kernels.direction_tables`. origin32: (3,) float32 camera
    centre in the scene's frame, as cast; origin: the same in float64, for the distances. Other arguments as
    :func:`sightplan.engines.kernels.add_hit`; pending: (k ≥ 8, 6) float64 scratch for hits on faces with ties,
    whose other elements are counted k at a time by one call (:func:`sightplan.engines.kernels.add_pending_ties`).
    Compiled without reference counting, as the kernels' loops.
    """
    f, u, valid, addr, vaddr = _packet(buf)
    _reset_lanes(f, u)
    for k in range(LANES):
        f[_ORG_X + k] = origin32[0]
        f[_ORG_Y + k] = origin32[1]
        f[_ORG_Z + k] = origin32[2]
    m = 0  # hits waiting in ``pending``
    col = p0 % width  # the column and row of the next pixel, kept without a division per pixel
    row = p0 // width
    for start in range(p0, p1, LANES):
        n = min(LANES, p1 - start)
        for k in range(LANES):
            if k < n:
                x, y, z = pixel_direction(mode, col, row, cols, rows, R)
                col += 1
                if col == width:
                    col = 0
                    row += 1
                f[_DIR_X + k] = x
                f[_DIR_Y + k] = y
                f[_DIR_Z + k] = z
                f[_TFAR + k] = np.inf
                u[_GEOM_ID + k] = _INVALID
                valid[k] = -1
            else:
                valid[k] = 0
        _intersect8(vaddr, scene, addr, 0)
        if m > pending.shape[0] - LANES:  # no room for another packet's hits
            add_pending_ties(pending, m, face_element, tie_ptr, tie_elem, tie_edge, count, depth_sum, angle_sum)
            m = 0
        for k in range(n):
            if u[_GEOM_ID + k] != _INVALID:
                p = np.int64(u[_PRIM_ID + k])
                if prims.shape[0]:
                    prims[start + k] = p
                d0, d1, d2 = np.float64(f[_DIR_X + k]), np.float64(f[_DIR_Y + k]), np.float64(f[_DIR_Z + k])
                t, a = hit_sums(p, d0, d1, d2, origin, R, mode, face_normal, face_offset, face_element, d_max, count,
                                depth_sum, angle_sum, memo)
                if t >= 0.0 and tie_ptr[p] != tie_ptr[p + 1]:  # on a face with ties: later, with others
                    pending[m, 0] = p
                    pending[m, 1] = origin[0] + t * d0
                    pending[m, 2] = origin[1] + t * d1
                    pending[m, 3] = origin[2] + t * d2
                    pending[m, 4] = t
                    pending[m, 5] = a
                    m += 1
    if m:
        add_pending_ties(pending, m, face_element, tie_ptr, tie_elem, tie_edge, count, depth_sum, angle_sum)


@nb.njit(nogil=True, _nrt=False, inline="always")
def _load(f, u, valid, origins, directions, tfar, start, n_rays):
    """Lanes 0..7 of the packet from rays start..start+8 (origins may be a broadcast view); the others off.
    ``tfar`` (n,) per ray, or an empty array for "unbounded" (then the hit ids are reset too). Returns the lanes used."""
    n = min(LANES, n_rays - start)
    for k in range(LANES):
        if k < n:
            i = start + k
            f[_ORG_X + k] = origins[i, 0]
            f[_ORG_Y + k] = origins[i, 1]
            f[_ORG_Z + k] = origins[i, 2]
            f[_DIR_X + k] = directions[i, 0]
            f[_DIR_Y + k] = directions[i, 1]
            f[_DIR_Z + k] = directions[i, 2]
            if tfar.shape[0]:
                f[_TFAR + k] = tfar[i]
            else:
                f[_TFAR + k] = np.inf
                u[_GEOM_ID + k] = _INVALID
            valid[k] = -1
        else:
            valid[k] = 0
    return n


@nb.njit(nogil=True, _nrt=False)
def first_hits(scene, origins, directions, out, buf, unbounded):
    """out[i] = the first triangle hit by ray i (−1 on a miss); origins may be a broadcast (n, 3) view; unbounded: an
    empty float32 array (no ray has a far limit)."""
    f, u, valid, addr, vaddr = _packet(buf)
    _reset_lanes(f, u)
    for start in range(0, directions.shape[0], LANES):
        n = _load(f, u, valid, origins, directions, unbounded, start, directions.shape[0])
        _intersect8(vaddr, scene, addr, 0)
        for k in range(n):
            out[start + k] = -1 if u[_GEOM_ID + k] == _INVALID else np.int32(u[_PRIM_ID + k])


@nb.njit(nogil=True, _nrt=False)
def unoccluded(scene, origins, directions, tnear, tfar, out, buf):
    """out[i] = True when nothing is hit along ray i between ``tnear[i]`` and ``tfar[i]`` (``rtcOccluded8``, which
    skips every box outside that stretch); tnear may be empty (0 for every ray); origins as :func:`first_hits`."""
    f, u, valid, addr, vaddr = _packet(buf)
    _reset_lanes(f, u)
    for start in range(0, directions.shape[0], LANES):
        n = _load(f, u, valid, origins, directions, tfar, start, directions.shape[0])
        if tnear.shape[0]:
            for k in range(n):
                f[_TNEAR + k] = tnear[start + k]
        _occluded8(vaddr, scene, addr, 0)
        for k in range(n):
            # an occluded ray comes back with tfar = −inf
            out[start + k] = not math.isinf(f[_TFAR + k])
