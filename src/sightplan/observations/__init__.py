"""Observations: the sparse element×frame and feature×frame tables."""

from .table import FrameObservation, Observations

__all__ = ["FrameObservation", "Observations"]
