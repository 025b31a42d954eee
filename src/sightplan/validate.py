"""Validation of a plan against a reality model Ψ registered to the model Γ (METRICS.md §7).

Conventions: λ = 1.2·e with e the registration error (m). Every frame is cast at the
settings' resolution scale s, pixel-centre rays as in :mod:`sightplan.engines`. Per pixel p,
Γ gives the element I_p and d_p(Γ), the distance from the camera centre to the first hit
within D_max; Ψ gives d_p(Ψ) along the same ray at any distance (so a reality in another
unit still shows as one); d_p(Ψ) is undefined where Ψ is not hit. ω_p = VR_{I_p} (0 for
occluder-only elements), VR from an evaluation of the plan on Γ.

- A = Σ ω_p |d_p(Γ) − d_p(Ψ)| / Σ ω_p over pixels where both are defined; None when Σ ω_p = 0.
  A_i = mean |d_p(Γ) − d_p(Ψ)| over those pixels of element i (its weights are all equal).
- Pixel p is complete iff d_p(Ψ) is defined and |d_p(Γ) − d_p(Ψ)| ≤ λ.
  c_i = complete / back-projected pixels of i over all frames (0 if never back-projected);
  Ce = mean c_i over the z targets; Cv = mean c_i over the visible ones (VR_i > 0).
- Ct = recall: share of points sampled uniformly (probability ∝ area, seeded) on the surfaces
  of Γ's present target elements that have Ψ within λ, with n = clip(round(area · 100 m⁻²),
  20 000, 1 000 000) points (``ct_density_per_m2``). Distances to a mesh Ψ are exact
  point–triangle distances (:func:`points_near_mesh`); to a point cloud, the nearest point.
- Precision: share of Ψ's points (a mesh Ψ: points sampled on it with the same rule) inside
  Γ's bounding box grown by λ (the evaluated region, as the crop of Tanks and Temples) that
  lie within λ of Γ's surfaces (targets and occluders: a reconstructed occluder is no error).
  F = 2PR / (P + R).

A point cloud Ψ is splatted into each frame: every point projects to a pixel position
(pinhole: perspective projection, depth z along the optical axis; equirectangular: by
direction, depth = distance) and covers the pixels whose centres lie within its footprint,
a disc of radius r_px = max(1, s_pt / (depth · angular pixel size)) pixels, at most
:data:`MAX_SPLAT_PX` (pinhole: angular size 1/fx across, 1/fy down; equirectangular: π/H
down and 2π/W·cos(latitude) across). Each pixel keeps the nearest depth, converted to the
distance along the pixel's own ray (pinhole: z·‖((u+½−cx)/fx, (v+½−cy)/fy, 1)‖). The point
spacing s_pt = r₈ · √(π/8), r₈ the median distance to the 8th neighbour (1/√density for a
uniform sampling), unless given. A disc of that radius closes the gaps of a regular scan and
of all but ~4 % of a random sampling, so a sparse cloud still fills its surfaces (c_i stays
high) while Ct, which needs a point within λ, drops once s_pt approaches λ. A splat keeps its
point's depth over its footprint (a pinhole: a plane parallel to the image; equirectangular: a
sphere about the camera), so on a surface inclined by θ to that, d_p(Ψ) errs by up to about
(footprint radius in metres)·tan θ, and taking the nearest biases it toward the camera.
"""

from __future__ import annotations

import csv
import hashlib
import math
import os
import time
from collections.abc import Callable, Iterable, Mapping
from concurrent.futures import ThreadPoolExecutor
from dataclasses import dataclass, field, replace
from pathlib import Path

import numba as nb
import numpy as np
from numpy.typing import ArrayLike, NDArray

from .camera.models import Camera, EquirectangularCamera
from .engines import make_engine
from .engines.base import DEFAULT_CHUNK_RAYS, Engine
from .engines.registry import ray_engine_name
from .errors import ModelError, SightplanError
from .evaluate import Evaluation, EvaluationSettings, evaluate
from .geometry.distance import point_triangle_sq
from .model.pointcloud import PointCloud, check_points
from .model.scene import Scene
from .plan.types import Plan

