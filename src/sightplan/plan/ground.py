"""The structure to capture and the ground it stands on.

Templates place frames against the model's **targets**: occluder-only elements (terrain,
furniture, site objects; ``is_target`` False) neither widen the box nor the outline. The
**ground** under a point is the terrain surface where the model has one (the highest
triangle of a non-target ``IfcSite`` or ``IfcGeographicElement`` under the point), else the
model's base: the lowest point of its targets.
"""

from __future__ import annotations

import numpy as np
from numpy.typing import ArrayLike, NDArray

from ..model.scene import Scene

TERRAIN_CLASSES = ("ifcsite", "ifcgeographicelement")
MIN_HEIGHT_M = 2.0  # least height of a waypoint above the ground (a plan setting)
_PAIRS = 4_000_000  # points × triangles compared at once


def terrain_elements(scene: Scene) -> NDArray[np.bool_]:
    """(z,) the present occluder-only elements that are ground: IfcSite and IfcGeographicElement."""
    cls = np.array([str(c).lower() for c in scene.elements.ifc_class], dtype=object)
    return scene.present & ~scene.elements.is_target & np.isin(cls, TERRAIN_CLASSES)


def targets_only(scene: Scene) -> Scene:
    """The scene with only its target elements; the scene itself when it has no occluders or no target faces."""
    targets = scene.targets
    if not len(scene.faces) or targets[scene.face_element].all() or not targets[scene.face_element].any():
        return scene
    return scene.with_present(targets)


def without_terrain(scene: Scene) -> Scene:
    """The scene less its terrain (the obstacles a safety distance applies to); itself when nothing is left."""
    terrain = terrain_elements(scene)
    if not terrain.any() or terrain[scene.face_element].all():
        return scene
    return scene.with_present(scene.present & ~terrain)


def base_z(scene: Scene) -> float:
    """The model's base: the lowest point of its targets (of everything when it has no target faces)."""
    return float(targets_only(scene).bounds()[0][2])


def has_terrain(scene: Scene) -> bool:
    return bool(len(scene.faces)) and bool(terrain_elements(scene)[scene.face_element].any())


def _top_under(tri: NDArray, xy: NDArray) -> NDArray[np.float64]:
    """(n,) the highest z of the (F, 3, 3) triangles on the vertical line through each (n, 2) point; NaN on none."""
    out = np.full(len(xy), -np.inf)
    lo2, hi2 = tri[:, :, :2].min(axis=1), tri[:, :, :2].max(axis=1)
    tol = 1e-9
    step = max(1, _PAIRS // max(len(tri), 1))
    for a in range(0, len(xy), step):
        p = xy[a:a + step]
        inside = ((lo2[None] <= p[:, None] + tol) & (hi2[None] >= p[:, None] - tol)).all(axis=2)
        i, j = np.nonzero(inside)
        if not len(i):
            continue
        t = tri[j]
        v0, v1, v2 = t[:, 1, :2] - t[:, 0, :2], t[:, 2, :2] - t[:, 0, :2], p[i] - t[:, 0, :2]
        den = v0[:, 0] * v1[:, 1] - v1[:, 0] * v0[:, 1]
        with np.errstate(divide="ignore", invalid="ignore"):
            l1 = (v2[:, 0] * v1[:, 1] - v1[:, 0] * v2[:, 1]) / den
            l2 = (v0[:, 0] * v2[:, 1] - v2[:, 0] * v0[:, 1]) / den
        l0 = 1 - l1 - l2
        hit = (den != 0) & (l0 >= -tol) & (l1 >= -tol) & (l2 >= -tol)  # faces seen edge-on are met at their edges
        z = l0 * t[:, 0, 2] + l1 * t[:, 1, 2] + l2 * t[:, 2, 2]
        np.maximum.at(out, a + i[hit], z[hit])
    out[out == -np.inf] = np.nan
    return out


def ground_z(scene: Scene, xy: ArrayLike) -> NDArray[np.float64]:
    """(n,) height of the ground under each (n, 2) point (x, y; a third column is ignored): the terrain's top
    surface where the model has terrain under the point, else the model's base (:func:`base_z`)."""
    P = np.atleast_2d(np.asarray(xy, float))[:, :2]
    base = base_z(scene)
    if not has_terrain(scene):
        return np.full(len(P), base)
    terrain = terrain_elements(scene)[scene.face_element]
    top = _top_under(scene.vertices[scene.faces[terrain]].astype(float), P)
    return np.where(np.isnan(top), base, top)


def height_floor(scene: Scene, xy: ArrayLike, min_height_m: float) -> float:
    """The lowest height (model frame) a waypoint over any of the (n, 2) points may fly at: the highest ground under
    them plus ``min_height_m``."""
    return float(ground_z(scene, xy).max()) + float(min_height_m)
