"""Visibility with trimesh's pure-numpy ray tracer: slow, independent of Embree.

It exists to cross-check the Embree engine on small scenes and as the plain baseline
of the benchmark; it is not meant for real plans.
"""

from __future__ import annotations

import threading

import numpy as np
from numpy.typing import NDArray

from ..errors import EngineError
from .base import Engine


class TrimeshEngine(Engine):
    """First hits from ``trimesh.ray.ray_triangle`` (numpy + an R-tree of triangles)."""

    name = "trimesh"
    BATCH_RAYS = 1024

    def __init__(self, scene, features=None, **kwargs) -> None:
        kwargs["threads"] = 1  # its caches are not thread-safe: one thread, no pool
        super().__init__(scene, features, **kwargs)
        try:
            import trimesh
            from trimesh.ray.ray_triangle import RayMeshIntersector
        except ImportError as exc:  # pragma: no cover
            raise EngineError(f"the trimesh engine needs trimesh and rtree ({exc})") from None
        self._empty = len(scene.faces) == 0
        if not self._empty:
            mesh = trimesh.Trimesh(self.local_vertices, scene.faces, process=False, validate=False)
            self._ray = RayMeshIntersector(mesh)
        self._lock = threading.Lock()

    def first_hit(self, origins: NDArray[np.float32], directions: NDArray[np.float32]) -> NDArray[np.int32]:
        if self._empty:
            return np.full(len(directions), -1, np.int32)
        o = np.ascontiguousarray(np.broadcast_to(origins, directions.shape), dtype=np.float64)
        d = directions.astype(np.float64)
        out = np.empty(len(d), np.int32)
        # ray_triangle materialises every (ray, candidate triangle) pair: small batches bound its memory
        step = self.BATCH_RAYS
        with self._lock:  # trimesh's caches are not thread-safe
            for i in range(0, len(d), step):
                out[i:i + step] = self._ray.intersects_first(o[i:i + step], d[i:i + step])
        return out