LAMBDA_PER_E = 1.2
CT_DENSITY_PER_M2 = 100.0
CT_MIN_SAMPLES = 20_000
CT_MAX_SAMPLES = 1_000_000
MAX_SPLAT_PX = 32
SPACING_NEIGHBOUR = 8
#: Far-pixel share above which Ψ looks misregistered or in another unit.
FAR_SHARE_WARNING = 0.5
#: Share of Γ's bounding box that Ψ's box must cover before the overlap warning is silent.
OVERLAP_WARNING = 0.5
_MAX_PIECES = 1_000_000
_PIECE_LIMIT = 4_000_000
_QUERY_BATCH = 100_000
_SAMPLES_PER_CHUNK = 512
_UNITS = ((1000.0, "Ψ in millimetres?"), (100.0, "Ψ in centimetres?"), (39.37, "Ψ in inches?"), (3.281, "Ψ in feet?"),
          (0.001, "Γ in millimetres, or Ψ in kilometres?"), (0.01, "Γ in centimetres?"), (0.0254, "Γ in inches?"),
          (0.3048, "Γ in feet?"))

ProgressCallback = Callable[[int, int], None]
Reality = Scene | PointCloud | NDArray


# =========================================================================== result
@dataclass(frozen=True)
class Validation:
    """Plan-level quality of a reconstruction, per element and overall (METRICS.md §7).

    Plan numbers are None where undefined. Per-element arrays have shape (z_all,), indexed
    like the scene's element table: ``c`` (0 where never back-projected), ``A_i`` (metres, NaN
    where no pixel has both distances), ``pixels`` back-projected pixels as cast (at scale s),
    ``pixels_complete``, ``pixels_both``, ``VR``, ``visible``, ``is_target``. ``counts``:
    pixel and sample totals; ``parameters``: what determined the numbers.
    """

    registration_error_m: float
    lam: float
    A: float | None
    Ce: float | None
    Cv: float | None
    Ct: float | None
    precision: float | None
    recall: float | None
    F: float | None
    z: int
    n_visible: int
    n_frames: int
    reality_kind: str
    c: NDArray[np.float64]
    A_i: NDArray[np.float64]
    pixels: NDArray[np.int64]
    pixels_complete: NDArray[np.int64]
    pixels_both: NDArray[np.int64]
    VR: NDArray[np.int64]
    visible: NDArray[np.bool_]
    is_target: NDArray[np.bool_]
    global_id: NDArray[np.object_]
    name: NDArray[np.object_]
    ifc_class: NDArray[np.object_]
    counts: dict
    parameters: dict
    warnings: tuple[str, ...] = ()
    timings: dict = field(default_factory=dict)

    def plan_metrics(self) -> dict:
        return {"A_m": self.A, "Ce": self.Ce, "Cv": self.Cv, "Ct": self.Ct, "precision": self.precision,
                "recall": self.recall, "F": self.F, "z": self.z, "visible": self.n_visible, "frames": self.n_frames}

    def element_rows(self) -> list[dict]:
        """One row per target element, in element order: global_id, name, ifc_class, c_i, A_i (m), pixels."""
        return [{"global_id": str(self.global_id[i]), "name": str(self.name[i]), "ifc_class": str(self.ifc_class[i]),
                 "c_i": float(self.c[i]), "A_i": _num(self.A_i[i]), "pixels": int(self.pixels[i])}
                for i in np.flatnonzero(self.is_target)]

    def to_dict(self) -> dict:
        """JSON-ready: null for undefined numbers, never NaN."""
        return {"format": "sightplan-validation", "version": 1, "metrics": self.plan_metrics(),
                "registration_error_m": self.registration_error_m, "lambda_m": self.lam, "reality": self.reality_kind,
                "parameters": dict(self.parameters), "counts": dict(self.counts), "warnings": list(self.warnings),
                "timings": dict(self.timings), "elements": self.element_rows()}

    def write_csv(self, path: str | Path) -> Path:
        """The element rows as CSV (empty cell for an undefined A_i)."""
        path = Path(path)
        rows = self.element_rows()
        with open(path, "w", newline="", encoding="utf-8") as fh:
            w = csv.DictWriter(fh, fieldnames=["global_id", "name", "ifc_class", "c_i", "A_i", "pixels"])
            w.writeheader()
            for r in rows:
                w.writerow({k: "" if v is None else (f"{v:.6g}" if isinstance(v, float) else v) for k, v in r.items()})
        return path


def _num(x: float) -> float | None:
    x = float(x)
    return x if math.isfinite(x) else None


# =========================================================================== geometry kernels
@nb.njit(cache=True, nogil=True)
def _any_within(points, idx, tri, r2):  # pragma: no cover - compiled
    """(n,) whether any candidate triangle idx[i, :] (index ≥ len(tri): none) lies within √r2 of points[i]."""
    n, k = idx.shape
    m = tri.shape[0]
    out = np.zeros(n, np.bool_)
    for i in range(n):
        for j in range(k):
            f = idx[i, j]
            if f >= m:
                break
            if point_triangle_sq(points[i, 0], points[i, 1], points[i, 2], tri[f]) <= r2:
                out[i] = True
                break
    return out


