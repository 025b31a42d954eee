"""Capture plans: the Plan type, its JSON format, and imports of flown captures."""

from .poses import R_from_gimbal, gimbal_from_R
from .types import Mission, Plan

__all__ = ["Mission", "Plan", "R_from_gimbal", "gimbal_from_R"]
