"""Γ and Ψ cast along the rays of one frame, chunk by chunk, reduced to per-element sums (on the engines' public
ray queries)."""

from __future__ import annotations

from concurrent.futures import ThreadPoolExecutor

import numba as nb
import numpy as np
from numpy.typing import NDArray

from ..camera.models import Camera
from ..engines.base import DEFAULT_CHUNK_RAYS, Engine
from .splat import splat_distances

_SAMPLES_PER_CHUNK = 512

# =========================================================================== casting
class FrameCaster:
    """Γ and Ψ along the rays of one frame, chunk by chunk, reduced to per-element sums."""

    def __init__(self, gamma: Engine, psi_engine: Engine | None, cloud: NDArray | None, spacing: float,
                 is_target: NDArray[np.bool_], lam: float, threads: int) -> None:
        self.gamma = gamma
        self.psi = psi_engine
        self.cloud = cloud
        self.spacing = spacing
        self.is_target = is_target
        self.lam = lam
        self.threads = threads
        self.z = gamma.n_elements
        self._pool = ThreadPoolExecutor(threads) if threads > 1 else None

    def close(self) -> None:
        if self._pool is not None:
            self._pool.shutdown(wait=True)

    def frame(self, camera: Camera, R_world_camera: NDArray, C_world: NDArray, scale: float) -> list:
        cam = camera.scaled(scale) if scale != 1 else camera
        R = np.ascontiguousarray(R_world_camera, np.float64)
        C = np.asarray(C_world, np.float64)
        n_px = cam.width * cam.height
        psi_img = None
        if self.cloud is not None:
            psi_img = splat_distances(self.cloud, cam, R, C, self.spacing).reshape(-1)
        chunk = int(min(DEFAULT_CHUNK_RAYS, max(1 << 16, -(-n_px // self.threads))))
        starts = list(range(0, n_px, chunk))
        n_workers = min(self.threads, len(starts))
        groups = [starts[j::n_workers] for j in range(n_workers)]

        def work(g: list[int]) -> list:
            return self._chunks(cam, R, C, g, n_px, chunk, psi_img)

        if self._pool is None or n_workers == 1:
            return [work(g) for g in groups]
        return list(self._pool.map(work, groups))

    def _chunks(self, cam: Camera, R: NDArray, C: NDArray, starts: list[int], n_px: int, chunk: int,
                psi_img: NDArray | None) -> list:
        z = self.z
        back = np.zeros(z, np.int64)
        complete = np.zeros(z, np.int64)
        both_n = np.zeros(z, np.int64)
        diff_sum = np.zeros(z, np.float64)
        stats = np.zeros(3, np.int64)  # pixels on the model, pixels where both are hit, of those farther apart than λ
        diffs, ratios = [], []
        size = min(chunk, n_px)
        buf = np.empty((size, 3), np.float32)
        tg = np.empty(size, np.float64)
        dp = np.empty(size, np.float64)
        samp_d = np.empty(_SAMPLES_PER_CHUNK + 1, np.float64)
        samp_r = np.empty(_SAMPLES_PER_CHUNK + 1, np.float64)
        g = self.gamma
        for p0 in starts:
            p1 = min(p0 + chunk, n_px)
            n = p1 - p0
            dirs = buf[:n]
            Engine.pixel_directions(cam, R, p0, p1, dirs)
            prim = g.hits_from(C, dirs, tg[:n])
            if psi_img is not None:
                dp[:n] = psi_img[p0:p1]
            else:
                self.psi.hits_from(C, dirs, dp[:n])
            k = _accumulate(prim, tg[:n], dp[:n], g.face_element, self.is_target, g.d_max, self.lam, back, complete,
                            both_n, diff_sum, stats, samp_d, samp_r, max(1, n // _SAMPLES_PER_CHUNK))
            if k:
                diffs.append(samp_d[:k].copy())
                ratios.append(samp_r[:k].copy())
        return [back, complete, both_n, diff_sum, int(stats[0]), int(stats[1]), int(stats[2]), diffs, ratios]

@nb.njit(cache=True, nogil=True)
def _accumulate(prim, tg, dp, face_element, is_target, d_max, lam, back, complete, both_n, diff_sum, stats,
                samp_d, samp_r, every):  # pragma: no cover - compiled
    """Per-element sums of one chunk (see :class:`FrameCaster`); returns how many (|dΓ − dΨ|, dΨ/dΓ) samples it kept."""
    k = 0
    seen = 0
    for i in range(len(prim)):
        if prim[i] < 0:
            continue
        t = tg[i]
        if not (t <= d_max):  # also drops inf
            continue
        e = face_element[prim[i]]
        target = is_target[e]
        stats[0] += 1
        if target:
            back[e] += 1
        d = dp[i]
        if not np.isfinite(d):
            continue
        diff = abs(t - d)
        stats[1] += 1
        if diff > lam:
            stats[2] += 1
        if target:
            both_n[e] += 1
            diff_sum[e] += diff
            if diff <= lam:
                complete[e] += 1
        if seen % every == 0 and k < len(samp_d):
            samp_d[k] = diff
            samp_r[k] = d / max(t, 1e-12)
            k += 1
        seen += 1
    return k