def _bisect(tri: NDArray[np.float64], max_edge: float, limit: int | None = None) -> NDArray[np.float64] | None:
    """Triangles (m, 3, 3) split at the midpoint of their longest edge until no edge exceeds ``max_edge``.

    The pieces cover exactly the same surface. None once there would be more than ``limit`` pieces.
    """
    done = []
    n_done = 0
    while len(tri):
        e = np.stack([np.linalg.norm(tri[:, 1] - tri[:, 0], axis=1), np.linalg.norm(tri[:, 2] - tri[:, 1], axis=1),
                      np.linalg.norm(tri[:, 0] - tri[:, 2], axis=1)], axis=1)
        longest = np.argmax(e, axis=1)
        split = e[np.arange(len(tri)), longest] > max_edge
        done.append(tri[~split])
        n_done += len(done[-1])
        s, k = tri[split], longest[split]
        if len(s) == 0:
            break
        if limit is not None and n_done + 2 * len(s) > limit:
            return None
        order = (np.arange(3)[None, :] + k[:, None]) % 3  # rotate so that the longest edge is v0–v1
        s = np.take_along_axis(s, order[:, :, None], axis=1)
        a, b, c = s[:, 0], s[:, 1], s[:, 2]
        m = 0.5 * (a + b)
        tri = np.concatenate([np.stack([a, m, c], axis=1), np.stack([m, b, c], axis=1)])
    return np.concatenate(done) if done else np.zeros((0, 3, 3))


def points_near_mesh(points: ArrayLike, vertices: ArrayLike, faces: ArrayLike, radius: float) -> NDArray[np.bool_]:
    """(n,) whether each point lies within ``radius`` (m) of the triangle mesh — exact point–triangle distances.

    Triangles are bisected until no edge exceeds L = max(4·radius, √(4·area/10⁶)) (L doubled
    while that makes over 4·10⁶ pieces, as slivers can); a point's candidates are the pieces
    whose centroid lies within radius + (largest centroid–vertex distance), found nearest
    first in a k-d tree (k grows until none is left out).
    """
    from scipy.spatial import cKDTree

    pts = np.ascontiguousarray(points, np.float64).reshape(-1, 3)
    out = np.zeros(len(pts), bool)
    faces = np.asarray(faces)
    if len(pts) == 0 or len(faces) == 0:
        return out
    tri = np.asarray(vertices, np.float64)[faces]
    lo, hi = pts.min(axis=0) - radius, pts.max(axis=0) + radius
    tri = tri[(tri.max(axis=1) >= lo).all(axis=1) & (tri.min(axis=1) <= hi).all(axis=1)]
    if len(tri) == 0:
        return out
    area = 0.5 * np.linalg.norm(np.cross(tri[:, 1] - tri[:, 0], tri[:, 2] - tri[:, 0]), axis=1).sum()
    edge = max(4.0 * radius, math.sqrt(4.0 * area / _MAX_PIECES), 1e-6)
    pieces = _bisect(tri, edge, _PIECE_LIMIT)
    while pieces is None:
        edge *= 2.0
        pieces = _bisect(tri, edge, _PIECE_LIMIT)
    pieces = np.ascontiguousarray(pieces)
    centroid = pieces.mean(axis=1)
    reach = math.sqrt(max(float(((pieces[:, j] - centroid) ** 2).sum(axis=1).max()) for j in range(3)))
    bound = radius + reach + 1e-9 * (1.0 + float(np.abs(centroid).max()))
    tree = cKDTree(centroid)
    m = len(pieces)
    r2 = radius * radius
    for b0 in range(0, len(pts), _QUERY_BATCH):
        todo = np.arange(b0, min(b0 + _QUERY_BATCH, len(pts)))
        k = 8
        while len(todo):
            kk = min(k, m)
            dist, idx = tree.query(pts[todo], k=kk, distance_upper_bound=bound, workers=-1)
            dist, idx = dist.reshape(len(todo), kk), idx.reshape(len(todo), kk)
            hit = _any_within(pts[todo], idx.astype(np.int64), pieces, r2)
            out[todo[hit]] = True
            if kk == m:
                break
            todo = todo[~hit & np.isfinite(dist[:, -1])]  # all kk within reach: there may be more
            k *= 4
    return out


