"""What every visibility engine shares: one frame in, one FrameObservation out.

An engine only has to answer "which triangle does each ray hit first" (:meth:`first_hit`)
for a batch of rays; ray generation, distances, angles, the per-element reduction and the
feature visibility test are written once, here, so engines cannot drift apart.
"""

from __future__ import annotations

import os
import threading
from abc import ABC, abstractmethod
from concurrent.futures import ThreadPoolExecutor
from typing import Literal

import numpy as np
from numpy.typing import NDArray

from ..camera.models import Camera, EquirectangularCamera, PinholeCamera
from ..errors import EngineError
from ..model.scene import Scene
from ..observations.features import FeatureSet
from ..observations.table import FrameObservation
from . import kernels
from .featurecull import FeatureIndex, Occluders

EngineName = Literal["auto", "embree", "gl", "trimesh"]

D_MAX_M = 1000.0
OCCLUSION_TOLERANCE_M = 0.0005
# float32 rays round their hits: within this of the limit an occlusion query is not trusted (≫ a float32 ulp)
OCCLUSION_BAND_REL = 1e-6
OCCLUSION_BAND_M = 1e-6
DEFAULT_CHUNK_RAYS = 1 << 19  # ~512k rays: best Embree throughput per call on this class of CPU
CHUNKS_PER_FRAME = 64  # a frame is cut into this many chunks, taken by the threads as they free up
MIN_CHUNK_RAYS = 1 << 14  # but none smaller than this (each has its own per-element sums)
PIXEL_PRIMS_MAX = 1 << 22  # a pinhole frame of at most this many pixels keeps each one's triangle for its features


