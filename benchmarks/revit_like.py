"""A generated IFC2X3 file shaped like a Revit export of a furnished building (a restaurant).

`python benchmarks/revit_like.py [PATH] [--rooms N] [--detail X] [--properties N]` writes one and
prints its size; :func:`write_revit_like_ifc` is the same from Python (tests use a tiny one).

What a Revit 2012 export of a furnished building looks like, and what this file has:

- millimetre length unit, one owner history, Site → Building → storeys, IfcSpace per room;
- per room four IfcWallStandardCase (extruded rectangles with an Axis polyline), each door and
  window sitting in an IfcOpeningElement that voids the wall (IfcRelVoidsElement) and that it
  fills (IfcRelFillsElement), so the geometry kernel has to subtract every opening; a floor
  IfcSlab; round IfcColumns (IfcCircleProfileDef extrusions);
- many IfcFurnishingElement occurrences whose geometry is shared as Revit shares a family's:
  one IfcRepresentationMap per IfcFurnitureType, each occurrence an IfcMappedItem of it with an
  identity target and its own placement. The furniture has curved detail: cylinder legs and
  table tops (IfcExtrudedAreaSolid of IfcCircleProfileDef), cushions, shades and foliage as
  IfcFacetedBrep shells of hundreds to thousands of faces, a table top clipped by an
  IfcBooleanClippingResult; doors and windows are mapped types too;
- Revit-sized property sets: ``properties`` IfcPropertySingleValue per element, in groups of 16.

``rooms`` scales the building (12 rooms per storey), ``detail`` the faces of the faceted shells
and ``properties`` the property sets. The defaults (32 rooms on 3 storeys) give 27.5 MB, 315,000
entities, 1,824 elements (1,376 of them furniture of 7 types) and 3.0 M triangles with
IfcOpenShell's default tessellation, written in about 15 s; :data:`TINY` (2 rooms, coarser shells,
16 properties) gives 0.5 MB and 114 elements in under a second.

A real Revit 2012 restaurant differs in three ways that decide what loading and sampling cost, and
:data:`RESTAURANT` adds them: ``studs`` small boxes in every furniture family (fittings, buttons, slats:
each vertex a corner, so corners make about 98 % of the simulated features, as there), ``window_bars``
glazing bars in the window type (about 8 % of the triangles outside the furniture, as there), and
``proxies`` floor partitions as IfcBuildingElementProxy with a faceted shell of their own, not shared
and heavy to tessellate (the real file has two of 44,228 triangles, 4.3 CPU-s each); ``plaza_m``, a
building pad that square around it, gives the real file's share of surface to the features.
"""

from __future__ import annotations

import argparse
import math
import sys
import time
import uuid
from pathlib import Path

import numpy as np

ROOMS_PER_STOREY = 12  # 4 × 3
ROOM_W, ROOM_D, WALL_H, WALL_T = 9000.0, 7000.0, 3200.0, 200.0  # mm
STOREY_H, SLAB_T = 3500.0, 250.0
PITCH_X, PITCH_Y = ROOM_W + WALL_T, ROOM_D + WALL_T
#: the keyword arguments of a model small enough for a test (0.5 MB, 114 elements, 70,000 triangles)
TINY = {"rooms": 2, "detail": 0.25, "properties": 16}
#: the facts of the real restaurant (see the module docstring): about 3.3 M triangles, 92 % of them furniture
RESTAURANT = {"rooms": 14, "detail": 1.0, "properties": 128, "studs": 240, "window_bars": 160, "proxies": 2,
              "plaza_m": 110.0}
