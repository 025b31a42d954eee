"""Plan-wide metrics (METRICS.md §4): VC, V̄C, VR, R, O, T."""

from __future__ import annotations

from dataclasses import asdict, dataclass

import numpy as np

from ..observations.table import Observations
from .elements import ElementMetrics, element_metrics
from .params import MetricParams
from .stability import FrameMetrics, frame_metrics


@dataclass(frozen=True)
class PlanMetrics:
    """Plan scalars; None where undefined (METRICS.md §4), never NaN.

    VC, VC_bar: fractions in [0, 1] (reports show them in %). VR: frames per visible
    element. R: m/px. O: degrees. T: stable features per frame. stable_share: share of
    stable frames (extension). z: target elements. n_visible, n_observed, n_frames.
    """

    VC: float | None
    VC_bar: float | None
    VR: float | None
    R: float | None
    O: float | None
    T: float | None
    stable_share: float | None
    z: int
    n_visible: int
    n_observed: int
    n_frames: int

    def to_dict(self) -> dict:
        return asdict(self)


@dataclass(frozen=True)
class Metrics:
    plan: PlanMetrics
    elements: ElementMetrics
    frames: FrameMetrics
    params: MetricParams


def _ratio(num: float, den: float) -> float | None:
    return float(num) / float(den) if den > 0 else None


def compute_metrics(obs: Observations, params: MetricParams | None = None) -> Metrics:
    """All metrics of a plan from its observations alone."""
    params = params or MetricParams()
    em = element_metrics(obs, params)
    fm = frame_metrics(obs, params)
    targets = em.is_target
    vis = em.visible & targets
    V = int(vis.sum())
    n_obs = int((em.observed & targets).sum())
    z = int(targets.sum())
    n = obs.n_frames
    plan = PlanMetrics(
        VC=_ratio(V, z),
        VC_bar=_ratio(V, n_obs),
        VR=_ratio(em.VR[vis].sum(), V),
        R=float(np.mean(em.R[vis])) if V else None,
        O=float(np.mean(em.O[vis])) if V else None,
        T=_ratio(fm.nu.sum(), n),
        stable_share=_ratio(fm.stable.sum(), n),
        z=z,
        n_visible=V,
        n_observed=n_obs,
        n_frames=n,
    )
    return Metrics(plan, em, fm, params)
