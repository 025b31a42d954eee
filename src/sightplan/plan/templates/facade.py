"""Facade grid ("3D grid", paper §3.2): waypoint grids on the four sides of the model's box.

Each side of the model's bounding box gets a vertical grid of waypoints at the safety
distance g, with columns every s_h and layers every s_v (eq. 11 with the horizontal and
vertical fields of view). Columns are spread evenly over the side's length and layers
from the box's bottom to its top, so neither spacing exceeds eq. 11. A top row at g above
the roof looks down at 45°; the first and last column of each side turn 45° toward their
corner. The other views are canonical (perpendicular to the facade). Each side is flown
as a snake, column by column, one mission per side, sides anticlockwise from the south.
"""

from __future__ import annotations

import math

import numpy as np

from ...camera.models import Camera, PinholeCamera
from ...errors import PlanError
from ...model.scene import Scene
from ..poses import R_from_gimbal
from ..types import Mission, Plan
from .spacing import waypoint_spacing

OBLIQUE_DEG = 45.0


def _positions(length: float, spacing: float) -> np.ndarray:
    """Evenly spread positions from 0 to ``length`` no more than ``spacing`` apart (one at 0 for zero length)."""
    n = max(1, math.ceil(length / spacing - 1e-9)) + 1 if length > 0 else 1
    return np.linspace(0.0, length, n) if n > 1 else np.zeros(1)


def facade_grid(scene: Scene, camera: Camera, safety_distance_m: float, overlap: float = 0.8,
                top_row: bool = True, oblique_edges: bool = True) -> Plan:
    """A facade-grid plan around ``scene``'s bounding box; see the module docstring."""
    if not isinstance(camera, PinholeCamera):
        raise PlanError("a facade grid needs a perspective (pinhole) camera")
    lo, hi = scene.bounds()
    size = hi - lo
    if not (size > 1e-3).all():  # a model thinner than a millimetre in any direction has no facade to fly
        raise PlanError(f"the model's box has no extent to plan around ({size.round(3).tolist()} m)")
    g = float(safety_distance_m)
    s_h = waypoint_spacing(g, camera.hfov_deg, overlap)
    s_v = waypoint_spacing(g, camera.vfov_deg, overlap)
    layers = lo[2] + _positions(size[2], s_v)
    # sides anticlockwise from the south: (start corner, along-side unit vector, length, outward normal)
    sides = [
        ("south", np.array([lo[0], lo[1]]), np.array([1.0, 0.0]), size[0], np.array([0.0, -1.0])),
        ("east", np.array([hi[0], lo[1]]), np.array([0.0, 1.0]), size[1], np.array([1.0, 0.0])),
        ("north", np.array([hi[0], hi[1]]), np.array([-1.0, 0.0]), size[0], np.array([0.0, 1.0])),
        ("west", np.array([lo[0], hi[1]]), np.array([0.0, -1.0]), size[1], np.array([-1.0, 0.0])),
    ]
    C, heading, pitch, missions = [], [], [], []
    for name, start, along, length, normal in sides:
        cols = _positions(length, s_h)
        look = -normal
        base_heading = math.degrees(math.atan2(look[0], look[1]))
        first = len(C)
        for j, u in enumerate(cols):
            xy = start + u * along + g * normal
            turn = 0.0
            if oblique_edges and len(cols) > 1 and j in (0, len(cols) - 1):
                # turn toward the corner: toward −along at the start, +along at the end (heading is clockwise)
                toward = -along if j == 0 else along
                turn = OBLIQUE_DEG if (look[0] * toward[1] - look[1] * toward[0]) < 0 else -OBLIQUE_DEG
            zs = list(layers) if j % 2 == 0 else list(layers[::-1])  # snake: up one column, down the next
            rows = [(z, 0.0) for z in zs]
            if top_row:
                top = (hi[2] + g, -OBLIQUE_DEG)
                rows = rows + [top] if j % 2 == 0 else [top] + rows
            for z, p in rows:
                C.append([xy[0], xy[1], z])
                heading.append((base_heading + turn) % 360.0)
                pitch.append(p)
        missions.append(Mission(f"facade {name}", first, len(C)))
    C = np.asarray(C)
    R = R_from_gimbal(np.asarray(heading), np.asarray(pitch), 0.0)
    return Plan.build(camera, R, C, missions=tuple(missions), waypoints=C,
                      parameters={"template": "facade_grid", "safety_distance_m": g, "overlap": overlap,
                                  "spacing_horizontal_m": s_h, "spacing_vertical_m": s_v, "top_row": top_row,
                                  "oblique_edges": oblique_edges})
