"""The structure to capture and the ground it stands on.

Templates place frames against the model's **targets**: occluder-only elements (terrain,
furniture, site objects; ``is_target`` False) neither widen the box nor the outline.

The **ground** is taken as a surveyor would (:class:`Ground`, one per scene, found once and kept on it):

1. a height the user gives (``--ground-z``, the web form's "ground z", :func:`with_ground_z`), else
2. the **terrain**: the top surface of the non-target ``IfcSite`` / ``IfcGeographicElement`` geometry under a
   point; a point beyond the terrain's edge takes the terrain's top at its nearest terrain vertex; else
3. the building's **outside ground level**, never a basement:
   - the sill of its lowest *exterior* door: a door is exterior when, in a horizontal section of the model
     through the door, the free space around it connects to the outside (a door opening onto a basement
     stair or a corridor does not);
   - with no door, the lowest point of the targets outside storeys named as basements ("basement",
     "cellar", "Keller", "UG", "sous-sol", "kelder", "B1", "-1"…), when some storey is so named;
   - else the model's base: the lowest point of its targets.

A scene derived from another (:meth:`~sightplan.model.scene.Scene.with_present`, a date) has the ground of the
scene it was derived from: the ground does not move while the building goes up.
"""

from __future__ import annotations

import re
from dataclasses import dataclass
from functools import cached_property

import numpy as np
from numpy.typing import ArrayLike, NDArray

from ..errors import PlanError
from ..model.scene import Scene

TERRAIN_CLASSES = ("ifcsite", "ifcgeographicelement")
MIN_HEIGHT_M = 2.0  # least height of a waypoint above the ground (a plan setting)
GROUND_STATION_HEIGHT_M = 1.5  # a pilot station stands this far above the ground (a pilot's eyes)
GROUND_Z_KEY = "ground_z_m"  # scene metadata: the user's ground height (model frame)
SECTION_CELL_M = 0.2  # the horizontal section's grid
DOOR_SECTION_M = 1.0  # the section is this far above a door's sill (or at its middle, if lower)
BASEMENT_WORDS = re.compile(r"basement|cellar|keller|sous[- ]?sol|kelder|souterrain|tiefgarage|\bug\b|\bb\d\b|"
                            r"(^|\s)-\d\b|\bu\d\b|\bkg\b|\bsótano|\bsotano|interrato|podziem", re.I)
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



@dataclass(frozen=True)
class Ground:
    """The site's ground: ``level_m``, the outside ground level (model frame, m); ``terrain``, the (F, 3, 3)
    terrain triangles (None without terrain); ``source`` ("user", "terrain", "exterior door", "storeys",
    "model base") and ``reason``, a sentence saying why."""

    level_m: float
    source: str
    reason: str
    terrain: NDArray[np.float64] | None = None

    def z(self, xy: ArrayLike) -> NDArray[np.float64]:
        """(n,) the ground's height under each (n, 2) point (a third column is ignored)."""
        P = np.atleast_2d(np.asarray(xy, float))[:, :2]
        if self.terrain is None or not len(P):
            return np.full(len(P), self.level_m)
        top = _top_under(self.terrain, P)
        off = np.isnan(top)
        if off.any():  # beyond the terrain's edge: its top at the nearest terrain vertex
            _, near = self._corner_tree.query(P[off])
            top[off] = _top_under(self.terrain, self.terrain.reshape(-1, 3)[near, :2])
        return np.where(np.isnan(top), self.level_m, top)

    @cached_property
    def _corner_tree(self):
        """A k-d tree of the terrain triangles' corners in XY, built on the first point beyond the terrain's edge."""
        from scipy.spatial import cKDTree

        return cKDTree(self.terrain.reshape(-1, 3)[:, :2])

    def to_dict(self) -> dict:
        return {"level_m": round(self.level_m, 3), "source": self.source, "reason": self.reason}


def with_ground_z(scene: Scene, z: float | None) -> Scene:
    """The scene with the user's ground height (model frame, m), which overrides the terrain and the building's
    ground level; the scene itself for None."""
    if z is None:
        return scene
    if not np.isfinite(z):
        raise PlanError(f"the ground height must be a finite number of metres, got {z}")
    from dataclasses import replace

    return replace(scene, metadata={**scene.metadata, GROUND_Z_KEY: float(z)})


