"""Capture-plan templates: each a function returning a Plan in the model's local metric frame."""

from .bridge import bridge
from .facade import facade_grid
from .indoor import indoor_route, indoor_routes, read_routes
from .lawnmower import lawnmower
from .orbit import orbit
from .spacing import waypoint_spacing

__all__ = ["bridge", "facade_grid", "indoor_route", "indoor_routes", "lawnmower", "orbit", "read_routes", "waypoint_spacing"]
