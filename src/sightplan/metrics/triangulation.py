"""Triangulation angles per element: the angle between the viewing rays that structure from motion needs.

VR_i counts the frames that see an element and O_i how squarely they see it, but neither says whether two of those
frames see the same point of it from directions far enough apart for the point to be triangulated. Here, from the
Observations' feature×frame visibility (METRICS.md §5.2), the simulated features' positions and the plan's camera
centres — no ray is cast:

- per feature u seen by the frames F_u, the ray from u to each camera centre C_f, f ∈ F_u; ``largest`` the largest
  angle between two of these rays and ``median`` the median over the pairs (0 when |F_u| = 1);
- per element i, over the features it owns (a corner shared by several elements belongs to none) that at least one
  frame sees: ``largest_deg`` and ``median_deg``, the medians over those features of the features' largest and
  median pairwise angles; ``max_deg`` the largest pairwise angle of any of them; ``triangulable`` the share of them
  whose largest angle is at least ``min_angle_deg`` (a point needs two views that far apart); ``views`` the median
  of |F_u|; and ``seen_share`` the share of all the features it owns that some frame sees — the share of its
  surface seen, sampled at the feature density;
- NaN where an element owns no feature (``seen_share``) or no frame sees any of them (the rest).

The angles are in degrees. Frames are counted once per feature however many frames share a centre.
"""

from __future__ import annotations

from dataclasses import dataclass

import numba as nb
import numpy as np
from numpy.typing import NDArray

from ..errors import ObservationsError
from ..observations.table import Observations

#: The smallest largest-angle at which a feature counts as triangulable (degrees): a structure-from-motion
#: pipeline keeps a point whose rays are this far apart (COLMAP's mapper: 1.5°).
MIN_TRIANGULATION_DEG = 2.0
#: The largest angle between two views of a point at which their descriptors still match, as a rule (degrees).
MATCHABLE_DEG = 40.0


@dataclass(frozen=True)
class TriangulationAngles:
    """Per element (z,), indexed like the scene's element table; see the module docstring."""

    largest_deg: NDArray[np.float64]
    median_deg: NDArray[np.float64]
    max_deg: NDArray[np.float64]
    triangulable: NDArray[np.float64]
    views: NDArray[np.float64]
    seen_share: NDArray[np.float64]
    features: NDArray[np.int64]
    features_seen: NDArray[np.int64]
    matchable_deg: NDArray[np.float64]
    min_angle_deg: float
    matchable_deg_limit: float


