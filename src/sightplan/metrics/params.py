"""Metric parameters (METRICS.md §3–5), validated once."""

from __future__ import annotations

from dataclasses import asdict, dataclass

from ..errors import SightplanError


@dataclass(frozen=True)
class MetricParams:
    """omega: visibility threshold Ω in full-resolution pixels (625 = a 25×25 patch).
    k: top-k frames for R_i and O_i. min_track: Y, minimum run of consecutive frames.
    min_features: Λ, features per frame for a stable frame."""

    omega: float = 625.0
    k: int = 3
    min_track: int = 5
    min_features: int = 50

    def __post_init__(self) -> None:
        if not self.omega >= 1:
            raise SightplanError(f"visibility threshold Ω must be at least 1 pixel, got {self.omega}")
        if self.k < 1:
            raise SightplanError(f"top-k must be at least 1, got {self.k}")
        if self.min_track < 1:
            raise SightplanError(f"minimum track length Y must be at least 1 frame, got {self.min_track}")
        if self.min_features < 0:
            raise SightplanError(f"minimum features per frame Λ must be ≥ 0, got {self.min_features}")

    def to_dict(self) -> dict:
        return asdict(self)
