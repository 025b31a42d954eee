"""The budget of an optimisation, and the longest prefix of a chosen order that keeps to it."""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass
from typing import TypeVar

import numpy as np
from numpy.typing import NDArray

from ..errors import PlanError
from ..plan.checks.feasibility import FeasibilityReport

T = TypeVar("T")


@dataclass(frozen=True)
class Budget:
    """At most ``frames`` views, ``minutes`` of flight, or ``batteries`` charges (None: no limit)."""

    frames: int | None = None
    minutes: float | None = None
    batteries: int | None = None

    def __post_init__(self) -> None:
        """Frames and batteries: whole numbers ≥ 1 (a float of whole value, 3.0, is taken as 3); minutes: a real
        number > 0. True or False, 2.5 frames, NaN, infinity or text are refused."""
        for name in ("frames", "minutes", "batteries"):
            v = given = getattr(self, name)
            if v is None:
                continue
            whole = name != "minutes"
            integer = isinstance(v, (int, np.integer)) and not isinstance(v, bool)
            real = integer or isinstance(v, (float, np.floating))
            if whole and real and not integer and math.isfinite(v) and float(v).is_integer():
                v, integer = int(v), True  # 3.0 frames: 3
            if not ((integer if whole else real and v < math.inf) and v > 0):
                raise PlanError(f"the budget's {name} must be {'a whole number ≥ 1' if whole else 'a number > 0'}, "
                                f"got {given!r}")
            object.__setattr__(self, name, int(v) if integer else float(v))

    def record(self) -> dict:
        """The budget as a plan's parameters record it."""
        return {"frames": self.frames, "minutes": self.minutes, "batteries": self.batteries}

    @property
    def limited(self) -> bool:
        return self.frames is not None or self.minutes is not None or self.batteries is not None

    def admits(self, frames: int, report: FeasibilityReport) -> bool:
        """Whether ``frames`` frames flown (or walked) as ``report`` says keep to the budget."""
        if self.frames is not None and frames > self.frames:
            return False
        if self.minutes is not None and (report.total_time_s or 0.0) > self.minutes * 60:
            return False
        return not (self.batteries is not None and (report.batteries or 0) > self.batteries)


def longest_prefix(views: NDArray, route: Callable[[NDArray, bool], T],
                   fits: Callable[[T], bool]) -> tuple[int, T] | None:
    """The longest prefix of ``views`` (the order chosen: the most useful first) whose ``route(prefix, grow)`` fits,
    by bisection (the plan grows with the prefix), and that route; first with the views grown into runs that
    register, then, for a budget too small for even one run, with the views alone (their frames reported
    unstable). None when not even one view fits."""
    for grow in (True, False):
        lo, hi, best = 1, len(views) + 1, None
        while lo < hi:
            mid = (lo + hi) // 2
            r = route(views[:mid], grow)
            if fits(r):
                lo, best = mid + 1, (mid, r)
            else:
                hi = mid
        if best is not None:
            return best
    return None