class Engine(ABC):
    """Turns (scene, frames) into observations, one frame at a time.

    scene: the scene at the capture date (every face belongs to an existing element).
    features: simulated features to test for visibility (or None).
    d_max: surfaces farther than this (metres) are not seen.
    threads: worker threads for the chunks of a frame.
    """

    name: str = "base"

    def __init__(self, scene: Scene, features: FeatureSet | None = None, *, d_max: float = D_MAX_M,
                 threads: int | None = None, chunk_rays: int = DEFAULT_CHUNK_RAYS) -> None:
        if not d_max > 0:
            raise EngineError(f"d_max must be positive, got {d_max}")
        self.scene = scene
        self.features = features
        self.d_max = float(d_max)
        self.threads = max(1, threads or min(32, os.cpu_count() or 1))
        self.chunk_rays = int(chunk_rays)
        self.n_elements = scene.n_elements
        # engines work in a frame centred on the model so float32 rays keep millimetres even for
        # georeferenced coordinates far from the origin: the centre of its box on a 0.5 m grid, which
        # depends on the geometry only (not on how a loader shares or repeats vertices)
        lo_hi = scene.vertices.min(axis=0) + scene.vertices.max(axis=0) if len(scene.vertices) else np.zeros(3)
        self.centre = np.round(lo_hi) / 2
        self.local_vertices = scene.vertices - self.centre
        normals = scene.face_normals()
        self._face_normal = np.ascontiguousarray(normals, dtype=np.float64)
        v0 = self.local_vertices[scene.faces[:, 0]] if len(scene.faces) else np.zeros((0, 3))
        self._face_offset = np.einsum("ij,ij->i", normals, v0)
        self._face_element = np.ascontiguousarray(scene.face_element, dtype=np.int32)
        # coincident surfaces: (tie_ptr, tie_elem, tie_edge), see kernels.tie_table
        self._ties = kernels.tie_table(scene.tie_pairs(), self.local_vertices, scene.faces, self._face_element)
        self._pool = ThreadPoolExecutor(self.threads) if self.threads > 1 else None
        self._feature_index: FeatureIndex | None = None
        self._index_lock = threading.Lock()

    # --------------------------------------------------------------- backend
    @abstractmethod
    def first_hit(self, origins: NDArray[np.float32], directions: NDArray[np.float32]) -> NDArray[np.int32]:
        """(n,) int32 index of the first triangle hit by each ray, −1 on a miss.

        origins: (n, 3) float32 in the engine's local frame (world − ``self.centre``;
        may be a broadcast view of one point); directions:
        (n, 3) float32 unit vectors. Must be safe to call from several threads.
        """

    def hit_distance(self, origins: NDArray[np.float32], directions: NDArray[np.float32]) -> NDArray[np.float64]:
        """(n,) distance to the first hit (inf on a miss), from the hit triangle's plane; local-frame origins."""
        t, _ = self._plane_distance(self.first_hit(origins, directions), origins, directions)
        return t

    def _plane_distance(self, prim: NDArray, origins: NDArray, directions: NDArray) -> tuple[NDArray, NDArray]:
        """(n,) distance along each ray to its hit triangle's plane (inf on a miss) and (n,) n·d (0 on a miss)."""
        hit = prim >= 0
        t = np.full(len(prim), np.inf)
        dn = np.zeros(len(prim))
        n = self._face_normal[prim[hit]]
        o = np.broadcast_to(origins, directions.shape)[hit].astype(np.float64)
        dn[hit] = np.einsum("ij,ij->i", n, directions[hit].astype(np.float64))
        t[hit] = (self._face_offset[prim[hit]] - np.einsum("ij,ij->i", n, o)) / dn[hit]
        return t, dn

    # ------------------------------------------------------------ ray queries
    @property
    def face_element(self) -> NDArray[np.int32]:
        """(F,) the element of each triangle, as the triangle ids :meth:`hits_from` returns index."""
        return self._face_element

    def hits_from(self, C_world: NDArray, directions: NDArray[np.float32], t_out: NDArray[np.float64]
                  ) -> NDArray[np.int32]:
        """The first hits of rays from the world point ``C_world`` along (n, 3) unit ``directions``: (n,) triangle
        ids (−1 on a miss), and into ``t_out`` (n,) the distance to the hit triangle's plane in float64 (inf on a
        miss or behind the point), as every engine measures it. Any thread may call it; with
        :meth:`pixel_directions` it is how other stages (validation, flight checks) cast rays."""
        origin = np.asarray(C_world, np.float64) - self.centre
        prim = self.first_hit(np.broadcast_to(origin.astype(np.float32), directions.shape), directions)
        kernels.plane_distances(prim, directions, origin, self._face_normal, self._face_offset, t_out)
        return prim

    def trace(self, C_world: NDArray, directions: NDArray[np.float32]
              ) -> tuple[NDArray[np.int32], NDArray[np.float64], NDArray[np.int32]]:
        """What rays from the world point ``C_world`` along (n, 3) unit float32 ``directions`` show, as
        :meth:`shaded_view` sees a pixel but for any rays (a distorted lens's, say): (n,) element ids (−1: nothing
        within d_max; on a coincident surface the smallest owner, METRICS.md §2), (n,) distances (inf where −1) and
        (n,) the triangle hit (−1 where nothing is)."""
        ids, t, _, prim = self._traced(np.asarray(C_world, dtype=np.float64) - self.centre,
                                       np.ascontiguousarray(directions, np.float32))
        return ids, t, prim

    def _traced(self, C: NDArray, dirs: NDArray[np.float32]
                ) -> tuple[NDArray[np.int32], NDArray[np.float64], NDArray[np.float64], NDArray[np.int32]]:
        """Rays from the local point ``C`` along ``dirs``: element ids (the ties rule applied), distances, |cos|
        with the hit triangle's normal (0 on a miss) and the triangles hit, each −1 / inf where nothing is."""
        origin = np.broadcast_to(C.astype(np.float32), dirs.shape)
        prim = self.first_hit(origin, dirs)
        t, dn = self._plane_distance(prim, C, dirs)
        hit = (prim >= 0) & (t <= self.d_max) & (t >= 0)
        ids = np.where(hit, self._face_element[np.maximum(prim, 0)], -1).astype(np.int32)
        kernels.smallest_owners(prim, t, dirs, C, self._face_element, *self._ties, ids)
        return ids, np.where(hit, t, np.inf), np.where(hit, np.abs(dn), 0.0), np.where(hit, prim, -1).astype(np.int32)

    @staticmethod
    def pixel_directions(cam: Camera, R: NDArray, p0: int, p1: int, out: NDArray[np.float32]) -> None:
        """Unit world directions of pixels p0..p1 (row-major) of ``cam`` into ``out``."""
        if isinstance(cam, EquirectangularCamera):
            kernels.equirect_directions(p0, p1, cam.width, cam.height, R, out)
        else:
            kernels.pinhole_directions(p0, p1, cam.width, cam.fx, cam.fy, cam.cx, cam.cy, R, out)

    def close(self) -> None:
        if self._pool is not None:
            self._pool.shutdown(wait=True)
            self._pool = None

    def __enter__(self) -> Engine:
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()

    # ------------------------------------------------------------ per frame
    def observe(self, camera: Camera, R_world_camera: NDArray, C_world: NDArray, scale: float = 1.0) -> FrameObservation:
        """Cast every pixel of ``camera`` at resolution scale ``scale`` and reduce to elements."""
        if not 0 < scale <= 1:
            raise EngineError(f"resolution scale must be in (0, 1], got {scale}")
        cam = camera.scaled(scale) if scale != 1 else camera
        R = np.ascontiguousarray(R_world_camera, dtype=np.float64)
        C_world = np.asarray(C_world, dtype=np.float64)
        C = C_world - self.centre
        n_px = cam.width * cam.height
        # chunks of at most chunk_rays, small enough that every worker gets several: the workers take the next
        # chunk as they finish one, so a part of the frame dense with geometry leaves no thread idle. Each chunk
        # has its own sums, added in the chunks' order: the same numbers whichever thread cast which chunk, and
        # whatever the number of threads (the chunks do not depend on it).
        size = max(MIN_CHUNK_RAYS, min(self.chunk_rays, -(-n_px // CHUNKS_PER_FRAME)))
        size = -(-size // 64) * 64  # whole 8-ray packets
        starts = list(range(0, n_px, size)) or [0]
        # the triangle each pixel hits: the feature test's proofs of occlusion, for free (:mod:`.featurecull`)
        keep_prims = (self.features is not None and len(self.features) > 0 and isinstance(cam, PinholeCamera)
                      and n_px <= PIXEL_PRIMS_MAX)
        prims = np.full(n_px, -1, np.int32) if keep_prims else None
        n_workers = min(self.threads, len(starts))
        queue = iter(starts)
        lock = threading.Lock()

        def next_chunk():
            while True:
                with lock:
                    p0 = next(queue, None)
                if p0 is None:
                    return
                yield p0

        def work(_=None):
            return self._cast_chunks(cam, R, C, next_chunk(), size, n_px, prims)

        if self._pool is None or n_workers == 1:
            done = work()
        else:
            done = [c for part in self._pool.map(work, range(n_workers)) for c in part]
        done.sort(key=lambda c: c[0])
        z = self.n_elements
        count, depth, angle = np.zeros(z, np.int64), np.zeros(z), np.zeros(z)
        for _, seen, c, d, a in done:  # each chunk's elements are distinct: plain fancy-index sums
            count[seen] += c
            depth[seen] += d
            angle[seen] += a
        seen = np.flatnonzero(count).astype(np.int32)
        c = count[seen]
        return FrameObservation(
            element=seen,
            count=c.astype(np.int64),
            depth_mean=depth[seen] / c,
            angle_mean=angle[seen] / c,
            features=self.visible_features(camera, R, C_world, pixels=None if prims is None else (
                prims.reshape(cam.height, cam.width), cam.width / camera.width, cam.height / camera.height)),
            pixel_scale=(camera.width * camera.height) / n_px,
            sampling_focal_px=camera.sampling_focal_px,
        )

    def _cast_chunks(self, cam: Camera, R: NDArray, C: NDArray, starts, size: int, n_px: int,
                     prims: NDArray[np.int32] | None = None):
        """[(p0, elements, their pixels, distance sums, angle sums)] of the chunks of ``size`` pixels starting at
        ``starts``: each chunk's sums kept apart, over the elements it saw. prims: (n_px,) to receive the triangle
        each pixel hits (−1 where none), or None."""
        z = self.n_elements
        count, depth, angle = np.zeros(z, np.int64), np.zeros(z), np.zeros(z)
        cast = self._chunk_caster(cam, R, C, min(max(size, 1), max(n_px, 1)), prims)
        out = []
        for p0 in starts:
            cast(p0, min(p0 + size, n_px), count, depth, angle)
            seen = np.flatnonzero(count)
            out.append((p0, seen, count[seen], depth[seen], angle[seen]))
            count[seen] = 0
            depth[seen] = 0.0
            angle[seen] = 0.0
        return out

    def _chunk_caster(self, cam: Camera, R: NDArray, C: NDArray, max_rays: int, prims: NDArray | None = None):
        """``cast(p0, p1, count, depth, angle)``: add pixels p0..p1 of one frame to the sums, and their triangles
        to ``prims`` when given. This one makes the rays, asks :meth:`first_hit` and reduces; an engine may fuse the
        three (the Embree engine does)."""
        buf = np.empty((max_rays, 3), np.float32)
        memo = kernels.angle_memo()
        C32 = C.astype(np.float32)
        mode = kernels.MODE_EQUIRECT if isinstance(cam, EquirectangularCamera) else kernels.MODE_PINHOLE

        def cast(p0: int, p1: int, count: NDArray, depth: NDArray, angle: NDArray) -> None:
            dirs = buf[: p1 - p0]
            self.pixel_directions(cam, R, p0, p1, dirs)
            prim = self.first_hit(np.broadcast_to(C32, dirs.shape), dirs)
            if prims is not None:
                prims[p0:p1] = prim
            kernels.accumulate_hits(prim, dirs, C, R, mode, self._face_normal, self._face_offset, self._face_element,
                                    *self._ties, self.d_max, count, depth, angle, memo)

        return cast

    def element_map(self, camera: Camera, R_world_camera: NDArray, C_world: NDArray, scale: float = 1.0
                    ) -> tuple[NDArray[np.int32], NDArray[np.float64]]:
        """(H, W) int32 element id per pixel (−1: nothing within d_max) and (H, W) distance in metres.

        On a coincident surface (METRICS.md §2) the pixel shows the smallest of the elements that own it.

        The simulated view of one frame; it holds a whole image, so use it for pictures and
        checks, not for evaluation (:meth:`observe` never keeps more than a chunk).
        """
        ids, t, _ = self.shaded_view(camera, R_world_camera, C_world, scale)
        return ids, t

    def shaded_view(self, camera: Camera, R_world_camera: NDArray, C_world: NDArray, scale: float = 1.0
                    ) -> tuple[NDArray[np.int32], NDArray[np.float64], NDArray[np.float64]]:
        """:meth:`element_map` plus (H, W) |cos| between each ray and its hit triangle's normal (0 on a miss)."""
        cam = camera.scaled(scale) if scale != 1 else camera
        R = np.ascontiguousarray(R_world_camera, dtype=np.float64)
        C = np.asarray(C_world, dtype=np.float64) - self.centre
        n_px = cam.width * cam.height
        dirs = np.empty((n_px, 3), np.float32)
        self.pixel_directions(cam, R, 0, n_px, dirs)
        ids, t, cos, _ = self._traced(C, dirs)
        shape = (cam.height, cam.width)
        return ids.reshape(shape), t.reshape(shape), cos.reshape(shape)

    # -------------------------------------------------------------- features
    @property
    def feature_index(self) -> FeatureIndex | None:
        """The features in frustum-culling blocks, built on first use (once per engine)."""
        if self.features is None or len(self.features) == 0:
            return None
        if self._feature_index is None:
            with self._index_lock:
                if self._feature_index is None:
                    self._feature_index = FeatureIndex(self.features.points, self.features.normals)
        return self._feature_index

    @property
    def occluders(self) -> Occluders:
        """This engine's triangles for the feature test's proofs of occlusion (:mod:`.featurecull`)."""
        return Occluders(self.first_hit, self.local_vertices, self.scene.faces, self.centre, self._big_hit())

    def _big_hit(self):
        """first_hit among the scene's big triangles only (:func:`.featurecull.big_triangles`), or None where the
        engine has no second BVH to cast them in."""
        return None

    def visible_features(self, camera: Camera, R_world_camera: NDArray, C_world: NDArray, *,
                         pixels: tuple[NDArray[np.int32], float, float] | None = None) -> NDArray[np.int32]:
        """(q,) int32 ascending indices of the features observed from this pose (METRICS.md §5.2).

        Observed iff it projects inside the image, lies within d_max, faces the camera,
        and nothing is hit along the ray from the centre closer than its distance − 0.5 mm.
        Only the features of blocks in the view frustum are tested, and only those that no
        triangle hit proves hidden cast their own ray (:mod:`.featurecull`); the result
        equals :meth:`visible_features_reference`. pixels: the triangles the frame's pixels
        just hit (:meth:`observe`), to prove with (see :meth:`FeatureIndex.candidates`).
        """
        index = self.feature_index
        if index is None:
            return np.zeros(0, np.int32)
        cover = self.occluders
        if isinstance(camera, PinholeCamera):
            cand, dirs, dist = index.candidates(C_world, R_world_camera, camera.width, camera.height, camera.fx,
                                                camera.fy, camera.cx, camera.cy, self.d_max, self._pool, self.threads,
                                                cover, pixels)
        else:
            cand, dirs, dist = index.candidates(C_world, None, 0, 0, 1.0, 1.0, 0.0, 0.0, self.d_max, cover=cover)
        if len(cand) == 0:
            return cand
        origin = (np.asarray(C_world, np.float64) - self.centre).astype(np.float32)
        return np.sort(cand[self._seen_from(origin, dirs, dist)])

    def _seen_from(self, origin32: NDArray[np.float32], dirs: NDArray[np.float32], dist: NDArray) -> NDArray[np.bool_]:
        """(k,) whether the first hit along each ray lies no nearer than its feature's distance − 0.5 mm, decided as
        :meth:`visible_features_reference` decides it: by occlusion queries (cheaper than first hits) up to just
        before and just after that limit, and, for the rare rays whose first hit falls between the two (within float32
        rounding of the limit), by the first hit's distance itself."""
        limit = dist - OCCLUSION_TOLERANCE_M
        band = OCCLUSION_BAND_REL * dist + OCCLUSION_BAND_M
        seen = self.unoccluded_rays(origin32, dirs, limit - band)
        maybe = np.flatnonzero(seen)
        # nothing before limit − band, so only the band is left to search; from limit − 4·band, since a query's
        # box tests round at either end of its stretch and may miss a hit right there (seen with Embree)
        unsure = maybe[~self.unoccluded_rays(origin32, dirs[maybe], (limit + band)[maybe], (limit - 4 * band)[maybe])]
        if len(unsure):
            t = self.hit_distance(np.broadcast_to(origin32, (len(unsure), 3)), dirs[unsure])
            seen[unsure] = t >= limit[unsure]
        return seen

    def unoccluded_rays(self, origin32: NDArray[np.float32], directions: NDArray[np.float32],
                        tfar: NDArray[np.float64], tnear: NDArray | None = None) -> NDArray[np.bool_]:
        """(k,) True where nothing is hit along each ray from ``origin32`` (local frame) closer than ``tfar``.

        tnear: where the caller already knows nothing is hit before it (an earlier query), so an engine with a range
        query searches only from there (the answer is the same)."""
        t = self.hit_distance(np.broadcast_to(origin32, directions.shape), directions)
        return t >= tfar

    def visible_features_reference(self, camera: Camera, R_world_camera: NDArray, C_world: NDArray, *,
                                   pixels: object = None) -> NDArray[np.int32]:
        """The brute-force form of :meth:`visible_features`: every feature tested, one first-hit ray per candidate.

        Kept as the reference the indexed path is tested against (it takes, and ignores, the same ``pixels``, so it
        can stand in for it).
        """
        fs = self.features
        if fs is None or len(fs) == 0:
            return np.zeros(0, np.int32)
        rel = fs.points - C_world
        dist = np.linalg.norm(rel, axis=1)
        # n·r summed left to right as the indexed test sums it: where the sight line lies in the feature's surface
        # (n·r rounds to either side of 0), both decide alike
        n = fs.normals
        ok = ((n[:, 0] * rel[:, 0] + n[:, 1] * rel[:, 1]) + n[:, 2] * rel[:, 2] < 0) & (dist <= self.d_max) & (dist > 0)
        if isinstance(camera, PinholeCamera):
            cam = rel @ R_world_camera  # camera-frame coordinates, (N, 3)
            zc = cam[:, 2]
            with np.errstate(divide="ignore", invalid="ignore"):
                x = camera.fx * cam[:, 0] / zc + camera.cx
                y = camera.fy * cam[:, 1] / zc + camera.cy
            ok &= (zc > 0) & (x >= 0) & (x < camera.width) & (y >= 0) & (y < camera.height)
        idx = np.flatnonzero(ok)
        if len(idx) == 0:
            return np.zeros(0, np.int32)
        d = (rel[idx] / dist[idx, None]).astype(np.float32)
        origin = np.broadcast_to((C_world - self.centre).astype(np.float32), d.shape)
        t = self.hit_distance(origin, d)
        return idx[t >= dist[idx] - OCCLUSION_TOLERANCE_M].astype(np.int32)