def sample_surface(vertices: ArrayLike, faces: ArrayLike, n: int, rng: np.random.Generator
                   ) -> tuple[NDArray[np.float64], NDArray[np.int64]]:
    """``n`` points uniformly over the triangles (probability ∝ area, uniform within each) and their face indices."""
    v = np.asarray(vertices, np.float64)
    f = np.asarray(faces)
    tri = v[f]
    areas = 0.5 * np.linalg.norm(np.cross(tri[:, 1] - tri[:, 0], tri[:, 2] - tri[:, 0]), axis=1)
    total = areas.sum()
    if n <= 0 or total <= 0:
        return np.zeros((0, 3)), np.zeros(0, np.int64)
    face = rng.choice(len(areas), size=n, p=areas / total)
    r1, r2 = rng.random(n), rng.random(n)
    s = np.sqrt(r1)
    t = tri[face]
    pts = (1 - s)[:, None] * t[:, 0] + (s * (1 - r2))[:, None] * t[:, 1] + (s * r2)[:, None] * t[:, 2]
    return pts, face


def _n_samples(area: float, density: float) -> int:
    return int(np.clip(round(area * density), CT_MIN_SAMPLES, CT_MAX_SAMPLES)) if area > 0 else 0


# =========================================================================== splatting
@nb.njit(cache=True, nogil=True)
def _splat_pinhole(points, C, R, fx, fy, cx, cy, W, H, spacing, max_r, zbuf):  # pragma: no cover - compiled
    """Nearest depth z per pixel of a pinhole frame; every point covers a disc of radius max(1, s·f/z) px."""
    for i in range(points.shape[0]):
        rx = points[i, 0] - C[0]
        ry = points[i, 1] - C[1]
        rz = points[i, 2] - C[2]
        x = R[0, 0] * rx + R[1, 0] * ry + R[2, 0] * rz
        y = R[0, 1] * rx + R[1, 1] * ry + R[2, 1] * rz
        z = R[0, 2] * rx + R[1, 2] * ry + R[2, 2] * rz
        if z <= 1e-9:
            continue
        u = fx * x / z + cx
        v = fy * y / z + cy
        ru = min(max(1.0, spacing * fx / z), max_r)
        rv = min(max(1.0, spacing * fy / z), max_r)
        if u < -ru or u > W + ru or v < -rv or v > H + rv:
            continue
        u0 = max(0, int(math.ceil(u - ru - 0.5)))
        u1 = min(W - 1, int(math.floor(u + ru - 0.5)))
        v0 = max(0, int(math.ceil(v - rv - 0.5)))
        v1 = min(H - 1, int(math.floor(v + rv - 0.5)))
        for py in range(v0, v1 + 1):
            dy = (py + 0.5 - v) / rv
            for px in range(u0, u1 + 1):
                dx = (px + 0.5 - u) / ru
                if dx * dx + dy * dy <= 1.0 and z < zbuf[py, px]:
                    zbuf[py, px] = z


@nb.njit(cache=True, nogil=True)
def _splat_equirect(points, C, R, W, H, spacing, max_r, dbuf):  # pragma: no cover - compiled
    """Nearest distance per pixel of an equirectangular frame; discs of max(1, s/(d·π/H)) px, wider by 1/cos(lat)."""
    for i in range(points.shape[0]):
        rx = points[i, 0] - C[0]
        ry = points[i, 1] - C[1]
        rz = points[i, 2] - C[2]
        d = math.sqrt(rx * rx + ry * ry + rz * rz)
        if d <= 1e-9:
            continue
        x = (R[0, 0] * rx + R[1, 0] * ry + R[2, 0] * rz) / d
        y = (R[0, 1] * rx + R[1, 1] * ry + R[2, 1] * rz) / d
        z = (R[0, 2] * rx + R[1, 2] * ry + R[2, 2] * rz) / d
        lon = math.atan2(x, z)
        lat = math.asin(min(1.0, max(-1.0, -y)))
        u = (lon + math.pi) / (2.0 * math.pi) * W
        v = (0.5 * math.pi - lat) / math.pi * H
        rv = min(max(1.0, spacing / d * H / math.pi), max_r)
        ru = min(rv / max(math.cos(lat), 1e-3), W / 2.0)
        v0 = max(0, int(math.ceil(v - rv - 0.5)))
        v1 = min(H - 1, int(math.floor(v + rv - 0.5)))
        a0 = int(math.ceil(u - ru - 0.5))
        a1 = int(math.floor(u + ru - 0.5))
        if a1 - a0 >= W:
            a1 = a0 + W - 1
        for py in range(v0, v1 + 1):
            dy = (py + 0.5 - v) / rv
            for a in range(a0, a1 + 1):
                dx = (a + 0.5 - u) / ru
                if dx * dx + dy * dy <= 1.0:
                    px = a % W
                    if d < dbuf[py, px]:
                        dbuf[py, px] = d