PROXY_TRIANGLES = 44_228  # a floor partition's, as the real file's
def _layout() -> list[tuple[str, float, float, float]]:
    items: list[tuple[str, float, float, float]] = []
    for tx, ty in ((1800, 1800), (4300, 1800), (1800, 4300), (4300, 4300)):  # round tables for four
        items.append(("round table", tx, ty, 0.0))
        for k in range(4):
            a = math.radians(45 + 90 * k)
            items.append(("chair", tx + 650 * math.cos(a), ty + 650 * math.sin(a), math.degrees(a) + 90))
    for ty in (1500, 4500):  # long tables for six
        items.append(("long table", 7300, ty, 90.0))
        for k in (-1, 0, 1):
            items.append(("chair", 6750, ty + 600 * k, -90.0))
            items.append(("chair", 7850, ty + 600 * k, 90.0))
    items += [("sofa", 4500, 6300, 180.0), ("plant", 500, 500, 0.0), ("plant", 8500, 6500, 0.0),
              ("bar stool", 3000, 3050, 0.0), ("bar stool", 6000, 3050, 0.0)]
    items += [("pendant lamp", x, y, 0.0) for x, y in ((1800, 1800), (4300, 1800), (1800, 4300), (4300, 4300))]
    return items


#: furniture of one room: (type, x, y, rotation in degrees), x and y in mm inside the room
ROOM_LAYOUT: list[tuple[str, float, float, float]] = _layout()


# ---------------------------------------------------------------- meshes of the faceted shells
def superellipsoid(radii: tuple[float, float, float], centre: tuple[float, float, float], nu: int, nv: int,
                   exponent: float = 0.35) -> tuple[np.ndarray, list[tuple[int, ...]]]:
    """A closed shell: ``nu`` segments around, ``nv`` from pole to pole; exponent < 1 makes it boxy
    (a cushion), 1 an ellipsoid. Quads between the rings, triangles at the poles."""
    def sgnpow(x: np.ndarray, e: float) -> np.ndarray:
        return np.sign(x) * np.abs(x) ** e

    u = np.arange(nu) * 2 * np.pi / nu
    v = np.arange(1, nv) * np.pi / nv - np.pi / 2  # latitudes strictly between the poles
    cu, su = np.cos(u), np.sin(u)
    cv, sv = np.cos(v), np.sin(v)
    x = sgnpow(cv[:, None], exponent) * sgnpow(cu[None, :], exponent)
    y = sgnpow(cv[:, None], exponent) * sgnpow(su[None, :], exponent)
    z = np.broadcast_to(sgnpow(sv[:, None], exponent), x.shape)
    rings = np.stack([x, y, z], axis=-1).reshape(-1, 3)
    verts = np.vstack([[0, 0, -1], rings, [0, 0, 1]]) * np.asarray(radii) + np.asarray(centre)
    south, north = 0, len(verts) - 1

    def ring(i: int, j: int) -> int:
        return 1 + i * nu + j % nu

    faces: list[tuple[int, ...]] = [(south, ring(0, j + 1), ring(0, j)) for j in range(nu)]
    for i in range(nv - 2):
        faces += [(ring(i, j), ring(i, j + 1), ring(i + 1, j + 1), ring(i + 1, j)) for j in range(nu)]
    faces += [(north, ring(nv - 2, j), ring(nv - 2, j + 1)) for j in range(nu)]
    return verts, faces


def partition_panel(size: tuple[float, float], depth: float, triangles: int, points: int = 21
                    ) -> tuple[np.ndarray, list[tuple[int, ...]]]:
    """A closed, folded floor panel: strips along y whose heights alternate (folds steeper than 30°), each strip's
    long edges carrying ``points`` collinear points, so each strip face triangulates into 2·points − 2 triangles;
    about ``triangles`` triangles in all."""
    per = 2 * points - 2
    n = max(2, round((triangles - 2 * per - 2) / (2 * per + 2)))
    xs, ys = np.linspace(0, size[0], n + 1), np.linspace(0, size[1], points)
    index: dict[tuple[float, float, float], int] = {}

    def v(x: float, y: float, z: float) -> int:
        return index.setdefault((round(float(x), 3), round(float(y), 3), round(float(z), 3)), len(index))

    def top(i: int) -> float:
        return depth * (1.0 + 0.5 * (i % 2))

    faces: list[tuple[int, ...]] = []
    for i in range(n):
        a, b = [v(xs[i], y, top(i)) for y in ys], [v(xs[i + 1], y, top(i + 1)) for y in ys]
        faces.append(tuple(a + b[::-1]))
        a, b = [v(xs[i], y, 0.0) for y in ys], [v(xs[i + 1], y, 0.0) for y in ys]
        faces.append(tuple(b + a[::-1]))
    for y, turn in ((0.0, 1), (size[1], -1)):
        ring = [v(x, y, top(i)) for i, x in enumerate(xs)] + [v(size[0], y, 0.0), v(0.0, y, 0.0)]
        faces.append(tuple(ring[::turn]))
    for i, x, turn in ((0, 0.0, -1), (n, size[0], 1)):
        ring = [v(x, y, top(i)) for y in ys] + [v(x, y, 0.0) for y in ys[::-1]]
        faces.append(tuple(ring[::turn]))
    return np.array(list(index)), faces


