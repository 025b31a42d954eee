"""How the metrics spread over draws of a perturbed plan: pure functions of each draw's :class:`Metrics`.

The draws themselves (perturbed plans cast through the engine) are :mod:`sightplan.robustness`; here only numbers
are summarised: per plan metric its nominal value, the mean and the 5th and 95th percentiles over the draws, and
per element the same of VR_i and the share of draws in which it is visible. Percentiles are numpy's (linear
interpolation between the sorted draws). A metric undefined in a draw (R and O when nothing is visible) is left
out of that draw's statistics; ``defined`` says in how many draws it was defined.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from .plan import Metrics, PlanMetrics

#: the plan metrics summarised, in the order tables show them (PlanMetrics' fields; V is ``n_visible``)
SPREAD_METRICS = ("n_visible", "VC", "VC_bar", "VR", "R", "O", "T", "stable_share")
PERCENTILES = (5.0, 95.0)


@dataclass(frozen=True)
class Spread:
    """One metric over the draws: nominal (the plan as planned), mean, p5, p95 (None where no draw defines it),
    and the number of draws that define it."""

    nominal: float | None
    mean: float | None
    p5: float | None
    p95: float | None
    defined: int

    def to_dict(self, factor: float = 1.0) -> dict:
        scale = lambda x: None if x is None else x * factor  # noqa: E731
        return {"nominal": scale(self.nominal), "mean": scale(self.mean), "p5": scale(self.p5),
                "p95": scale(self.p95), "defined": self.defined}


def spread(nominal: float | None, values: Sequence[float | None]) -> Spread:
    """The :class:`Spread` of ``values`` (one per draw; None where undefined)."""
    x = np.array([np.nan if v is None else float(v) for v in values], float)
    x = x[np.isfinite(x)]
    if len(x) == 0:
        return Spread(nominal, None, None, None, 0)
    p5, p95 = np.percentile(x, PERCENTILES)
    return Spread(None if nominal is None else float(nominal), float(x.mean()), float(p5), float(p95), len(x))


@dataclass(frozen=True)
class ElementSpread:
    """Per element (z_all,), indexed like the scene's element table (zero for non-targets): VR_i nominal, mean over
    the draws, p5, p95, and the share of draws in which the element is visible."""

    VR_nominal: NDArray[np.int64]
    VR_mean: NDArray[np.float64]
    VR_p5: NDArray[np.float64]
    VR_p95: NDArray[np.float64]
    visible_share: NDArray[np.float64]


@dataclass(frozen=True)
class DrawSummary:
    """plan: metric name (:data:`SPREAD_METRICS`) → :class:`Spread`; elements: :class:`ElementSpread`;
    draws: the number of draws."""

    plan: dict[str, Spread]
    elements: ElementSpread
    draws: int


def summarize_draws(nominal: Metrics, draws: Sequence[Metrics]) -> DrawSummary:
    """Spread of every plan metric and of each VR_i over ``draws`` (each the metrics of one perturbed plan)."""
    if not draws:
        raise ValueError("no draws to summarise")
    plans: list[PlanMetrics] = [d.plan for d in draws]
    plan = {name: spread(getattr(nominal.plan, name), [getattr(p, name) for p in plans]) for name in SPREAD_METRICS}
    VR = np.stack([d.elements.VR for d in draws]).astype(np.float64)  # (draws, z_all)
    p5, p95 = np.percentile(VR, PERCENTILES, axis=0)
    elements = ElementSpread(VR_nominal=nominal.elements.VR.copy(), VR_mean=VR.mean(axis=0), VR_p5=p5, VR_p95=p95,
                             visible_share=(VR > 0).mean(axis=0))
    return DrawSummary(plan, elements, len(draws))
