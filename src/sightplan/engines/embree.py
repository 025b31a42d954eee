"""Visibility with Intel Embree, the default CPU engine.

The library comes with the ``embreex`` wheel; sightplan calls it through its own thin
binding (:mod:`sightplan.engines.rtc`) so that whole chunks of a frame (ray generation,
8-ray packets, reduction) run in one compiled loop per thread (:mod:`.packets`).
"""

from __future__ import annotations

import numpy as np
from numpy.typing import NDArray

from ..camera.models import Camera, EquirectangularCamera
from ..errors import EngineError
from . import kernels, rtc
from .base import Engine
from .featurecull import BIG_INRADIUS_M, BIG_SHARE_MAX, big_triangles

_UNBOUNDED = np.zeros(0, np.float32)  # no far limit on the rays (packets.first_hits)
_NO_PRIMS = np.zeros(0, np.int32)  # the pixels' triangles not kept (packets.cast_pixels)

try:  # keep the error until this engine is asked for
    from . import packets as _packets

    _IMPORT_ERROR: Exception | None = None if rtc.available() else rtc.load_error()
except ImportError as exc:  # pragma: no cover - depends on the platform
    _IMPORT_ERROR = exc


def available() -> bool:
    return _IMPORT_ERROR is None


def _kernel_rays(origins: NDArray, directions: NDArray) -> tuple[NDArray[np.float32], NDArray[np.float32]]:
    """(n, 3) float32 origins, a broadcast view where they are shared, and directions, for the kernels. These call
    Embree by its address in the process, so numba cannot cache them: each is compiled once per process and type
    of arguments. A broadcast view of one ray counts as contiguous, a type of its own, which cost a second compile
    (0.5 s) in the middle of a frame; one ray goes as two."""
    d = np.asarray(directions, np.float32)
    if len(d) == 1:
        d = np.repeat(d, 2, axis=0)
    return np.broadcast_to(np.asarray(origins, np.float32), d.shape), d


class EmbreeEngine(Engine):
    """First hits from an Embree BVH, cast in coherent 8-ray packets; every kernel releases the GIL."""

    name = "embree"

    def __init__(self, scene, features=None, **kwargs) -> None:
        if _IMPORT_ERROR is not None:
            raise EngineError(f"the embree engine needs embreex ({_IMPORT_ERROR}); install it with `pip install embreex`")
        super().__init__(scene, features, **kwargs)
        self._rtc = rtc.TriangleScene(self.local_vertices, scene.faces)
        self._empty = self._rtc.n_faces == 0
        self._big: tuple[rtc.TriangleScene, NDArray[np.int32]] | None = None

    def close(self) -> None:
        super().close()
        self._rtc.release()
        if self._big is not None:
            self._big[0].release()
        self._empty = True

    def _big_hit(self):
        """first_hit in a second BVH of the scene's big triangles (walls, slabs, panes: :func:`big_triangles`),
        built on first use: the first of them behind a window's bars or a railing proves a block of features hidden
        where the bars' own triangles cannot."""
        if self._big is None:
            with self._index_lock:
                if self._big is None:
                    ids = big_triangles(self.local_vertices, self.scene.faces, BIG_INRADIUS_M)
                    if len(ids) > BIG_SHARE_MAX * len(self.scene.faces):
                        ids = ids[:0]  # the first hits are mostly big already: a second BVH would add little
                    used, faces = np.unique(self.scene.faces[ids], return_inverse=True)
                    self._big = (rtc.TriangleScene(self.local_vertices[used], faces.reshape(-1, 3)),
                                 ids.astype(np.int32))
        scene, ids = self._big
        if scene.n_faces == 0:
            return None

        def hit(origins: NDArray[np.float32], directions: NDArray[np.float32]) -> NDArray[np.int32]:
            n = len(directions)
            o, d = _kernel_rays(origins, directions)
            out = np.full(len(d), -1, np.int32)
            if n:
                _packets.first_hits(scene.handle, o, d, out, rtc.packet_buffer(), _UNBOUNDED)
            return np.where(out >= 0, ids[np.maximum(out, 0)], -1).astype(np.int32)[:n]

        return hit

    def first_hit(self, origins: NDArray[np.float32], directions: NDArray[np.float32]) -> NDArray[np.int32]:
        n = len(directions)
        if self._empty or n == 0:
            return np.full(n, -1, np.int32)
        o, d = _kernel_rays(origins, directions)
        out = np.full(len(d), -1, np.int32)
        _packets.first_hits(self._rtc.handle, o, d, out, rtc.packet_buffer(), _UNBOUNDED)
        return out[:n]

    def _chunk_caster(self, cam: Camera, R: NDArray, C: NDArray, max_rays: int, prims: NDArray | None = None):
        """Rays, packets and reduction fused in one compiled loop (:func:`.packets.cast_pixels`)."""
        prims = _NO_PRIMS if prims is None else prims
        buf = rtc.packet_buffer()
        pending = np.zeros((32 * rtc.LANES, 6))  # hits on faces with ties, counted 256 at a time
        memo = kernels.angle_memo()
        C32 = C.astype(np.float32)
        if isinstance(cam, EquirectangularCamera):
            mode, fx, fy, cx, cy = kernels.MODE_EQUIRECT, 1.0, 1.0, 0.0, 0.0
        else:
            mode, fx, fy, cx, cy = kernels.MODE_PINHOLE, cam.fx, cam.fy, cam.cx, cam.cy
        cols, rows = kernels.direction_tables(mode, cam.width, cam.height, float(fx), float(fy), float(cx), float(cy))

        def cast(p0: int, p1: int, count: NDArray, depth: NDArray, angle: NDArray) -> None:
            if not self._empty:
                _packets.cast_pixels(self._rtc.handle, p0, p1, mode, cam.width, cols, rows, R, C32, C,
                                     self._face_normal, self._face_offset,
                                     self._face_element, *self._ties, self.d_max, count, depth, angle, buf,
                                     pending, prims, memo)

        return cast

    def unoccluded_rays(self, origin32: NDArray[np.float32], directions: NDArray[np.float32],
                        tfar: NDArray[np.float32], tnear: NDArray[np.float32] | None = None) -> NDArray[np.bool_]:
        n = len(directions)
        if n == 0 or self._empty:
            return np.full(n, self._empty, np.bool_)
        origins, directions = _kernel_rays(origin32, directions)
        tfar = np.resize(np.asarray(tfar, np.float32), len(directions))
        tnear = _UNBOUNDED if tnear is None else np.resize(np.asarray(tnear, np.float32), len(directions))
        out = np.zeros(len(directions), np.bool_)
        step = max(4096, -(-n // self.threads))
        cuts = [*range(0, n - step // 2, step), len(directions)] if n > step else [0, len(directions)]

        def part(s: int, e: int) -> None:  # every part thousands of rays long, or the whole
            _packets.unoccluded(self._rtc.handle, origins[s:e], directions[s:e], tnear[s:e] if len(tnear) else tnear,
                                tfar[s:e], out[s:e], rtc.packet_buffer())

        if self._pool is None or len(cuts) == 2:
            part(0, len(directions))
        else:
            list(self._pool.map(part, cuts[:-1], cuts[1:]))
        return out[:n]