def splat_distances(points: NDArray[np.float64], camera: Camera, R_world_camera: NDArray, C_world: NDArray,
                    spacing_m: float, max_px: float = MAX_SPLAT_PX) -> NDArray[np.float64]:
    """(H, W) distance along each pixel's ray to the nearest splatted point (inf where none); see the module docstring."""
    R = np.ascontiguousarray(R_world_camera, np.float64)
    C = np.asarray(C_world, np.float64)
    W, H = camera.width, camera.height
    buf = np.full((H, W), np.inf)
    if isinstance(camera, EquirectangularCamera):
        _splat_equirect(points, C, R, W, H, float(spacing_m), float(max_px), buf)
        return buf
    _splat_pinhole(points, C, R, camera.fx, camera.fy, camera.cx, camera.cy, W, H, float(spacing_m), float(max_px), buf)
    x = (np.arange(W) + 0.5 - camera.cx) / camera.fx
    y = (np.arange(H) + 0.5 - camera.cy) / camera.fy
    return buf * np.sqrt(1.0 + x[None, :] ** 2 + y[:, None] ** 2)


def point_spacing(points: NDArray[np.float64], tree=None, sample: int = 20_000, seed: int = 0) -> float:
    """s = r₈·√(π/8), r₈ the median distance to the 8th nearest neighbour of up to ``sample`` points (1/√density)."""
    from scipy.spatial import cKDTree

    n = len(points)
    if n < 2:
        return 0.0
    tree = tree if tree is not None else cKDTree(points)
    k = min(SPACING_NEIGHBOUR, n - 1)
    idx = np.random.default_rng(seed).choice(n, size=min(sample, n), replace=False)
    d, _ = tree.query(points[idx], k=k + 1, workers=-1)
    return float(np.median(d[:, -1]) * math.sqrt(math.pi / k))


# =========================================================================== casting
class _Caster:
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
    """Per-element sums of one chunk (see :class:`_Caster`); returns how many (|dΓ − dΨ|, dΨ/dΓ) samples it kept."""
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


# =========================================================================== validation
def _reality_arrays(reality: Reality) -> tuple[Scene | None, NDArray | None]:
    if isinstance(reality, Scene):
        if len(reality.faces) == 0:
            raise ModelError("the reality model has no triangles")
        return reality, None
    pts = reality.points if isinstance(reality, PointCloud) else reality
    return None, check_points(pts, "the reality point cloud")


def _unit_hint(ratio: float) -> str:
    if not (ratio > 0 and math.isfinite(ratio)):
        return ""
    for value, label in _UNITS:
        if abs(math.log(ratio / value)) < math.log(1.1):
            return f" (≈ {value:g}: {label})"
    return ""


def _overlap_share(a: NDArray, b: NDArray, margin: float) -> float:
    """Share of box a (grown by margin) covered by box b (grown by margin), per-axis lengths multiplied."""
    lo = np.maximum(a[0], b[0]) - margin
    hi = np.minimum(a[1], b[1]) + margin
    return float(np.prod(np.clip(hi - lo, 0, None) / (a[1] - a[0] + 2 * margin)))


