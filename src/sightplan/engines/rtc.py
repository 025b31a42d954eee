"""A thin binding to the Embree 4 library that the ``embreex`` wheel ships.

embreex casts one ray at a time (``rtcIntersect1``) behind a Python call. This module
opens the same shared library with :mod:`ctypes` and exposes the packet queries
(``rtcIntersect8``, ``rtcOccluded8``) as ctypes function objects that numba kernels
call directly, without the GIL: ray generation, the cast and the reduction then run in
one compiled loop per worker thread (:mod:`sightplan.engines.packets`).

Pointers cross into numba as unsigned 64-bit addresses (``array.ctypes.data``), which is
the same register on every 64-bit ABI Embree supports.

Layouts (``rtcore_ray.h``, packets of 8, 32-byte aligned, structure-of-arrays):
``RTCRay8`` is 12 blocks of 8 lanes: org x, y, z, tnear, dir x, y, z, time, tfar, mask,
id, flags; ``RTCHit8`` follows it with Ng x, y, z, u, v, primID, geomID, then the
instance ids. Only primID and geomID are read back.
"""

from __future__ import annotations

import ctypes
import glob
import os
import threading

import numpy as np
from numpy.typing import NDArray

from ..errors import EngineError

LANES = 8
# float offsets (in 4-byte words) of the blocks of an RTCRayHit8
ORG_X, ORG_Y, ORG_Z, TNEAR = 0, 8, 16, 24
DIR_X, DIR_Y, DIR_Z, TIME = 32, 40, 48, 56
TFAR, MASK, RAY_ID, FLAGS = 64, 72, 80, 88
PRIM_ID, GEOM_ID = 96 + 5 * 8, 96 + 6 * 8
#: words reserved per packet: the ray, the hit and room for instance ids of any Embree 4 build
PACKET_WORDS = 512
#: word offset of the valid mask (after the packet, 32-byte aligned)
VALID = PACKET_WORDS
#: words of one packet buffer, including 64 bytes of slack for alignment
BUFFER_WORDS = PACKET_WORDS + LANES + 16
INVALID_ID = 0xFFFFFFFF

# RTCGeometryType, RTCBufferType, RTCFormat, RTCBuildQuality, RTCSceneFlags (rtcore_*.h)
_GEOMETRY_TRIANGLE = 0
_BUFFER_INDEX, _BUFFER_VERTEX = 0, 1
_FORMAT_UINT3, _FORMAT_FLOAT3 = 0x5003, 0x9003
BUILD_QUALITY_MEDIUM = 1
SCENE_FLAG_NONE = 0

_P = ctypes.c_void_p
_U64 = ctypes.c_uint64


def _library_path() -> str:
    """The libembree4 that embreex ships (its wheel keeps it in ``embreex.libs``)."""
    import embreex  # the package that installs the library

    here = os.path.dirname(os.path.abspath(embreex.__file__))
    candidates = []
    for folder in (os.path.join(here, os.pardir, "embreex.libs"), here):
        candidates += sorted(glob.glob(os.path.join(folder, "libembree4*.so*")))
        candidates += sorted(glob.glob(os.path.join(folder, "libembree4*.dylib")))
        candidates += sorted(glob.glob(os.path.join(folder, "embree4*.dll")))
    if not candidates:
        raise OSError(f"no libembree4 beside embreex in {here}")
    return candidates[0]


def _open():
    lib = ctypes.CDLL(_library_path())
    for name, restype, argtypes in (
        ("rtcNewDevice", _P, [ctypes.c_char_p]),
        ("rtcReleaseDevice", None, [_P]),
        ("rtcGetDeviceError", ctypes.c_int, [_P]),
        ("rtcNewScene", _P, [_P]),
        ("rtcSetSceneFlags", None, [_P, ctypes.c_int]),
        ("rtcSetSceneBuildQuality", None, [_P, ctypes.c_int]),
        ("rtcCommitScene", None, [_P]),
        ("rtcReleaseScene", None, [_P]),
        ("rtcNewGeometry", _P, [_P, ctypes.c_int]),
        ("rtcSetSharedGeometryBuffer", None,
         [_P, ctypes.c_int, ctypes.c_uint, ctypes.c_int, _P, ctypes.c_size_t, ctypes.c_size_t, ctypes.c_size_t]),
        ("rtcCommitGeometry", None, [_P]),
        ("rtcAttachGeometry", ctypes.c_uint, [_P, _P]),
        ("rtcReleaseGeometry", None, [_P]),
    ):
        fn = getattr(lib, name)
        fn.restype, fn.argtypes = restype, argtypes
    # the queries, typed with integer addresses so numba kernels can call them
    intersect8 = ctypes.CFUNCTYPE(None, _U64, _U64, _U64, _U64)(("rtcIntersect8", lib))
    occluded8 = ctypes.CFUNCTYPE(None, _U64, _U64, _U64, _U64)(("rtcOccluded8", lib))
    return lib, intersect8, occluded8


