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

_UNBOUNDED = np.zeros(0, np.float32)  # no far limit on the rays (packets.first_hits)

try:  # keep the error until this engine is asked for
    from . import packets as _packets

    _IMPORT_ERROR: Exception | None = None if rtc.available() else rtc.load_error()
except ImportError as exc:  # pragma: no cover - depends on the platform
    _IMPORT_ERROR = exc


def available() -> bool:
    return _IMPORT_ERROR is None


class EmbreeEngine(Engine):
    """First hits from an Embree BVH, cast in coherent 8-ray packets; every kernel releases the GIL."""

    name = "embree"

    def __init__(self, scene, features=None, **kwargs) -> None:
        if _IMPORT_ERROR is not None:
            raise EngineError(f"the embree engine needs embreex ({_IMPORT_ERROR}); install it with `pip install embreex`")
        super().__init__(scene, features, **kwargs)
        self._rtc = rtc.TriangleScene(self.local_vertices, scene.faces)
        self._empty = self._rtc.n_faces == 0

    def close(self) -> None:
        super().close()
        self._rtc.release()
        self._empty = True

    def first_hit(self, origins: NDArray[np.float32], directions: NDArray[np.float32]) -> NDArray[np.int32]:
        out = np.full(len(directions), -1, np.int32)
        if self._empty or len(directions) == 0:
            return out
        o = np.broadcast_to(np.asarray(origins, np.float32), directions.shape)
        _packets.first_hits(self._rtc.handle, o, np.asarray(directions, np.float32), out, rtc.packet_buffer(),
                            _UNBOUNDED)
        return out

    def _chunk_caster(self, cam: Camera, R: NDArray, C: NDArray, max_rays: int):
        """Rays, packets and reduction fused in one compiled loop (:func:`.packets.cast_pixels`)."""
        buf = rtc.packet_buffer()
        pending = np.zeros((32 * rtc.LANES, 6))  # hits on faces with ties, counted 256 at a time
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
                                     pending)

        return cast

    def unoccluded_rays(self, origin32: NDArray[np.float32], directions: NDArray[np.float32],
                        tfar: NDArray[np.float32]) -> NDArray[np.bool_]:
        out = np.zeros(len(directions), np.bool_)
        if len(directions) == 0:
            return out
        if self._empty:
            out[:] = True
            return out
        origins = np.broadcast_to(np.asarray(origin32, np.float32), directions.shape)
        tfar = np.asarray(tfar, np.float32)
        starts = list(range(0, len(directions), max(4096, -(-len(directions) // self.threads))))
        if self._pool is None or len(starts) == 1:
            _packets.unoccluded(self._rtc.handle, origins, directions, tfar, out, rtc.packet_buffer())
            return out

        def part(s: int) -> None:
            e = min(s + (starts[1] - starts[0]), len(directions))
            _packets.unoccluded(self._rtc.handle, origins[s:e], directions[s:e], tfar[s:e], out[s:e],
                                rtc.packet_buffer())

        list(self._pool.map(part, starts))
        return out