@nb.njit(nogil=True, cache=True)
def _pair_angles(start, frames, points, centres, matchable):
    """Per feature group g (rows start[g]:start[g+1] of ``frames``, feature ``points[g]``): the largest, the
    median, and the largest up to ``matchable`` angle (radians) between the rays from the point to the frames'
    centres."""
    n = len(start) - 1
    largest = np.zeros(n)
    median = np.zeros(n)
    within = np.zeros(n)
    kmax = 0
    for g in range(n):
        kmax = max(kmax, start[g + 1] - start[g])
    rays = np.empty((kmax, 3))
    buf = np.empty(max(1, kmax * (kmax - 1) // 2))
    for g in range(n):
        a, b = start[g], start[g + 1]
        k = b - a
        for j in range(k):
            d0 = centres[frames[a + j], 0] - points[g, 0]
            d1 = centres[frames[a + j], 1] - points[g, 1]
            d2 = centres[frames[a + j], 2] - points[g, 2]
            norm = np.sqrt(d0 * d0 + d1 * d1 + d2 * d2)
            if norm == 0.0:
                norm = 1.0
            rays[j, 0] = d0 / norm
            rays[j, 1] = d1 / norm
            rays[j, 2] = d2 / norm
        m = 0
        best = 0.0
        best_within = 0.0
        for i in range(k):
            for j in range(i + 1, k):
                c0 = rays[i, 1] * rays[j, 2] - rays[i, 2] * rays[j, 1]
                c1 = rays[i, 2] * rays[j, 0] - rays[i, 0] * rays[j, 2]
                c2 = rays[i, 0] * rays[j, 1] - rays[i, 1] * rays[j, 0]
                dot = rays[i, 0] * rays[j, 0] + rays[i, 1] * rays[j, 1] + rays[i, 2] * rays[j, 2]
                ang = np.arctan2(np.sqrt(c0 * c0 + c1 * c1 + c2 * c2), dot)
                buf[m] = ang
                m += 1
                if ang > best:
                    best = ang
                if best_within < ang <= matchable:
                    best_within = ang
        largest[g] = best
        within[g] = best_within
        if m > 0:
            median[g] = np.median(buf[:m])
    return largest, median, within


def _group_median(group: NDArray[np.int64], value: NDArray[np.float64], n_groups: int) -> NDArray[np.float64]:
    """(n_groups,) median of ``value`` per group; NaN for empty groups."""
    out = np.full(n_groups, np.nan)
    if len(group) == 0:
        return out
    order = np.lexsort((value, group))
    g, v = group[order], value[order]
    starts = np.flatnonzero(np.r_[True, g[1:] != g[:-1]])
    ends = np.r_[starts[1:], len(g)]
    lo, hi = starts + (ends - starts - 1) // 2, starts + (ends - starts) // 2
    out[g[starts]] = 0.5 * (v[lo] + v[hi])
    return out


def triangulation_angles(obs: Observations, centres: NDArray, feature_points: NDArray, feature_element: NDArray,
                         min_angle_deg: float = MIN_TRIANGULATION_DEG,
                         matchable_deg: float = MATCHABLE_DEG) -> TriangulationAngles:
    """The per-element triangulation angles (module docstring) of the plan whose camera centres are ``centres``
    (n, 3), from ``obs``'s feature visibility and the features' positions (N, 3) and owning elements (N,)."""
    centres = np.asarray(centres, np.float64).reshape(-1, 3)
    points = np.asarray(feature_points, np.float64).reshape(-1, 3)
    owner = np.asarray(feature_element, np.int64).reshape(-1)
    if len(centres) != obs.n_frames:
        raise ObservationsError(f"{len(centres)} camera centres for {obs.n_frames} frames")
    if len(points) != obs.n_features or len(owner) != obs.n_features:
        raise ObservationsError(f"{len(points)} feature positions and {len(owner)} owners for the "
                                f"{obs.n_features} features the observations were made with")
    z = obs.n_elements
    owned = owner >= 0
    features = np.bincount(owner[owned], minlength=z).astype(np.int64)
    fid = obs.feature_id.astype(np.int64)
    keep = owner[fid] >= 0
    fid, ff = fid[keep], obs.feature_frame.astype(np.int64)[keep]
    order = np.lexsort((ff, fid))
    fid, ff = fid[order], ff[order]
    if len(fid):
        firsts = np.flatnonzero(np.r_[True, fid[1:] != fid[:-1]])
        u = fid[firsts]
        start = np.r_[firsts, len(fid)].astype(np.int64)
        largest, median, within = _pair_angles(start, ff, np.ascontiguousarray(points[u]),
                                               np.ascontiguousarray(centres), np.radians(matchable_deg))
        largest, median, within = np.degrees(largest), np.degrees(median), np.degrees(within)
        views = np.diff(start).astype(np.float64)
    else:
        u = np.zeros(0, np.int64)
        largest = median = within = views = np.zeros(0)
    e = owner[u]
    seen = np.bincount(e, minlength=z).astype(np.int64)
    with np.errstate(invalid="ignore", divide="ignore"):
        tri = np.bincount(e, weights=(within >= min_angle_deg).astype(float), minlength=z) / seen
        share = np.where(features > 0, seen / np.maximum(features, 1), np.nan)
    maxed = np.full(z, -np.inf)
    np.maximum.at(maxed, e, largest)
    return TriangulationAngles(
        largest_deg=_group_median(e, largest, z), median_deg=_group_median(e, median, z),
        matchable_deg=_group_median(e, within, z),
        max_deg=np.where(seen > 0, maxed, np.nan), triangulable=np.where(seen > 0, tri, np.nan),
        views=_group_median(e, views, z), seen_share=share, features=features, features_seen=seen,
        min_angle_deg=float(min_angle_deg), matchable_deg_limit=float(matchable_deg))
