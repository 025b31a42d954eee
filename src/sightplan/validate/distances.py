"""How far a point cloud Ψ lies from the model Γ: robust accuracy and the outliers a sparse SfM cloud carries.

Up to :data:`DISTANCE_SAMPLE` of Ψ's points (seeded) are measured to Γ's nearest triangle, exactly, within a search
radius of max(4·λ, :data:`SEARCH_SHARE` of Γ's bounding-box diagonal); a point beyond it counts as infinitely far.
From the median m and the median absolute deviation MAD of those distances, a point is an *outlier* when no triangle
of Γ lies within the bound b = max(λ, m + :data:`OUTLIER_MADS` · 1.4826 · MAD) — about four standard deviations of
the inliers' spread beyond the median, never nearer than λ and never beyond the search radius. A cloud larger than
the sample is searched for its outliers point by point only when the sample holds one. The accuracy is the
median and the 90th percentile of the inliers' distances. When m itself exceeds λ (a reality badly registered, far
off or in another unit: the validation warns) no bound is set and nothing is excluded.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from ..model.scene import Scene
from .surface import nearest_faces, points_near_mesh

DISTANCE_SAMPLE = 50_000
SEARCH_SHARE = 0.05
OUTLIER_MADS = 5.0
MAD_TO_SIGMA = 1.4826


@dataclass(frozen=True)
class CloudDistances:
    """Point-to-model distances of a cloud (metres). median_all_m: over the sample, outliers included (inf when
    beyond the search radius); median_m, p90_m: over the inliers (None when none is measured); bound_m: the
    outlier bound (inf: none set); outlier (n,): each cloud point beyond it; sampled: points measured."""

    median_all_m: float
    median_m: float | None
    p90_m: float | None
    bound_m: float
    search_m: float
    sampled: int
    outlier: NDArray[np.bool_]

    @property
    def n_outliers(self) -> int:
        return int(self.outlier.sum())

    def to_dict(self) -> dict:
        finite = lambda x: x if x is not None and math.isfinite(x) else None  # noqa: E731
        return {"median_all_m": finite(self.median_all_m), "median_m": self.median_m, "p90_m": self.p90_m,
                "outlier_bound_m": finite(self.bound_m), "search_m": self.search_m, "sampled": self.sampled,
                "outliers": self.n_outliers}


def cloud_distances(cloud: NDArray, scene: Scene, lam: float, seed: int = 0) -> CloudDistances:
    """Distances from ``cloud`` (n, 3) to ``scene``'s triangles, their robust bound and the outliers beyond it
    (module docstring); λ in metres."""
    pts = np.asarray(cloud, np.float64).reshape(-1, 3)
    n = len(pts)
    lo, hi = scene.bounds()
    search = max(4.0 * lam, SEARCH_SHARE * float(np.linalg.norm(hi - lo)), 1e-6)
    outlier = np.zeros(n, bool)
    if n == 0 or len(scene.faces) == 0:
        return CloudDistances(math.inf, None, None, math.inf, search, 0, outlier)
    pick = np.arange(n) if n <= DISTANCE_SAMPLE else np.sort(
        np.random.default_rng(seed).choice(n, DISTANCE_SAMPLE, replace=False))
    _, d = nearest_faces(pts[pick], scene.vertices, scene.faces, search)
    median_all = float(np.median(d))
    bound = math.inf
    if median_all <= lam:
        mad = float(np.median(np.abs(d - median_all)))
        bound = min(max(lam, median_all + OUTLIER_MADS * MAD_TO_SIGMA * mad), search)
        if len(pick) == n:
            outlier = d > bound
        elif (d > bound).any():
            outlier = ~points_near_mesh(pts, scene.vertices, scene.faces, bound)
    inliers = d[np.isfinite(d) & (d <= bound)]
    med = float(np.median(inliers)) if len(inliers) else None
    p90 = float(np.percentile(inliers, 90)) if len(inliers) else None
    return CloudDistances(median_all, med, p90, bound, search, len(pick), outlier)