def validate(
    scene: Scene,
    plan: Plan,
    reality: Reality,
    registration_error_m: float,
    settings: EvaluationSettings | None = None,
    evaluation: Evaluation | None = None,
    *,
    point_spacing_m: float | None = None,
    ct_density_per_m2: float = CT_DENSITY_PER_M2,
    seed: int = 0,
    cache_dir: str | Path | None | bool = None,
    progress: ProgressCallback | None = None,
) -> Validation:
    """Validate ``plan`` on ``scene`` (Γ at the capture date) against ``reality`` (Ψ, in Γ's frame and unit).

    reality: a Scene (mesh) or a point cloud (:class:`PointCloud` or (n, 3) points).
    registration_error_m: e; λ = 1.2·e. evaluation: the plan's evaluation on ``scene`` (its
    VR_i are the weights); evaluated with ``settings`` when not given. point_spacing_m: the
    cloud's spacing for splatting (estimated when None). See the module docstring.
    """
    t_start = time.perf_counter()
    settings = settings or EvaluationSettings()
    e = float(registration_error_m)
    if not (e >= 0 and math.isfinite(e)):
        raise SightplanError(f"the registration error must be a number of metres ≥ 0, got {registration_error_m!r}")
    if not (ct_density_per_m2 > 0 and math.isfinite(ct_density_per_m2)):
        raise SightplanError(f"the Ct sampling density must be a positive number per m², got {ct_density_per_m2!r}")
    lam = LAMBDA_PER_E * e
    psi_scene, cloud = _reality_arrays(reality)
    timings: dict[str, float] = {}
    if evaluation is None:
        t0 = time.perf_counter()
        evaluation = evaluate(scene, plan, settings, cache_dir=cache_dir)
        timings["evaluation_s"] = time.perf_counter() - t0
    obs = evaluation.observations
    if obs.n_elements != scene.n_elements or obs.n_frames != len(plan):
        raise SightplanError(f"the evaluation has {obs.n_frames} frames and {obs.n_elements} elements; the plan and "
                             f"model have {len(plan)} and {scene.n_elements}: evaluate this plan on this model")
    em = evaluation.metrics.elements
    is_target = em.is_target & scene.present
    VR = em.VR.astype(np.int64)
    visible = em.visible & is_target
    threads = max(1, settings.threads or min(32, os.cpu_count() or 1))

    warnings: list[str] = []
    spacing = 0.0
    tree = None
    if cloud is not None:
        from scipy.spatial import cKDTree

        tree = cKDTree(cloud)
        spacing = float(point_spacing_m) if point_spacing_m is not None else point_spacing(cloud, tree, seed=seed)
        if not (spacing >= 0 and math.isfinite(spacing)):
            raise SightplanError(f"point spacing must be a number of metres ≥ 0, got {point_spacing_m!r}")
        if spacing > lam:
            warnings.append(f"the point cloud's spacing ({spacing:.3g} m) exceeds λ = {lam:.3g} m: Ct (recall) is "
                            "limited by the sampling, while splatted pixels still fill its surfaces")

    # ---- pixels
    t0 = time.perf_counter()
    z = scene.n_elements
    back = np.zeros(z, np.int64)
    complete = np.zeros(z, np.int64)
    both_n = np.zeros(z, np.int64)
    diff_sum = np.zeros(z, np.float64)
    n_model = n_both = n_far = 0
    diffs: list[NDArray] = []
    ratios: list[NDArray] = []
    rays = ray_engine_name(settings.engine)  # the validation casts its own rays: a ray caster, never a rasteriser
    gamma = make_engine(rays, scene, d_max=settings.d_max, threads=1)
    psi_engine = make_engine(rays, psi_scene, threads=1) if psi_scene is not None else None
    caster = _Caster(gamma, psi_engine, cloud, spacing, is_target, lam, threads)
    try:
        for f in range(len(plan)):
            for part in caster.frame(plan.camera_of(f), plan.R_world_camera[f], plan.C_world[f], settings.scale):
                back += part[0]
                complete += part[1]
                both_n += part[2]
                diff_sum += part[3]
                n_model += part[4]
                n_both += part[5]
                n_far += part[6]
                diffs += part[7]
                ratios += part[8]
            if progress is not None:
                progress(f + 1, len(plan))
    finally:
        caster.close()
        gamma.close()
        if psi_engine is not None:
            psi_engine.close()
    timings["cast_s"] = time.perf_counter() - t0

    c = np.where(back > 0, complete / np.maximum(back, 1), 0.0) * is_target
    with np.errstate(invalid="ignore", divide="ignore"):
        A_i = np.where(both_n > 0, diff_sum / np.maximum(both_n, 1), np.nan)
    weight = (VR * both_n * is_target).astype(np.float64)
    A = float((VR * diff_sum * is_target).sum() / weight.sum()) if weight.sum() > 0 else None
    z_t = int(is_target.sum())
    V = int(visible.sum())
    Ce = float(c[is_target].mean()) if z_t else None
    Cv = float(c[visible].mean()) if V else None

    # ---- surfaces: Ct (recall) and precision
    t0 = time.perf_counter()
    rng = np.random.default_rng(seed)
    tgt_faces = scene.faces[is_target[scene.face_element]]
    area = float(scene.face_areas()[is_target[scene.face_element]].sum())
    n_ct = _n_samples(area, ct_density_per_m2)
    gamma_pts, _ = sample_surface(scene.vertices, tgt_faces, n_ct, rng)
    if cloud is not None:
        d, _ = tree.query(gamma_pts, k=1, distance_upper_bound=np.nextafter(lam, np.inf), workers=-1)
        near = np.isfinite(d)
    else:
        near = points_near_mesh(gamma_pts, psi_scene.vertices, psi_scene.faces, lam)
    Ct = float(near.mean()) if len(gamma_pts) else None
    timings["ct_s"] = time.perf_counter() - t0

    t0 = time.perf_counter()
    box = scene.bounds()
    lo, hi = box[0] - lam, box[1] + lam
    if cloud is not None:
        psi_pts = cloud[((cloud >= lo) & (cloud <= hi)).all(axis=1)]
        if len(psi_pts) > CT_MAX_SAMPLES:
            psi_pts = psi_pts[np.sort(rng.choice(len(psi_pts), CT_MAX_SAMPLES, replace=False))]
    else:
        tri = psi_scene.vertices[psi_scene.faces]
        inside = (tri.max(axis=1) >= lo).all(axis=1) & (tri.min(axis=1) <= hi).all(axis=1)
        area_in = float(psi_scene.face_areas()[inside].sum())
        psi_pts, _ = sample_surface(psi_scene.vertices, psi_scene.faces[inside], _n_samples(area_in, ct_density_per_m2), rng)
        psi_pts = psi_pts[((psi_pts >= lo) & (psi_pts <= hi)).all(axis=1)]
    prec_hit = points_near_mesh(psi_pts, scene.vertices, scene.faces, lam)
    precision = float(prec_hit.mean()) if len(psi_pts) else None
    timings["precision_s"] = time.perf_counter() - t0
    recall = Ct
    if precision is None or recall is None:
        F = None
    else:
        F = 2 * precision * recall / (precision + recall) if precision + recall > 0 else 0.0

    # ---- sanity
    d_sample = np.concatenate(diffs) if diffs else np.zeros(0)
    r_sample = np.concatenate(ratios) if ratios else np.zeros(0)
    med_diff = float(np.median(d_sample)) if len(d_sample) else None
    med_ratio = float(np.median(r_sample)) if len(r_sample) else None
    psi_box = psi_scene.bounds() if psi_scene is not None else np.stack([cloud.min(axis=0), cloud.max(axis=0)])
    diag_g = float(np.linalg.norm(box[1] - box[0]))
    diag_p = float(np.linalg.norm(psi_box[1] - psi_box[0]))
    size_ratio = diag_p / diag_g if diag_g > 0 else None
    hint = _unit_hint(med_ratio) if med_ratio is not None else ""
    hint = hint or (_unit_hint(size_ratio) if size_ratio is not None else "")
    box_text = "" if size_ratio is None else f"bounding-box size ratio Ψ/Γ {size_ratio:.4g}"
    if n_both and n_far > FAR_SHARE_WARNING * n_both:
        warnings.append(
            f"{n_far / n_both:.0%} of the {n_both:,} pixels where both models are hit differ by more than λ = {lam:.3g} m "
            f"(median |dΓ − dΨ| = {med_diff:.3g} m): the reality looks badly registered or in another unit; "
            f"scale ratio estimate median(dΨ/dΓ) = {med_ratio:.4g}" + (f", {box_text}" if box_text else "") + hint)
    elif n_model and not n_both:
        warnings.append(f"the reality is hit on none of the {n_model:,} pixels where the model is: is it in the model's "
                        "frame and unit?" + (f" ({box_text}{_unit_hint(size_ratio)})" if box_text else ""))
    share = _overlap_share(box, psi_box, max(lam, 0.01 * diag_g))
    if share < OVERLAP_WARNING:
        warnings.append(f"the reality's bounding box covers only {share:.0%} of the model's"
                        + (f" ({box_text}{_unit_hint(size_ratio)})" if box_text else "")
                        + ": is it registered to the model, in the same frame and unit?")

    timings["total_s"] = time.perf_counter() - t_start
    counts = {"pixels_model": n_model, "pixels_targets": int(back.sum()), "pixels_both": n_both,
              "pixels_both_targets": int(both_n.sum()), "pixels_far": n_far, "pixels_complete": int(complete.sum()),
              "median_abs_diff_m": med_diff, "median_ratio": med_ratio, "box_size_ratio": size_ratio,
              "box_overlap_share": share, "ct_samples": int(len(gamma_pts)), "ct_hits": int(near.sum()),
              "precision_samples": int(len(psi_pts)), "precision_hits": int(prec_hit.sum())}
    parameters = {"scale": settings.scale, "engine": gamma.name, "d_max_m": settings.d_max,
                  "omega": evaluation.settings.metric.omega, "ct_density_per_m2": ct_density_per_m2,
                  "ct_samples_min": CT_MIN_SAMPLES, "ct_samples_max": CT_MAX_SAMPLES, "seed": seed,
                  "point_spacing_m": spacing if cloud is not None else None,
                  "max_splat_px": MAX_SPLAT_PX if cloud is not None else None,
                  "reality_points": int(len(cloud)) if cloud is not None else None,
                  "reality_triangles": int(len(psi_scene.faces)) if psi_scene is not None else None}
    el = scene.elements
    return Validation(
        registration_error_m=e, lam=lam, A=A, Ce=Ce, Cv=Cv, Ct=Ct, precision=precision, recall=recall, F=F,
        z=z_t, n_visible=V, n_frames=len(plan), reality_kind="mesh" if psi_scene is not None else "point cloud",
        c=c, A_i=A_i, pixels=back, pixels_complete=complete, pixels_both=both_n, VR=VR, visible=visible,
        is_target=is_target, global_id=el.global_id, name=el.name, ifc_class=el.ifc_class, counts=counts,
        parameters=parameters, warnings=tuple(warnings), timings=timings,
    )


