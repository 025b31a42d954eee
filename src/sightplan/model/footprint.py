"""A model's footprint seen from above: the union of its elements' outlines on the ground plane, for a map.

Each element contributes the convex hull of its vertices in x, y (a slab, a wall, a column: convex or nearly so), so
the union follows courtyards and wings that a hull of the whole model would fill. The terrain (``IfcSite``,
``IfcGeographicElement``) is left out: it would cover the map with one rectangle.

    rings = footprint_rings(scene)     # [[(x, y), ...], ...] closed outer rings, model frame, metres
"""

from __future__ import annotations

import numpy as np
import shapely
from numpy.typing import NDArray

from .scene import Scene

#: Classes left out of the footprint: the ground the building stands on.
TERRAIN_CLASSES = frozenset({"IfcSite", "IfcGeographicElement"})
#: Outlines are simplified to this tolerance (m): a map at street zoom cannot show less.
SIMPLIFY_M = 0.05
#: A point or a line (an element seen edge-on) is widened by this much (m) so that it has an area.
THIN_M = 0.05


def element_hulls(scene: Scene) -> list[shapely.Geometry]:
    """The convex hull in x, y of each element of the scene that is present and not terrain."""
    keep = scene.present & ~np.isin(scene.elements.ifc_class.astype(str), list(TERRAIN_CLASSES))
    faces_kept = keep[scene.face_element]
    if not faces_kept.any():
        return []
    fe = scene.face_element[faces_kept]
    order = np.argsort(fe, kind="stable")
    fe = fe[order]
    corners = scene.faces[faces_kept][order]
    cuts = np.flatnonzero(np.diff(fe)) + 1
    hulls = []
    for part in np.split(corners, cuts):
        xy = scene.vertices[np.unique(part), :2]
        hull = shapely.convex_hull(shapely.multipoints(xy))
        hulls.append(hull if hull.area > 0 else hull.buffer(THIN_M))
    return hulls


def footprint(scene: Scene) -> shapely.Geometry:
    """The union of the elements' hulls, simplified (an empty polygon for an empty scene)."""
    hulls = element_hulls(scene)
    if not hulls:
        return shapely.Polygon()
    return shapely.union_all(hulls).simplify(SIMPLIFY_M)


def footprint_rings(scene: Scene) -> list[NDArray[np.float64]]:
    """The footprint's outer rings, each (n, 2) x, y in metres, closed (the first point repeated last), largest
    first. Holes (a courtyard) are not returned: a map draws the building's outline."""
    shape = footprint(scene)
    polygons = list(getattr(shape, "geoms", [shape]))
    polygons = [p for p in polygons if isinstance(p, shapely.Polygon) and not p.is_empty]
    polygons.sort(key=lambda p: -p.area)
    return [np.asarray(p.exterior.coords, float) for p in polygons]
