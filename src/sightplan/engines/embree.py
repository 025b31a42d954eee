"""Visibility with Intel Embree (through ``embreex``), the default CPU engine."""

from __future__ import annotations

import numpy as np
from numpy.typing import NDArray

from ..errors import EngineError
from .base import Engine

try:  # keep the ImportError until this engine is asked for
    from embreex import rtcore_scene as _rtcs
    from embreex.mesh_construction import TriangleMesh as _TriangleMesh

    _IMPORT_ERROR: ImportError | None = None
except ImportError as exc:  # pragma: no cover - depends on the platform
    _IMPORT_ERROR = exc


def available() -> bool:
    return _IMPORT_ERROR is None


class EmbreeEngine(Engine):
    """First hits from an Embree BVH; ``run`` releases the GIL, so chunks cast in parallel."""

    name = "embree"

    def __init__(self, scene, features=None, **kwargs) -> None:
        if _IMPORT_ERROR is not None:
            raise EngineError(f"the embree engine needs embreex ({_IMPORT_ERROR}); install it with `pip install embreex`")
        super().__init__(scene, features, **kwargs)
        self._scene = _rtcs.EmbreeScene()
        if len(scene.faces):
            _TriangleMesh(self._scene, self.local_vertices.astype(np.float32), scene.faces.astype(np.int32))
        self._empty = len(scene.faces) == 0
        if not self._empty:  # commit the BVH now, once, rather than lazily from several threads
            self.first_hit(np.zeros((1, 3), np.float32), np.array([[0, 0, 1]], np.float32))

    def first_hit(self, origins: NDArray[np.float32], directions: NDArray[np.float32]) -> NDArray[np.int32]:
        if self._empty:
            return np.full(len(directions), -1, np.int32)
        return np.asarray(self._scene.run(origins, directions, query="INTERSECT"), dtype=np.int32)
