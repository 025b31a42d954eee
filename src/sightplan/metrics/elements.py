"""Per-element metrics (METRICS.md §3): VR_i, visible, observed, R_i, O_i."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from ..observations.table import Observations
from .params import MetricParams


@dataclass(frozen=True)
class ElementMetrics:
    """Every array has shape (z_all,), indexed like the scene's element table.

    is_target: elements that count in z. VR: redundant visibility (frames with |γ| ≥ Ω).
    visible: VR > 0. observed: some frame has a rendered count ≥ 1.
    R: mean of the k_i smallest ρ (m/px), NaN where not visible.
    O: mean of the k_i smallest θ̄ (degrees), NaN where not visible.
    pixels_total: Σ_f |γ_{i,f}| in full-resolution pixels. frames_observed: frames with count ≥ 1.
    """

    is_target: NDArray[np.bool_]
    VR: NDArray[np.int64]
    visible: NDArray[np.bool_]
    observed: NDArray[np.bool_]
    R: NDArray[np.float64]
    O: NDArray[np.float64]
    pixels_total: NDArray[np.float64]
    frames_observed: NDArray[np.int64]


def _mean_of_k_smallest(group: NDArray[np.int64], value: NDArray[np.float64], k: int, n_groups: int) -> NDArray[np.float64]:
    """(n_groups,) mean of the min(k, size) smallest values per group; NaN for empty groups."""
    order = np.lexsort((value, group))
    g, v = group[order], value[order]
    first = np.searchsorted(g, g, side="left")
    rank = np.arange(len(g)) - first
    take = rank < k
    total = np.bincount(g[take], weights=v[take], minlength=n_groups)
    count = np.bincount(g[take], minlength=n_groups)
    with np.errstate(invalid="ignore", divide="ignore"):
        return np.where(count > 0, total / np.maximum(count, 1), np.nan)


def element_metrics(obs: Observations, params: MetricParams) -> ElementMetrics:
    z = obs.n_elements
    target_row = obs.is_target[obs.element]
    pixels = obs.pixels
    over = target_row & (pixels >= params.omega)
    e_over = obs.element[over].astype(np.int64)
    VR = np.bincount(e_over, minlength=z).astype(np.int64)
    observed = np.bincount(obs.element[target_row & (obs.count >= 1)], minlength=z) > 0
    R = _mean_of_k_smallest(e_over, obs.ssd[over], params.k, z)
    O = _mean_of_k_smallest(e_over, obs.angle_mean[over], params.k, z)
    return ElementMetrics(
        is_target=obs.is_target.copy(),
        VR=VR,
        visible=VR > 0,
        observed=observed,
        R=R,
        O=O,
        pixels_total=np.bincount(obs.element, weights=pixels, minlength=z) * obs.is_target,
        frames_observed=np.bincount(obs.element[target_row], minlength=z).astype(np.int64),
    )
