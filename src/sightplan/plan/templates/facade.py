"""Facade grid ("3D grid", paper §3.2): waypoint grids around the model at the safety distance g.

``footprint="box"``: each side of the model's bounding box gets a vertical grid of
waypoints at g, with columns every s_h and layers every s_v (eq. 11 with the horizontal
and vertical fields of view). Columns are spread evenly over the side's length and layers
from the bottom row to the box's top, so neither spacing exceeds eq. 11. The box is that
of the model's targets: occluders (terrain, furniture, site objects) do not widen it. The
bottom row stands ``min_height_m`` above the highest ground under the side's columns (the
terrain, else the model's base), or at the targets' base where that is higher. A top row at
g above the roof looks down at 45°; the first and last column of each side turn 45° inward,
toward the middle of their side. The other views are canonical (perpendicular to the
facade). Each side is flown as a snake, column by column, one mission per side, sides
anticlockwise from the south. Frames that see no target are dropped
(:func:`~sightplan.plan.aim.drop_blind_frames`) unless ``drop_blind`` is False.

``footprint="outline"``: the same grid on the model's real outline instead of its box. The
outline is the exterior of the union of the targets' triangles projected to XY (shapely, which
ifcopenshell depends on), with gaps narrower than g/10 closed and details within g/100
simplified away. Each edge's parallel offset at g is trimmed where it comes closer than g
to another edge (inside corners, narrow notches), so every waypoint is g from its own
wall and no nearer to any other; where simplifying cut into the footprint the offset
grows by g/100 so that this still holds. Columns are spread evenly along each trimmed
offset, the cameras look perpendicular to their edge, the top row and the turned end
columns are as for the box. One mission per edge, edges anticlockwise from the one whose
offset lies farthest south; a footprint in several parts is flown part by part
(southernmost first), parts lying in another part's courtyard are skipped. Each edge's
bottom row stands ``min_height_m`` above the highest ground under its columns.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Literal

import numpy as np
from numpy.typing import NDArray

from ...camera.models import Camera, PinholeCamera
from ...errors import PlanError
from ...geometry.poses import R_from_gimbal
from ...model.scene import Scene
from ..aim import drop_blind_frames
from ..ground import MIN_HEIGHT_M, height_floor, targets_only
from ..types import Mission, Plan
from .base import Params, Template, param
from .spacing import check_frame_budget, waypoint_spacing

OBLIQUE_DEG = 45.0
GAP_SHARE = 0.05  # outline mode: gaps in the footprint narrower than 2·GAP_SHARE·g are closed…
DETAIL_SHARE = 0.01  # …and details within DETAIL_SHARE·g simplified away


def _positions(length: float, spacing: float) -> np.ndarray:
    """Evenly spread positions from 0 to ``length`` no more than ``spacing`` apart (one at 0 for zero length)."""
    n = max(1, math.ceil(length / spacing - 1e-9)) + 1 if length > 0 else 1
    return np.linspace(0.0, length, n) if n > 1 else np.zeros(1)


def footprint_outlines(scene: Scene, gap_m: float = 0.0,
                       detail_m: float = 0.0) -> tuple[list[NDArray[np.float64]], float, object]:
    """Exterior rings of the model's XY footprint, each (k, 2) anticlockwise (not closed), southernmost part first.

    The footprint is the union of all triangles projected to XY (faces seen edge-on count
    as thin strips). Gaps narrower than 2·``gap_m`` are closed, details within ``detail_m``
    simplified away (with 0, only collinear vertices are merged). Parts lying inside another
    part's ring are left out. Also returns how far the footprint may reach outside the rings
    (0 unless simplifying cut into it) and the footprint itself (a shapely geometry).
    """
    import shapely
    from shapely.geometry import Polygon
    from shapely.geometry.polygon import orient

    tri = scene.vertices[scene.faces][:, :, :2].astype(float)
    lo, hi = scene.bounds()
    diag = float(np.linalg.norm(hi[:2] - lo[:2]))
    e1, e2 = tri[:, 1] - tri[:, 0], tri[:, 2] - tri[:, 0]
    area = 0.5 * np.abs(e1[:, 0] * e2[:, 1] - e1[:, 1] * e2[:, 0])
    flat = area > 1e-12 * diag * diag
    if diag == 0 or not flat.any():
        raise PlanError("the model has no footprint area to outline")
    footprint = shapely.union_all(shapely.polygons(tri[flat]))
    hair = 1e-6 * diag
    edge_on = shapely.linestrings(tri[~flat])  # faces seen edge-on (walls): usually on the boundary already
    grown = footprint.buffer(hair, join_style="mitre")
    shapely.prepare(grown)
    loose = edge_on[~shapely.covers(grown, edge_on)]
    if len(loose):
        footprint = shapely.union_all([footprint, *shapely.buffer(loose, hair, cap_style="square", join_style="mitre")])
    tol = max(float(detail_m), hair)
    shape = footprint
    if gap_m > 0:
        shape = shapely.union(footprint.buffer(gap_m, join_style="mitre").buffer(-gap_m, join_style="mitre"), footprint)
    simple = shape.simplify(tol)
    excess = tol if shapely.difference(shape, simple).area > hair * hair else 0.0
    parts = [p for p in shapely.get_parts(simple) if p.geom_type == "Polygon" and p.area > 0]
    shells = [Polygon(p.exterior) for p in parts]
    outer = [s for i, s in enumerate(shells) if not any(j != i and o.contains(s) for j, o in enumerate(shells))]
    rings = [np.asarray(orient(s, 1.0).exterior.coords, float)[:-1] for s in outer]
    return sorted(rings, key=lambda r: (r[:, 1].min(), r[:, 0].min())), excess, footprint


def _capsule_intervals(P: NDArray, d: NDArray, A: NDArray, B: NDArray, r: float) -> tuple[NDArray, NDArray]:
    """(m, m) open parameter intervals (lo, hi) where the line P[i] + t·d[i] (d unit) lies within ``r``
    of segment A[j]B[j]: the union of the two end disks and the rectangle (a capsule is convex,
    so the union is one interval). Empty intervals have lo ≥ hi."""
    rel = P[:, None, :] - A[None, :, :]  # (m, m, 2)
    seg = B - A
    length = np.linalg.norm(seg, axis=1)
    u = seg / length[:, None]
    n = np.stack([u[:, 1], -u[:, 0]], axis=1)
    lo, hi = np.full(rel.shape[:2], np.inf), np.full(rel.shape[:2], -np.inf)
    for end in (rel, P[:, None, :] - B[None, :, :]):  # the disks at A and B
        b = np.einsum("ik,ijk->ij", d, end)
        disc = b * b - (np.einsum("ijk,ijk->ij", end, end) - r * r)
        root = np.sqrt(np.maximum(disc, 0))
        hit = disc > 0
        lo = np.where(hit, np.minimum(lo, -b - root), lo)
        hi = np.where(hit, np.maximum(hi, -b + root), hi)
    t0, t1 = np.full(rel.shape[:2], -np.inf), np.full(rel.shape[:2], np.inf)
    for axis, a_lo, a_hi in ((u, 0.0, length[None, :]), (n, -r, r)):  # the rectangle as two slabs
        alpha = np.einsum("ijk,jk->ij", rel, axis)
        beta = d @ axis.T
        with np.errstate(divide="ignore", invalid="ignore"):
            s0, s1 = (a_lo - alpha) / beta, (a_hi - alpha) / beta
        flat = np.abs(beta) < 1e-12
        inside = (alpha > a_lo) & (alpha < a_hi)
        t0 = np.maximum(t0, np.where(flat, np.where(inside, -np.inf, np.inf), np.minimum(s0, s1)))
        t1 = np.minimum(t1, np.where(flat, np.where(inside, np.inf, -np.inf), np.maximum(s0, s1)))
    rect = t0 < t1
    return np.where(rect, np.minimum(lo, t0), lo), np.where(rect, np.maximum(hi, t1), hi)


COMPASS = ("north", "north-east", "east", "south-east", "south", "south-west", "west", "north-west")


def _compass(bearing_deg: float) -> str:
    """The nearest of the eight compass points to a true bearing."""
    return COMPASS[round((bearing_deg % 360.0) / 45.0) % 8]


def _north_offset(scene: Scene, centre: np.ndarray) -> float:
    """Degrees from a model heading to the true heading at ``centre`` (0 for a model without a georeference)."""
    from ...geo import Georeference, GeoreferenceError

    try:
        geo = Georeference.from_scene_metadata(scene.metadata)
        return 0.0 if geo is None else float(geo.north_offset_deg(centre)[0])
    except GeoreferenceError:
        return 0.0


def _outline_sides(scene: Scene, g: float, s_h: float) -> list[tuple]:
    """(name, start, along, columns, outward normal) per outline edge, as for the box's sides."""
    import shapely

    rings, excess, footprint = footprint_outlines(scene, GAP_SHARE * g, DETAIL_SHARE * g)
    d = g + excess  # the offset from the simplified rings that keeps g from the real footprint
    A = np.concatenate(rings)
    B = np.concatenate([np.roll(r, -1, axis=0) for r in rings])
    length = np.linalg.norm(B - A, axis=1)
    along = (B - A) / length[:, None]
    normal = np.stack([along[:, 1], -along[:, 0]], axis=1)  # outward for an anticlockwise ring
    tiny = 1e-6 * max(float(length.max()), d)  # rounding: a line touching a capsule gets an interval this narrow
    near: list[list[tuple[float, float]]] = []  # per edge: where its offset comes within d of another edge
    for rows in np.array_split(np.arange(len(A)), max(1, len(A) // 256)):
        lo_t, hi_t = _capsule_intervals(A[rows] + d * normal[rows], along[rows], A, B, d)
        lo_t[np.arange(len(rows)), rows] = np.inf  # not its own edge
        hit = (hi_t > 0) & (lo_t < length[rows, None]) & (hi_t - lo_t > tiny)
        near += [sorted(zip(lo_t[k][hit[k]], hi_t[k][hit[k]])) for k in range(len(rows))]
    sides, first = [], 0
    for p, ring in enumerate(rings):
        edges = []
        for i in range(first, first + len(ring)):
            free, pos = [], 0.0  # [0, length] less the open intervals too near another edge
            for a, b in near[i]:
                if a > pos + tiny:
                    free.append((pos, a))
                pos = max(pos, b)
            if length[i] > pos + tiny:
                free.append((pos, length[i]))
            if free:
                cols = np.concatenate([a + _positions(b - a, s_h) for a, b in free])
                xy = A[i] + d * normal[i] + cols[:, None] * along[i]
                cols = cols[shapely.distance(shapely.points(xy), footprint) >= g * (1 - 1e-9)]  # a last guard
            if free and len(cols):
                mid = A[i] + d * normal[i] + along[i] * (free[0][0] + free[-1][1]) / 2
                edges.append((i, cols, mid))
        first += len(ring)
        if not edges:
            continue
        k0 = min(range(len(edges)), key=lambda k: (edges[k][2][1], edges[k][2][0]))
        prefix = f"facade part {p + 1} edge" if len(rings) > 1 else "facade edge"
        for n_edge, (i, cols, _) in enumerate(edges[k0:] + edges[:k0]):
            sides.append((f"{prefix} {n_edge + 1}", A[i] + excess * normal[i], along[i], cols, normal[i]))
    if not sides:
        raise PlanError(f"no part of the model's outline can be flown at {g:g} m")
    return sides


def _valid_min_height(min_height_m: float) -> float:
    if not (min_height_m >= 0 and math.isfinite(min_height_m)):
        raise PlanError(f"the minimum height must be a number of metres ≥ 0, got {min_height_m}")
    return float(min_height_m)


def layer_heights(floor: float, top: float, spacing: float) -> NDArray[np.float64]:
    """Heights from ``floor`` to ``top`` no more than ``spacing`` apart (just ``floor`` when it is not below ``top``)."""
    return floor + _positions(top - floor, spacing) if top > floor else np.array([floor])


def facade_grid(scene: Scene, camera: Camera, safety_distance_m: float, overlap: float = 0.8,
                top_row: bool = True, oblique_edges: bool = True, footprint: Literal["box", "outline"] = "box",
                min_height_m: float = MIN_HEIGHT_M, drop_blind: bool = True) -> Plan:
    """A facade-grid plan around the bounding box or real outline of ``scene``'s targets; see the module docstring."""
    if not isinstance(camera, PinholeCamera):
        raise PlanError("a facade grid needs a perspective (pinhole) camera")
    if footprint not in ("box", "outline"):
        raise PlanError(f"the footprint must be 'box' or 'outline', got {footprint!r}")
    min_h = _valid_min_height(min_height_m)
    structure = targets_only(scene)
    lo, hi = structure.bounds()
    size = hi - lo
    if not (size > 1e-3).all():  # a model thinner than a millimetre in any direction has no facade to fly
        raise PlanError(f"the model's box has no extent to plan around ({size.round(3).tolist()} m)")
    g = float(safety_distance_m)
    s_h = waypoint_spacing(g, camera.hfov_deg, overlap)
    s_v = waypoint_spacing(g, camera.vfov_deg, overlap)
    # the box's grid, estimated before anything is built (an outline's is no larger than its box's by much)
    check_frame_budget((2 * (size[0] + size[1]) / s_h + 8) * (size[2] / s_v + 3),
                       f"a facade grid at {g:g} m with {overlap:.0%} overlap", "overlap or safety_distance_m")
    if footprint == "outline":
        sides = _outline_sides(structure, g, s_h)
    else:
        # sides anticlockwise from the south: (name, start corner, along-side unit vector, columns, outward normal)
        sides = [
            ("south", np.array([lo[0], lo[1]]), np.array([1.0, 0.0]), _positions(size[0], s_h), np.array([0.0, -1.0])),
            ("east", np.array([hi[0], lo[1]]), np.array([0.0, 1.0]), _positions(size[1], s_h), np.array([1.0, 0.0])),
            ("north", np.array([hi[0], hi[1]]), np.array([-1.0, 0.0]), _positions(size[0], s_h), np.array([0.0, 1.0])),
            ("west", np.array([lo[0], hi[1]]), np.array([0.0, -1.0]), _positions(size[1], s_h), np.array([-1.0, 0.0])),
        ]
        offset = _north_offset(scene, (lo + hi) / 2)  # the sides are named by the true bearing they face
        sides = [(f"facade {_compass(math.degrees(math.atan2(normal[0], normal[1])) + offset) if offset else name}",
                  start, along, cols, normal) for name, start, along, cols, normal in sides]
    C, heading, pitch, missions = [], [], [], []
    floors = []
    for name, start, along, cols, normal in sides:
        look = -normal
        base_heading = math.degrees(math.atan2(look[0], look[1]))
        column_xy = start + cols[:, None] * along + g * normal
        floor = max(float(lo[2]), height_floor(scene, column_xy, min_h))
        floors.append(floor)
        layers = layer_heights(floor, float(hi[2]), s_v)
        first = len(C)
        for j, xy in enumerate(column_xy):
            turn = 0.0
            if oblique_edges and len(cols) > 1 and j in (0, len(cols) - 1):
                # turn inward, toward the side's middle: +along at the start, −along at the end (heading is clockwise)
                toward = along if j == 0 else -along
                turn = OBLIQUE_DEG if (look[0] * toward[1] - look[1] * toward[0]) < 0 else -OBLIQUE_DEG
            zs = list(layers) if j % 2 == 0 else list(layers[::-1])  # snake: up one column, down the next
            rows = [(z, 0.0) for z in zs]
            if top_row:
                top = (max(hi[2] + g, floor), -OBLIQUE_DEG)
                rows = rows + [top] if j % 2 == 0 else [top] + rows
            for z, p in rows:
                C.append([xy[0], xy[1], z])
                heading.append((base_heading + turn) % 360.0)
                pitch.append(p)
        missions.append(Mission(name, first, len(C)))
    C = np.asarray(C)
    R = R_from_gimbal(np.asarray(heading), np.asarray(pitch), 0.0)
    plan = Plan.build(camera, R, C, missions=tuple(missions), waypoints=C,
                      parameters={"template": "facade_grid", "safety_distance_m": g, "overlap": overlap,
                                  "spacing_horizontal_m": s_h, "spacing_vertical_m": s_v, "top_row": top_row,
                                  "oblique_edges": oblique_edges, "footprint": footprint, "min_height_m": min_h,
                                  "bottom_row_z_m": float(min(floors))})
    return drop_blind_frames(scene, plan, "facade grid") if drop_blind else plan


@dataclass(frozen=True)
class FacadeParams(Params):
    overlap: float = param(0.8, "image overlap l between neighbouring frames", ge=0, le=0.95)
    footprint: str = param("box", "grids on the sides of the bounding 'box', or around the model's real 'outline'",
                           choices=("box", "outline"))


def _build(scene: Scene, camera: Camera, p: FacadeParams, safety_distance_m: float, min_height_m: float) -> Plan:
    return facade_grid(scene, camera, safety_distance_m, p.overlap, footprint=p.footprint, min_height_m=min_height_m)


TEMPLATE = Template("facade", "grids around the sides", FacadeParams, _build, order=0)