# =========================================================================== synthetic reality
def outward_normal(scene: Scene, element: int) -> NDArray[np.float64]:
    """Unit normal of the element's largest flat side (faces grouped by normal to 10⁻³), turned away from the
    centre of the scene's bounding box (a tie keeps the winding normal)."""
    sel = scene.face_element == element
    if not sel.any():
        raise ModelError(f"element {element} has no faces in this scene")
    n = scene.face_normals()[sel]
    a = scene.face_areas()[sel]
    key, inv = np.unique(np.round(n, 3), axis=0, return_inverse=True)
    inv = inv.reshape(-1)
    best = int(np.argmax(np.bincount(inv, weights=a, minlength=len(key))))
    normal = (n[inv == best] * a[inv == best, None]).sum(axis=0)
    normal /= np.linalg.norm(normal)
    tri = scene.vertices[scene.faces[sel]]
    centroid = (tri.mean(axis=1) * a[:, None]).sum(axis=0) / max(a.sum(), 1e-300)
    box = scene.bounds()
    return -normal if normal @ (centroid - box.mean(axis=0)) < 0 else normal


def synthetic_reality(scene: Scene, remove: Iterable[int] = (), shift: Mapping[int, float | ArrayLike] | None = None,
                      noise_m: float = 0.0, points_per_m2: float | None = None, seed: int = 0) -> Scene | PointCloud:
    """The model as a reconstruction with known defects, for checks.

    remove: element indices left out. shift: element index → metres along its
    :func:`outward_normal`, or a (3,) vector in metres (its faces get vertices of their own,
    so neighbours stay put). With ``points_per_m2``: round(area·density) points drawn
    uniformly on the result (seeded), each moved by isotropic Gaussian noise of σ = ``noise_m``
    per axis, as a :class:`PointCloud` with the faces' winding normals; else a Scene.
    """
    z = scene.n_elements
    removed = np.zeros(z, bool)
    for i in remove:
        if not 0 <= int(i) < z:
            raise ModelError(f"element index {i} is out of range (0..{z - 1})")
        removed[int(i)] = True
    if not (noise_m >= 0 and math.isfinite(noise_m)):
        raise ModelError(f"noise must be a number of metres ≥ 0, got {noise_m!r}")
    if noise_m > 0 and points_per_m2 is None:
        raise ModelError("noise applies to a point sampling: give points_per_m2")
    keep = ~removed[scene.face_element]
    faces = scene.faces[keep].copy()
    fe = scene.face_element[keep]
    parts = [scene.vertices]
    count = len(scene.vertices)
    for i, amount in (shift or {}).items():
        if not 0 <= int(i) < z:
            raise ModelError(f"element index {i} is out of range (0..{z - 1})")
        vec = np.asarray(amount, np.float64)
        vec = float(vec) * outward_normal(scene, int(i)) if vec.ndim == 0 else vec.reshape(3)
        sel = fe == int(i)
        if not sel.any():
            continue
        corners = scene.vertices[faces[sel]].reshape(-1, 3) + vec
        faces[sel] = count + np.arange(len(corners)).reshape(-1, 3)
        count += len(corners)
        parts.append(corners)
    vertices = np.concatenate(parts)
    h = hashlib.sha256(b"synthetic reality\0")
    for arr in (vertices, faces, fe):
        h.update(np.ascontiguousarray(arr).tobytes())
    psi = replace(scene, vertices=vertices, faces=faces.astype(np.int32), face_element=fe.astype(np.int32),
                  present=scene.present & ~removed, content_hash=h.hexdigest(), source=f"synthetic reality of {scene.source}",
                  metadata={**scene.metadata, "synthetic_reality": {
                      "removed": np.flatnonzero(removed).tolist(),
                      "shift": {int(k): np.asarray(v, float).tolist() for k, v in (shift or {}).items()}}})
    if points_per_m2 is None:
        return psi
    if not (points_per_m2 > 0 and math.isfinite(points_per_m2)):
        raise ModelError(f"points per m² must be a positive number, got {points_per_m2!r}")
    rng = np.random.default_rng(seed)
    n = int(round(float(psi.face_areas().sum()) * points_per_m2))
    if n == 0:
        raise ModelError("the synthetic reality has no surface to sample")
    pts, face = sample_surface(psi.vertices, psi.faces, n, rng)
    if noise_m > 0:
        pts = pts + rng.normal(0.0, noise_m, pts.shape)
    return PointCloud(pts, psi.face_normals()[face])