def ground_of(scene: Scene) -> Ground:
    """The scene's :class:`Ground` (see the module docstring), found once per scene and kept on it."""
    found = scene.__dict__.get("_ground")
    if found is None:
        root = scene.__dict__.get("_derived_from", scene)
        found = root.__dict__.get("_ground") or _find_ground(root)
        object.__setattr__(root, "_ground", found)
        object.__setattr__(scene, "_ground", found)
    return found


def _find_ground(scene: Scene) -> Ground:
    user = scene.metadata.get(GROUND_Z_KEY)
    if user is not None:
        return Ground(float(user), "user", f"given by the user: z = {float(user):+.2f} m")
    base = base_z(scene)
    if has_terrain(scene):
        tri = scene.vertices[scene.faces[terrain_elements(scene)[scene.face_element]]].astype(float)
        top = float(tri[:, :, 2].max())
        return Ground(top, "terrain", "the model's terrain surface (IfcSite / IfcGeographicElement geometry)", tri)
    sills = exterior_door_sills(scene)
    if len(sills):
        z = float(sills.min())
        return Ground(z, "exterior door", f"the sill of the lowest of {len(sills)} exterior door(s): z = {z:+.2f} m"
                      + (f" (the model's base, {base:+.2f} m, is below the ground)" if base < z - 0.05 else ""))
    storeys = np.array([str(s) for s in scene.elements.storey], dtype=object)
    basement = np.array([bool(BASEMENT_WORDS.search(s)) for s in storeys])
    above = scene.targets & ~basement
    if (scene.targets & basement).any() and above[scene.face_element].any():
        z = float(scene.vertices[scene.faces[above[scene.face_element]]][:, :, 2].min())
        names = ", ".join(sorted(set(storeys[scene.targets & basement])))
        return Ground(z, "storeys", f"the lowest point above the basement storeys ({names}): z = {z:+.2f} m")
    return Ground(base, "model base", f"the model's base (lowest point of its targets): z = {base:+.2f} m; "
                  "no terrain, exterior door or basement storey says otherwise")


def exterior_door_sills(scene: Scene) -> NDArray[np.float64]:
    """(k,) the sill (lowest point) of each present door that opens to the outside: in a horizontal section of the
    model (terrain left out) :data:`DOOR_SECTION_M` above the sill, the free space next to the door reaches the
    section's edge. Doors sharing a section height share one section."""
    cls = np.array([str(c).lower() for c in scene.elements.ifc_class], dtype=object)
    doors = np.flatnonzero(scene.present & np.isin(cls, ("ifcdoor", "ifcdoorstandardcase")))
    if not len(doors) or not len(scene.faces):
        return np.zeros(0)
    tri = scene.vertices[scene.faces]
    fe = scene.face_element
    lo = np.full((len(scene.elements), 3), np.inf)
    hi = np.full((len(scene.elements), 3), -np.inf)
    np.minimum.at(lo, fe, tri.min(axis=1))
    np.maximum.at(hi, fe, tri.max(axis=1))
    doors = doors[np.isfinite(lo[doors, 0])]
    solid = ~terrain_elements(scene)[fe]
    zs = lo[doors, 2] + np.minimum(DOOR_SECTION_M, (hi[doors, 2] - lo[doors, 2]) / 2)
    out = []
    for z0 in np.unique(np.round(zs, 1)):
        group = doors[np.round(zs, 1) == z0]
        outside, origin = _section_outside(tri[solid], float(z0))
        if outside is None:
            continue
        for d in group:
            a = np.floor((lo[d, :2] - origin) / SECTION_CELL_M).astype(int) - 2
            b = np.floor((hi[d, :2] - origin) / SECTION_CELL_M).astype(int) + 3
            a, b = np.maximum(a, 0), np.minimum(b, outside.shape)
            if outside[a[0]:b[0], a[1]:b[1]].any():
                out.append(lo[d, 2])
    return np.asarray(out, float)


