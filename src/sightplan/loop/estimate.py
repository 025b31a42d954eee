"""What a closed loop will cost before it starts: the photographs' size at the default render scale, and the
minutes to expect.

By default the photographs hold about :data:`DEFAULT_PHOTO_PIXELS` pixels each (0.1 of a 20 MP camera's width:
547 × 365 px), where SIFT still finds thousands of features per frame and a facade grid of a hundred frames goes
round the loop in minutes. The expected time is :data:`S_PER_MPX` seconds per million photograph pixels (rendering
and SIFT) plus :data:`S_PER_FRAME` seconds per frame (matching, mapping, evaluation, validation, measures and
study), rates measured on the Duplex's facade grid on 2 cores (README, the closed loop).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from ..errors import SightplanError
from ..plan.types import Plan

DEFAULT_PHOTO_PIXELS = 200_000
S_PER_MPX = 1.9
S_PER_FRAME = 0.65


def default_scale(plan: Plan) -> float:
    """The render scale at which the plan's largest camera takes about :data:`DEFAULT_PHOTO_PIXELS` pixels, rounded
    down to two decimals (at most 1, at least 0.01)."""
    if not plan.cameras:
        raise SightplanError("the plan has no camera")
    pixels = max(c.width * c.height for c in plan.cameras.values())
    s = min(1.0, math.sqrt(DEFAULT_PHOTO_PIXELS / pixels))
    return max(0.01, math.floor(s * 100 + 1e-6) / 100)


@dataclass(frozen=True)
class LoopEstimate:
    """frames; scale; width × height of the largest photograph; megapixels over all photographs; minutes expected."""

    frames: int
    scale: float
    width: int
    height: int
    megapixels: float
    minutes: float

    def text(self) -> str:
        return (f"photographs: {self.frames} frames × {self.width}×{self.height} px at render scale {self.scale:g} "
                f"({self.megapixels:,.1f} Mpx in all); expected about {self.minutes:.0f} min on 2 cores "
                "(--scale to change)")


def estimate(plan: Plan, scale: float) -> LoopEstimate:
    """The photographs of ``plan`` at render scale ``scale`` and the minutes the loop should take (module docstring)."""
    ids, counts = np.unique(np.asarray(plan.frame_camera, dtype=str), return_counts=True)
    cams = [plan.cameras[i].scaled(scale) if scale != 1 else plan.cameras[i] for i in ids]
    largest = max(cams, key=lambda c: c.width * c.height, default=None)
    mpx = sum(int(n) * c.width * c.height for c, n in zip(cams, counts, strict=True)) / 1e6
    minutes = (S_PER_MPX * mpx + S_PER_FRAME * len(plan)) / 60
    return LoopEstimate(len(plan), scale, largest.width if largest else 0, largest.height if largest else 0, mpx,
                        minutes)
