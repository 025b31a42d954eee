"""Capture-plan templates: each a function returning a Plan in the model's local metric frame."""

from .facade import facade_grid
from .orbit import orbit
from .spacing import waypoint_spacing

__all__ = ["facade_grid", "orbit", "waypoint_spacing"]