try:
    _lib, intersect8, occluded8 = _open()
    _LOAD_ERROR: Exception | None = None
except (OSError, AttributeError, ImportError) as exc:  # pragma: no cover - depends on the platform
    _lib = intersect8 = occluded8 = None
    _LOAD_ERROR = exc

_device = None
_device_lock = threading.Lock()


def available() -> bool:
    return _LOAD_ERROR is None


def load_error() -> Exception | None:
    """Why the Embree library could not be loaded (None when it was)."""
    return _LOAD_ERROR


def _shared_device():
    """One Embree device per process (it owns the thread pool that builds BVHs)."""
    global _device
    with _device_lock:
        if _device is None:
            _device = _lib.rtcNewDevice(None)
            if not _device:
                raise EngineError("Embree could not create a device (unsupported CPU?)")
        return _device


class TriangleScene:
    """An Embree scene of one triangle mesh; ``handle`` is the RTCScene address for the kernels.

    vertices: (n, 3) coordinates (converted to float32; keep them near the origin);
    faces: (m, 3) vertex indices. The arrays are copied and kept alive as long as the scene.
    Built with Embree's defaults (medium-quality BVH, no robust flag), as embreex builds.
    """

    def __init__(self, vertices: NDArray, faces: NDArray) -> None:
        if _LOAD_ERROR is not None:
            raise EngineError(f"the Embree library could not be opened: {_LOAD_ERROR}")
        self._device = _shared_device()
        # Embree reads vertices with 16-byte loads: one padding vertex after the last
        self._vertices = np.zeros((len(vertices) + 1, 3), np.float32)
        self._vertices[:-1] = vertices
        self._faces = np.ascontiguousarray(faces, dtype=np.uint32)
        self.n_faces = len(self._faces)
        self.handle = 0
        if self.n_faces == 0:
            return
        scene = _lib.rtcNewScene(self._device)
        _lib.rtcSetSceneFlags(scene, SCENE_FLAG_NONE)
        _lib.rtcSetSceneBuildQuality(scene, BUILD_QUALITY_MEDIUM)
        geom = _lib.rtcNewGeometry(self._device, _GEOMETRY_TRIANGLE)
        _lib.rtcSetSharedGeometryBuffer(geom, _BUFFER_VERTEX, 0, _FORMAT_FLOAT3, self._vertices.ctypes.data, 0, 12,
                                        len(vertices))
        _lib.rtcSetSharedGeometryBuffer(geom, _BUFFER_INDEX, 0, _FORMAT_UINT3, self._faces.ctypes.data, 0, 12,
                                        self.n_faces)
        _lib.rtcCommitGeometry(geom)
        _lib.rtcAttachGeometry(scene, geom)
        _lib.rtcReleaseGeometry(geom)
        _lib.rtcCommitScene(scene)
        error = _lib.rtcGetDeviceError(self._device)
        if error != 0:
            _lib.rtcReleaseScene(scene)
            hint = " (out of memory)" if error == 3 else ""
            raise EngineError(f"Embree could not build the scene's BVH: error {error}{hint}")
        self.handle = int(scene)

    def release(self) -> None:
        if self.handle:
            _lib.rtcReleaseScene(ctypes.c_void_p(self.handle))
            self.handle = 0

    def __del__(self) -> None:  # pragma: no cover - timing depends on the garbage collector
        try:
            self.release()
        except Exception:
            pass


def packet_buffer() -> NDArray[np.float32]:
    """A zeroed buffer for one packet (ray, hit and valid mask); kernels align it to 32 bytes."""
    return np.zeros(BUFFER_WORDS, np.float32)