def box(lo: tuple[float, float, float], hi: tuple[float, float, float]) -> tuple[np.ndarray, list[tuple[int, ...]]]:
    x0, y0, z0 = lo
    x1, y1, z1 = hi
    verts = np.array([[x0, y0, z0], [x1, y0, z0], [x1, y1, z0], [x0, y1, z0],
                      [x0, y0, z1], [x1, y0, z1], [x1, y1, z1], [x0, y1, z1]])
    faces = [(0, 3, 2, 1), (4, 5, 6, 7), (0, 1, 5, 4), (1, 2, 6, 5), (2, 3, 7, 6), (3, 0, 4, 7)]
    return verts, faces


# ---------------------------------------------------------------- the writer
class _Writer:
    """The file being written and the entities every element shares."""

    def __init__(self, seed: int, schema: str = "IFC2X3") -> None:
        import ifcopenshell

        self.rng = np.random.default_rng(seed)
        self.f = f = ifcopenshell.file(schema=schema)
        person = f.createIfcPerson(None, "Architect", None, None, None, None, None, None)
        org = f.createIfcOrganization(None, "Generated", None, None, None)
        app = f.createIfcApplication(org, "2012", "Autodesk Revit Architecture 2012", "Revit")
        self.history = f.createIfcOwnerHistory(f.createIfcPersonAndOrganization(person, org, None), app, None,
                                               "ADDED", None, None, None, 1300000000)
        self.origin3 = self.point(0, 0, 0)
        self.z = self.direction(0, 0, 1)
        self.x = self.direction(1, 0, 0)
        self.identity = f.createIfcAxis2Placement3D(self.origin3, None, None)
        self.centre2 = f.createIfcAxis2Placement2D(self.point(0, 0), None)  # IFC2X3 profiles need a Position
        self.identity_op = f.createIfcCartesianTransformationOperator3D(None, None, self.origin3, None, None)
        self.n_elements = 0
        self.n_properties = 0

    def guid(self) -> str:
        import ifcopenshell.guid

        return ifcopenshell.guid.compress(uuid.UUID(bytes=self.rng.bytes(16)).hex)

    def point(self, x: float, y: float, z: float | None = None):
        coords = (float(x), float(y)) if z is None else (float(x), float(y), float(z))
        return self.f.createIfcCartesianPoint(coords)

    def direction(self, x: float, y: float, z: float):
        return self.f.createIfcDirection((float(x), float(y), float(z)))

    def placement(self, relative_to, x: float = 0.0, y: float = 0.0, z: float = 0.0, angle_deg: float = 0.0):
        ref = None
        if angle_deg:
            a = math.radians(angle_deg)
            ref = self.direction(round(math.cos(a), 12), round(math.sin(a), 12), 0.0)
        axes = self.f.createIfcAxis2Placement3D(self.point(x, y, z), self.z if ref is not None else None, ref)
        return self.f.createIfcLocalPlacement(relative_to, axes)

    def root(self, ifc_class: str, name: str, **attributes):
        return self.f.create_entity(ifc_class, GlobalId=self.guid(), OwnerHistory=self.history, Name=name, **attributes)

    # geometry
    def brep(self, verts: np.ndarray, faces: list[tuple[int, ...]]):
        pts = [self.point(*p) for p in np.round(verts, 3)]
        f = self.f
        ifc_faces = [f.createIfcFace([f.createIfcFaceOuterBound(f.createIfcPolyLoop([pts[i] for i in q]), True)])
                     for q in faces]
        return f.createIfcFacetedBrep(f.createIfcClosedShell(ifc_faces))

    def cylinder(self, radius: float, height: float, x: float = 0.0, y: float = 0.0, z: float = 0.0):
        profile = self.f.createIfcCircleProfileDef("AREA", None, self.centre2, float(radius))
        position = self.f.createIfcAxis2Placement3D(self.point(x, y, z), None, None)
        return self.f.createIfcExtrudedAreaSolid(profile, position, self.z, float(height))

    def block(self, lo: tuple[float, float, float], hi: tuple[float, float, float]):
        """An axis-aligned box as an extruded rectangle (swept solid, exact)."""
        (x0, y0, z0), (x1, y1, z1) = lo, hi
        centre = self.f.createIfcAxis2Placement2D(self.point((x0 + x1) / 2, (y0 + y1) / 2), None)
        profile = self.f.createIfcRectangleProfileDef("AREA", None, centre, float(x1 - x0), float(y1 - y0))
        position = self.f.createIfcAxis2Placement3D(self.point(0, 0, z0), None, None)
        return self.f.createIfcExtrudedAreaSolid(profile, position, self.z, float(z1 - z0))

    def shape(self, context, kind: str, items: list, identifier: str = "Body"):
        return self.f.createIfcShapeRepresentation(context, identifier, kind, items)

    def properties(self, product, count: int, prefix: str) -> None:
        """``count`` single values in property sets of up to 16, like Revit's parameter groups."""
        f = self.f
        groups = ("Constraints", "Dimensions", "Identity Data", "Phasing", "Other", "Materials and Finishes",
                  "Construction", "Graphics", "Analytical Properties", "General")
        for g in range((count + 15) // 16):
            props = []
            for k in range(min(16, count - 16 * g)):
                n = 16 * g + k
                if n % 3 == 0:
                    value = f.createIfcLengthMeasure(float(self.rng.uniform(0, 5000)))
                elif n % 3 == 1:
                    value = f.createIfcLabel(f"{prefix} value {n}")
                else:
                    value = f.createIfcBoolean(bool(n % 2))
                props.append(f.createIfcPropertySingleValue(f"{groups[g % len(groups)]} parameter {k}", None, value, None))
            pset = f.createIfcPropertySet(self.guid(), self.history, groups[g % len(groups)], None, props)
            f.createIfcRelDefinesByProperties(self.guid(), self.history, None, None, [product], pset)
            self.n_properties += len(props)


def write_revit_like_ifc(path: str | Path, *, rooms: int = 32, detail: float = 1.0, properties: int = 128,
                         seed: int = 0, studs: int = 0, window_bars: int = 0, proxies: int = 0,
                         plaza_m: float = 0.0) -> dict:
    """Write the model to ``path`` (see the module docstring); returns its counts: elements,
    by_class, furniture types, rooms, storeys, entities, bytes, write_s."""
    t0 = time.perf_counter()
    w = _Writer(seed)
    f = w.f
    rooms = max(1, int(rooms))
    storeys = math.ceil(rooms / ROOMS_PER_STOREY)

    def res(n: int) -> int:
        return max(6, int(round(n * math.sqrt(detail))))

    project = w.root("IfcProject", "Restaurant", LongName="Generated restaurant", Phase="Project Phase")
    length = f.createIfcSIUnit(None, "LENGTHUNIT", "MILLI", "METRE")
    area = f.createIfcSIUnit(None, "AREAUNIT", None, "SQUARE_METRE")
    volume = f.createIfcSIUnit(None, "VOLUMEUNIT", None, "CUBIC_METRE")
    angle = f.createIfcSIUnit(None, "PLANEANGLEUNIT", None, "RADIAN")
    project.UnitsInContext = f.createIfcUnitAssignment([length, area, volume, angle])
    model = f.createIfcGeometricRepresentationContext(None, "Model", 3, 0.01, w.identity,
                                                      f.createIfcDirection((0.0, 1.0)))
    body = f.createIfcGeometricRepresentationSubContext("Body", "Model", None, None, None, None, model, None,
                                                        "MODEL_VIEW", None)
    axis_ctx = f.createIfcGeometricRepresentationSubContext("Axis", "Model", None, None, None, None, model, None,
                                                            "GRAPH_VIEW", None)
    project.RepresentationContexts = [model]
    site = w.root("IfcSite", "Surface", ObjectPlacement=w.placement(None), CompositionType="ELEMENT",
                  RefLatitude=(52, 5, 0), RefLongitude=(5, 7, 0), RefElevation=0.0)
    building = w.root("IfcBuilding", "Restaurant", ObjectPlacement=w.placement(site.ObjectPlacement),
                      CompositionType="ELEMENT")
    f.createIfcRelAggregates(w.guid(), w.history, None, None, project, [site])
    f.createIfcRelAggregates(w.guid(), w.history, None, None, site, [building])

    # ---- types: one representation map per family, shared by every occurrence
    def rep_map(items: list, kind: str):
        return f.createIfcRepresentationMap(w.identity, w.shape(body, kind, items))

    legs = [w.cylinder(15, 430, x, y) for x in (-190, 190) for y in (-190, 190)]
    families: dict[str, list] = {
        "chair": [w.brep(*superellipsoid((230, 230, 30), (0, 0, 450), res(32), res(16))),
                  w.brep(*superellipsoid((220, 25, 220), (0, 210, 720), res(32), res(16))), *legs],
        "round table": [w.cylinder(450, 30, z=720), w.cylinder(40, 690, z=30), w.cylinder(250, 30)],
        "long table": [f.createIfcBooleanClippingResult(
            "DIFFERENCE", w.block((-900, -450, 720), (900, 450, 750)),
            f.createIfcHalfSpaceSolid(f.createIfcPlane(f.createIfcAxis2Placement3D(
                w.point(850, 400, 735), w.direction(0.7071, 0.7071, 0.0), None)), False)),
            *[w.cylinder(25, 720, x, y) for x in (-820, 820) for y in (-370, 370)]],
        "sofa": [w.brep(*superellipsoid((1000, 420, 200), (0, 0, 220), res(48), res(24))),
                 w.brep(*superellipsoid((1000, 120, 300), (0, 330, 600), res(48), res(24))),
                 w.brep(*superellipsoid((100, 400, 250), (-950, 0, 500), res(24), res(16))),
                 w.brep(*superellipsoid((100, 400, 250), (950, 0, 500), res(24), res(16)))],
        "plant": [w.cylinder(200, 400), w.brep(*superellipsoid((450, 450, 600), (0, 0, 1000), res(64), res(32), 1.0))],
        "bar stool": [w.cylinder(180, 60, z=720), w.cylinder(25, 700, z=20), w.cylinder(220, 20)],
        "pendant lamp": [w.brep(*superellipsoid((300, 300, 180), (0, 0, 2400), res(48), res(24), 0.8)),
                         w.cylinder(3, 600, z=2580)],
    }
    def stud_boxes(n: int, lo: tuple[float, float], hi: tuple[float, float], z: float) -> list:
        """``n`` 12 mm boxes in a grid over lo…hi at height z, apart from each other: 12 triangles, 8 corners each."""
        side = max(1, math.ceil(math.sqrt(n)))
        out = []
        for k in range(n):
            x = lo[0] + (hi[0] - lo[0]) * ((k % side) + 0.5) / side
            y = lo[1] + (hi[1] - lo[1]) * ((k // side) + 0.5) / side
            out.append(w.brep(*box((x - 6, y - 6, z), (x + 6, y + 6, z + 12))))
        return out

    if studs:
        spots = {"chair": ((-200, -200), (200, 200), 480), "round table": ((-400, -400), (400, 400), 750),
                 "long table": ((-850, -400), (850, 400), 750), "sofa": ((-950, -380), (950, 380), 420),
                 "plant": ((-180, -180), (180, 180), 400), "bar stool": ((-150, -150), (150, 150), 780),
                 "pendant lamp": ((-250, -250), (250, 250), 2200)}
        for name, (lo, hi, z) in spots.items():
            families[name] = families[name] + stud_boxes(studs, lo, hi, z)
    brep_only = ("chair", "sofa", "plant", "pendant lamp")
    maps = {name: rep_map(items, "Brep" if name in brep_only else "SolidModel" if studs else "SweptSolid")
            for name, items in families.items()}
    types = {name: w.root("IfcFurnitureType", name.title(), RepresentationMaps=[m], ElementType=name.title(),
                          AssemblyPlace="FACTORY") for name, m in maps.items()}
    door_map = rep_map([w.brep(*box((0, -60, 0), (60, 60, 2100))), w.brep(*box((940, -60, 0), (1000, 60, 2100))),
                        w.brep(*box((60, -60, 2040), (940, 60, 2100))), w.block((70, -20, 0), (930, 20, 2030)),
                        f.createIfcExtrudedAreaSolid(f.createIfcCircleProfileDef("AREA", None, w.centre2, 10.0),
                                                     f.createIfcAxis2Placement3D(w.point(850, -20, 1000),
                                                                                 w.direction(0, -1, 0), None),
                                                     w.z, 60.0)], "Brep")
    window_map = rep_map([w.brep(*box((0, -50, 0), (1200, 50, 60))), w.brep(*box((0, -50, 1440), (1200, 50, 1500))),
                          w.brep(*box((0, -50, 60), (60, 50, 1440))), w.brep(*box((1140, -50, 60), (1200, 50, 1440))),
                          w.block((60, -6, 60), (1140, 6, 1440)),
                          *[w.brep(*box((60 + 1080 * (k + 0.5) / window_bars - 4, -10, 60),
                                        (60 + 1080 * (k + 0.5) / window_bars + 4, -6, 1440)))
                            for k in range(window_bars)]], "Brep")
    door_type = w.root("IfcDoorStyle", "Single-Flush 1000 x 2100", OperationType="SINGLE_SWING_LEFT",
                       ConstructionType="WOOD", ParameterTakesPrecedence=False, Sizeable=False,
                       RepresentationMaps=[door_map])
    window_type = w.root("IfcWindowStyle", "Fixed 1200 x 1500", ConstructionType="WOOD", OperationType="SINGLE_PANEL",
                         ParameterTakesPrecedence=False, Sizeable=False, RepresentationMaps=[window_map])
    occurrences: dict = {t: [] for t in [*types.values(), door_type, window_type]}
    by_class: dict[str, int] = {}
    wall_profiles: dict[float, object] = {}

    def element(ifc_class: str, name: str, where, reps: list, storey_products: list, **attributes):
        product = w.root(ifc_class, name, ObjectPlacement=where,
                         Representation=f.createIfcProductDefinitionShape(None, None, reps), **attributes)
        if ifc_class != "IfcOpeningElement":
            w.properties(product, properties, name)
        if ifc_class not in ("IfcOpeningElement", "IfcSpace"):  # the products that become scene elements
            storey_products.append(product)
            by_class[ifc_class] = by_class.get(ifc_class, 0) + 1
            w.n_elements += 1
        return product

    def mapped(m):
        return w.shape(body, "MappedRepresentation", [f.createIfcMappedItem(m, w.identity_op)])

    for s in range(storeys):
        storey = w.root("IfcBuildingStorey", f"Level {s + 1}", Elevation=s * STOREY_H, CompositionType="ELEMENT",
                        ObjectPlacement=w.placement(building.ObjectPlacement, 0, 0, s * STOREY_H))
        f.createIfcRelAggregates(w.guid(), w.history, None, None, building, [storey])
        here: list = []
        spaces: list = []
        sp = storey.ObjectPlacement
        for r in range(min(ROOMS_PER_STOREY, rooms - s * ROOMS_PER_STOREY)):
            ox, oy = (r % 4) * PITCH_X, (r // 4) * PITCH_Y
            tag = f"{s + 1}.{r + 1:02d}"
            spaces.append(element("IfcSpace", tag, w.placement(sp, ox, oy),
                                  [w.shape(body, "SweptSolid", [w.block((0, 0, 0), (ROOM_W, ROOM_D, WALL_H))])],
                                  [], LongName=f"Dining {tag}", CompositionType="ELEMENT",
                                  InteriorOrExteriorSpace="INTERNAL"))
            # walls counter-clockwise, the room on their left (+Y)
            for k, (x, y, ang, length_mm) in enumerate(((ox, oy, 0, ROOM_W), (ox + ROOM_W, oy, 90, ROOM_D),
                                                        (ox + ROOM_W, oy + ROOM_D, 180, ROOM_W),
                                                        (ox, oy + ROOM_D, 270, ROOM_D))):
                where = w.placement(sp, x, y, 0, ang)
                if length_mm not in wall_profiles:
                    centre = f.createIfcAxis2Placement2D(w.point(length_mm / 2, 0), None)
                    wall_profiles[length_mm] = f.createIfcRectangleProfileDef("AREA", None, centre, length_mm, WALL_T)
                solid = f.createIfcExtrudedAreaSolid(wall_profiles[length_mm], w.identity, w.z, WALL_H)
                axis = w.shape(axis_ctx, "Curve2D", [f.createIfcPolyline([w.point(0, 0), w.point(length_mm, 0)])], "Axis")
                wall = element("IfcWallStandardCase", f"Basic Wall:Interior 200mm:{tag}.{k}", where,
                               [axis, w.shape(body, "SweptSolid", [solid])], here)
                # a door in the first wall, two windows in the others
                fillings = [("door", 0.25 * length_mm, 0.0, 1000.0, 2100.0)] if k == 0 else [
                    ("window", length_mm * q - 600, 900.0, 1200.0, 1500.0) for q in (0.3, 0.7)]
                for kind, at, sill, width, height in fillings:
                    opening_at = w.placement(where, at, 0, sill)
                    cut = f.createIfcExtrudedAreaSolid(
                        f.createIfcRectangleProfileDef("AREA", None, f.createIfcAxis2Placement2D(
                            w.point(width / 2, -height / 2), None), width, height),
                        f.createIfcAxis2Placement3D(w.point(0, -WALL_T / 2 - 10, 0), w.direction(0, 1, 0), w.x),
                        w.z, WALL_T + 20)
                    opening = element("IfcOpeningElement", f"Opening {tag}.{k}", opening_at,
                                      [w.shape(body, "SweptSolid", [cut])], here)
                    f.createIfcRelVoidsElement(w.guid(), w.history, None, None, wall, opening)
                    if kind == "door":
                        filler = element("IfcDoor", f"Single-Flush:1000 x 2100:{tag}.{k}", w.placement(opening_at),
                                         [mapped(door_map)], here, OverallHeight=2100.0, OverallWidth=1000.0)
                        occurrences[door_type].append(filler)
                    else:
                        filler = element("IfcWindow", f"Fixed:1200 x 1500:{tag}.{k}", w.placement(opening_at),
                                         [mapped(window_map)], here, OverallHeight=1500.0, OverallWidth=1200.0)
                        occurrences[window_type].append(filler)
                    f.createIfcRelFillsElement(w.guid(), w.history, None, None, opening, filler)
            element("IfcSlab", f"Floor:Generic 250mm:{tag}", w.placement(sp, ox, oy, -SLAB_T),
                    [w.shape(body, "SweptSolid", [w.block((0, 0, 0), (ROOM_W, ROOM_D, SLAB_T))])], here,
                    PredefinedType="FLOOR")
            for cx, cy in ((ox + 300, oy + 300), (ox + ROOM_W - 300, oy + ROOM_D - 300)):
                element("IfcColumn", f"Round Column:400mm:{tag}", w.placement(sp, cx, cy),
                        [w.shape(body, "SweptSolid", [w.cylinder(200, WALL_H)])], here)
            for n, (family, x, y, rot) in enumerate(ROOM_LAYOUT):
                jitter = w.rng.uniform(-40, 40, 2)
                item = element("IfcFurnishingElement", f"{family.title()}:{tag}.{n:02d}",
                               w.placement(sp, ox + x + jitter[0], oy + y + jitter[1], 0, rot + w.rng.uniform(-5, 5)),
                               [mapped(maps[family])], here)
                occurrences[types[family]].append(item)
        if s == 0 and plaza_m > 0:  # a building pad under everything
            half = 500.0 * plaza_m
            element("IfcSlab", "Pad:Plaza", w.placement(sp, 2 * PITCH_X, 1.5 * PITCH_Y, -SLAB_T - 300.0),
                    [w.shape(body, "SweptSolid", [w.block((-half, -half, 0), (half, half, 300.0))])], here,
                    PredefinedType="BASESLAB")
        for k in range(proxies if s == 0 else 0):  # heavy floor partitions, each with a shell of its own
            panel = w.brep(*partition_panel((3000.0, 2000.0), 40.0, PROXY_TRIANGLES))
            element("IfcBuildingElementProxy", f"Floor partition:{k + 1}", w.placement(sp, 600 + 3500 * k, 600, 0),
                    [w.shape(body, "Brep", [panel])], here)
        f.createIfcRelContainedInSpatialStructure(w.guid(), w.history, None, None, here, storey)
        f.createIfcRelAggregates(w.guid(), w.history, None, None, storey, spaces)
    for type_, products in occurrences.items():
        if products:
            f.createIfcRelDefinesByType(w.guid(), w.history, None, None, products, type_)
    path = Path(path)
    f.write(str(path))
    return {"elements": w.n_elements, "by_class": dict(sorted(by_class.items())), "furniture_types": len(types),
            "rooms": rooms, "storeys": storeys, "properties": w.n_properties, "entities": len(list(f)),
            "bytes": path.stat().st_size, "write_s": time.perf_counter() - t0}


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("path", nargs="?", default="revit_like.ifc")
    ap.add_argument("--rooms", type=int, default=32, help="rooms, 12 per storey (default 32)")
    ap.add_argument("--detail", type=float, default=1.0, help="faces of the faceted shells, relative (default 1)")
    ap.add_argument("--properties", type=int, default=128, help="property values per element (default 128)")
    ap.add_argument("--seed", type=int, default=0)
    ap.add_argument("--studs", type=int, default=0, help="small boxes in every furniture family (default 0)")
    ap.add_argument("--window-bars", type=int, default=0, help="glazing bars in the window type (default 0)")
    ap.add_argument("--proxies", type=int, default=0, help="heavy, unshared floor partitions (default 0)")
    ap.add_argument("--plaza", type=float, default=0.0, help="side of a building pad around it, metres (default 0)")
    ap.add_argument("--tiny", action="store_true", help=f"the test model: {TINY}")
    ap.add_argument("--restaurant", action="store_true", help=f"the real restaurant's facts: {RESTAURANT}")
    args = ap.parse_args(argv)
    options = TINY if args.tiny else RESTAURANT if args.restaurant else {
        "rooms": args.rooms, "detail": args.detail, "properties": args.properties, "studs": args.studs,
        "window_bars": args.window_bars, "proxies": args.proxies, "plaza_m": args.plaza}
    info = write_revit_like_ifc(args.path, seed=args.seed, **options)
    print(f"{args.path}: {info['bytes'] / 2**20:.1f} MB, {info['entities']:,} entities, {info['elements']:,} elements "
          f"({', '.join(f'{k} {v}' for k, v in info['by_class'].items())}), written in {info['write_s']:.1f} s")
    return 0


if __name__ == "__main__":
    sys.exit(main())


def generated(path: Path, **options) -> tuple[Path, dict]:
    """The model :func:`write_revit_like_ifc` writes for ``options`` at ``path``, written once (its facts beside it in
    a .json) and reused by later runs."""
    import json
    import os

    meta = path.with_suffix(".json")
    if path.is_file() and meta.is_file():
        return path, json.loads(meta.read_text())
    tmp = path.with_suffix(".tmp.ifc")
    info = write_revit_like_ifc(tmp, **options)
    os.replace(tmp, path)
    meta.write_text(json.dumps(info))
    return path, info