def _section_outside(tri: NDArray, z0: float) -> tuple[NDArray[np.bool_] | None, NDArray]:
    """A grid (cells of :data:`SECTION_CELL_M`) of the horizontal section z = ``z0`` through the (F, 3, 3)
    triangles: True where free space connects to the grid's edge; and the grid's origin (x, y)."""
    from scipy import ndimage

    zt = tri[:, :, 2]
    cut = tri[(zt.min(axis=1) <= z0) & (zt.max(axis=1) >= z0)]
    if not len(cut):
        return None, np.zeros(2)
    pts = []
    for i, j in ((0, 1), (1, 2), (2, 0)):  # where each edge crosses the plane: the section's segments' ends
        a, b = cut[:, i], cut[:, j]
        da, db = a[:, 2] - z0, b[:, 2] - z0
        with np.errstate(divide="ignore", invalid="ignore"):
            t = np.clip(np.where(da != db, da / (da - db), 0.0), 0, 1)
        pts.append(a[:, :2] + t[:, None] * (b[:, :2] - a[:, :2]))
    ends = np.stack(pts, axis=1)  # (k, 3, 2): a triangle's section lies within the hull of these
    origin = ends.reshape(-1, 2).min(axis=0) - 4 * SECTION_CELL_M
    shape = np.ceil((ends.reshape(-1, 2).max(axis=0) + 4 * SECTION_CELL_M - origin) / SECTION_CELL_M).astype(int) + 1
    if shape.prod() > 50_000_000:
        return None, origin
    occupied = np.zeros(shape, bool)
    for i, j in ((0, 1), (1, 2), (2, 0)):
        p, q = ends[:, i], ends[:, j]
        n = np.maximum(1, np.ceil(np.linalg.norm(q - p, axis=1) / (SECTION_CELL_M / 2)).astype(int))
        owner = np.repeat(np.arange(len(p)), n + 1)
        t = (np.arange(len(owner)) - np.repeat(np.cumsum(n + 1) - (n + 1), n + 1)) / np.repeat(n, n + 1)
        xy = p[owner] + t[:, None] * (q[owner] - p[owner])
        cell = np.floor((xy - origin) / SECTION_CELL_M).astype(int)
        occupied[cell[:, 0], cell[:, 1]] = True
    labels, _ = ndimage.label(~occupied)
    edge = np.unique(np.concatenate([labels[0], labels[-1], labels[:, 0], labels[:, -1]]))
    return np.isin(labels, edge[edge > 0]), origin


def ground_z(scene: Scene, xy: ArrayLike) -> NDArray[np.float64]:
    """(n,) height of the ground under each (n, 2) point (x, y; a third column is ignored): see :class:`Ground`."""
    return ground_of(scene).z(xy)


def height_floor(scene: Scene, xy: ArrayLike, min_height_m: float) -> float:
    """The lowest height (model frame) a waypoint over any of the (n, 2) points may fly at: the highest ground under
    them plus ``min_height_m``."""
    return float(ground_z(scene, xy).max()) + float(min_height_m)


FAR_STATION_M = 5_000.0  # a pilot station given by latitude/longitude farther than this from the model is a mistake


def stations_from_geodetic(scene: Scene, geo, latlon: ArrayLike, height_m: float = GROUND_STATION_HEIGHT_M
                           ) -> NDArray[np.float64]:
    """(n, 3) pilot stations (model frame) at (n, 2) latitude°, longitude° (WGS 84): ``height_m`` above the
    ground there (:func:`ground_z`); ``geo`` is the model's :class:`~sightplan.geo.Georeference`.

    A point more than :data:`FAR_STATION_M` from the model is refused, naming it: a latitude and longitude
    given the wrong way round, or another site's."""
    ll = np.asarray(latlon, float).reshape(-1, 2)
    bad = ~np.isfinite(ll).all(axis=1) | (np.abs(ll[:, 0]) > 90) | (np.abs(ll[:, 1]) > 180)
    if bad.any():
        lat, lon = ll[np.flatnonzero(bad)[0]]
        raise PlanError(f"ground station {lat:g}, {lon:g} is not a latitude (−90…90) and a longitude (−180…180)")
    xyz = geo.from_geodetic(ll[:, 0], ll[:, 1], np.full(len(ll), geo.height_m))
    lo, hi = scene.vertices.min(axis=0), scene.vertices.max(axis=0)
    far = np.linalg.norm(np.maximum(0.0, np.maximum(lo[:2] - xyz[:, :2], xyz[:, :2] - hi[:2])), axis=1)
    if (far > FAR_STATION_M).any():
        k = int(np.argmax(far))
        raise PlanError(f"ground station {ll[k, 0]:.6f}, {ll[k, 1]:.6f} lies {far[k] / 1000:,.1f} km from the model "
                        f"(placed by {geo.source}): give latitude first, then longitude, of a point on this site")
    xyz[:, 2] = ground_z(scene, xyz) + float(height_m)
    return xyz
