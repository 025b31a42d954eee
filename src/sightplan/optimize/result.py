"""What an optimisation found, outdoors or in: the plan, its checks' report and the counts the command line, the
web job and the benchmark print."""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np
from numpy.typing import NDArray

from ..plan.checks.feasibility import FeasibilityReport
from ..plan.types import Plan
from .targets import ElementTargets


@dataclass(frozen=True)
class OptimizeResult:
    """The optimised plan (split and checked), its flight report, and what the optimisation found: per element
    (z,) ``met``; the targets; candidate counts; the views chosen and removed; unstable frames; frames that see no
    target (``blind_frames``: the waste, 0 by construction); timings (s)."""

    plan: Plan
    report: FeasibilityReport
    targets: ElementTargets
    met: NDArray[np.bool_]
    candidates: int
    candidates_dropped: dict
    candidates_blind: int
    removed: int
    forbidden_legs: int
    unstable_frames: int
    blind_frames: int
    stability_views: int = 0
    timings: dict = field(default_factory=dict)

    @property
    def n_met(self) -> int:
        return int(self.met.sum())

    def summary(self) -> dict:
        r = self.report
        return {"frames": len(self.plan), "missions": len(self.plan.missions), "batteries": r.batteries,
                "minutes": None if r.total_time_s is None else round(r.total_time_s / 60, 2),
                "targets": self.targets.n_active, "met": self.n_met, "candidates": self.candidates,
                "candidates_blind": self.candidates_blind, "removed": self.removed,
                "forbidden_legs": self.forbidden_legs, "unstable_frames": self.unstable_frames,
                "stability_views": self.stability_views,
                "blind_frames": self.blind_frames, "ok": r.ok,
                "violations": list(r.violations), "timings_s": {k: round(v, 3) for k, v in self.timings.items()}}
