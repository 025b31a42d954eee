"""Stability of reconstruction from simulated feature tracks (METRICS.md §5.3–5.4)."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from ..observations.table import Observations
from .params import MetricParams


@dataclass(frozen=True)
class FrameMetrics:
    """Per frame (n,): nu — features stable in the frame (ν_f); stable — ν_f ≥ Λ;
    features_observed — features observed at all; elements_visible — target elements
    with |γ| ≥ Ω; pixels_on_targets — full-resolution pixels on target elements."""

    nu: NDArray[np.int64]
    stable: NDArray[np.bool_]
    features_observed: NDArray[np.int64]
    elements_visible: NDArray[np.int64]
    pixels_on_targets: NDArray[np.float64]


def stable_feature_counts(feature_id: NDArray, frame: NDArray, n_frames: int, min_track: int) -> NDArray[np.int64]:
    """(n_frames,) ν_f: features lying, in frame f, on a run of ≥ ``min_track`` consecutive frames."""
    if len(frame) == 0:
        return np.zeros(n_frames, np.int64)
    order = np.lexsort((frame, feature_id))
    u, f = feature_id[order].astype(np.int64), frame[order].astype(np.int64)
    new_run = np.r_[True, (u[1:] != u[:-1]) | (f[1:] != f[:-1] + 1)]
    run = np.cumsum(new_run) - 1
    length = np.bincount(run)
    stable = length[run] >= min_track
    return np.bincount(f[stable], minlength=n_frames).astype(np.int64)


def frame_metrics(obs: Observations, params: MetricParams) -> FrameMetrics:
    n = obs.n_frames
    nu = stable_feature_counts(obs.feature_id, obs.feature_frame, n, params.min_track)
    target_row = obs.is_target[obs.element]
    pixels = obs.pixels
    return FrameMetrics(
        nu=nu,
        stable=nu >= params.min_features,
        features_observed=np.bincount(obs.feature_frame, minlength=n).astype(np.int64),
        elements_visible=np.bincount(obs.frame[target_row & (pixels >= params.omega)], minlength=n).astype(np.int64),
        pixels_on_targets=np.bincount(obs.frame[target_row], weights=pixels[target_row], minlength=n),
    )
