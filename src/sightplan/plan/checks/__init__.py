"""Feasibility checks of a plan against the model (flight safety)."""

from .safety import SafetyReport, check_safety, point_distances, segment_distances

__all__ = ["SafetyReport", "check_safety", "point_distances", "segment_distances"]
