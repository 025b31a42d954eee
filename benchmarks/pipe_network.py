"""A generated IFC of a heating network, shaped like BlenderBIM and Revit MEP exports (the tie search's hard case).

`python benchmarks/pipe_network.py [PATH] [--storeys N] [--bays N] [--schema IFC4|IFC2X3]` writes one and prints its
size; :func:`write_pipes_ifc` is the same from Python (tests use :data:`SMALL`, the benchmark :data:`BIG`).

What real MEP exports of heating and plumbing look like, and what this file reproduces:

- pipe segments are extrusions of their profile along their own axis, one solid per segment (IfcPipeSegment in IFC4,
  IfcFlowSegment typed by an IfcPipeSegmentType in IFC2X3): most of a polygon of 12 to 32 sides, some of an
  IfcCircleProfileDef that the geometry kernel facets itself (its facet count, not the file's);
- fittings, valves and heaters are type meshes shared by their occurrences (an IfcRepresentationMap per type, each
  occurrence an IfcMappedItem with its own placement): elbows (IfcPipeFitting BEND, 90° and 45°, a faceted bend),
  tees (JUNCTION), couplings (CONNECTOR), isolating and radiator valves (IfcValve) and panel radiators
  (IfcSpaceHeater); in IFC2X3 IfcFlowFitting, IfcFlowController and IfcEnergyConversionDevice with their types;
- **flush faces** where they join: each segment ends in the plane of the port of the fitting or valve it meets (its
  end face lies on the fitting's, another polygon), and two segments joined by a coupling end on each other;
  couplings and valves carry sleeves at the pipe's radius plus 0.1–0.6 mm over the segment ends, with another facet
  count or turned by the occurrence's placement, so flush facets' normals differ by hundredths of a degree to over
  ten degrees; the fittings' placements carry up to 0.02° of rounding tilt, as exported matrices do; drop pipes end
  on the radiators' top covers (within 0.3 mm), the radiators hang with their backs 0.3 mm off the wall face, and
  the walls stand flush on the slabs;
- a supply and a return network per storey: risers in a corner (a tee at each storey, couplings at the slabs),
  mains along the walls under the ceiling (elbows at the corners, one corner cut by two 45° elbows, couplings
  every 6 m at most, an isolating valve), and per radiator a tee on each main, a branch to the wall, an elbow, a
  drop with a radiator valve, and the radiator; the walls and a slab of every storey for context.

``storeys`` and ``bays`` (radiators per 3 m bay of the long walls) scale it. :data:`SMALL` (1 storey, 1 bay: 63
elements, 8,128 triangles once tessellated, 4,105 of them flush with another element's) is for tests that compare
the tie search with a brute force; :data:`BIG` (4 storeys, 20 bays: 3,082 elements, 192 radiators, 395,016
triangles, 3.0 MB, written in about 6 s) for the benchmark.
"""

from __future__ import annotations

import argparse
import math
import sys
import time
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))
from revit_like import _Writer, box  # noqa: E402  (the IFC helpers of the Revit-like model)

#: a model for tests (8,128 triangles)
SMALL = {"storeys": 1, "bays": 1}
#: the benchmark's model (395,016 triangles)
BIG = {"storeys": 4, "bays": 20}
STOREY_H, SLAB_T, WALL_T = 3500.0, 250.0, 200.0  # mm
BAY = 3000.0  # one radiator per bay of wall
SEGMENT_MAX = 6000.0  # longest segment; longer legs are joined by couplings
SUPPLY_INSET, RETURN_INSET = 300.0, 500.0  # mains' axes from the wall faces
SUPPLY_Z, RETURN_Z = 3000.0, 2800.0  # mains' axes above the storey's floor
HEATER_Z, HEATER_H, HEATER_T = 250.0, 600.0, 100.0  # a radiator's bottom, height and depth
TILT_DEG = 0.02  # largest rounding tilt of an occurrence's placement

# the network's pipe classes: (name, outer radius mm, sides of the segments' profile or 0 for a circle the kernel
# facets, sides of the fittings' meshes, how far their sleeves stand off the pipe's radius in mm)
RISER = ("DN50", 30.15, 32, 32, 0.15)
RISER_RETURN = ("DN50c", 30.15, 0, 28, 0.5)
SUPPLY = ("DN32", 21.2, 24, 23, 0.4)
RETURN = ("DN32c", 21.2, 0, 24, 0.25)
BRANCH = ("DN15", 10.65, 16, 16, 0.55)
BRANCH_RETURN = ("DN15b", 10.65, 12, 13, 0.1)


# ---------------------------------------------------------------- type meshes (mm, local: z along the pipe)
def ring(r: float, sides: int, phase: float = 0.0) -> np.ndarray:
    a = phase + 2 * np.pi * np.arange(sides) / sides
    return np.stack([r * np.cos(a), r * np.sin(a)], axis=1)


def prism(r: float, sides: int, z0: float, z1: float, phase: float = 0.0) -> tuple[np.ndarray, list[tuple[int, ...]]]:
    """A closed faceted cylinder along z: ``sides`` quads and two polygon ends."""
    xy = ring(r, sides, phase)
    verts = np.concatenate([np.c_[xy, np.full(sides, z0)], np.c_[xy, np.full(sides, z1)]])
    k = np.arange(sides)
    faces: list[tuple[int, ...]] = [(int(a), int((a + 1) % sides), int((a + 1) % sides + sides), int(a + sides))
                                    for a in k]
    faces += [tuple(int(a) for a in k[::-1]), tuple(int(a + sides) for a in k)]
    return verts, faces


def turned(mesh: tuple[np.ndarray, list], matrix: np.ndarray, at=(0.0, 0.0, 0.0)) -> tuple[np.ndarray, list]:
    return mesh[0] @ np.asarray(matrix).T + np.asarray(at), mesh[1]


Z_TO_X = np.array([[0.0, 0.0, 1.0], [0.0, 1.0, 0.0], [-1.0, 0.0, 0.0]])  # turns the z axis onto x


def bend(r: float, sides: int, radius: float, angle: float, steps: int) -> tuple[np.ndarray, list]:
    """A faceted bend: the port ring at the origin (in the xy plane, leaving along +z) swept by ``angle`` about the
    axis through (radius, 0, 0) along y; the second port leaves along (sin angle, 0, cos angle)."""
    xy = ring(r, sides)
    rings = []
    for k in range(steps + 1):
        psi = angle * k / steps
        x = radius - (radius - xy[:, 0]) * math.cos(psi)
        z = (radius - xy[:, 0]) * math.sin(psi)
        rings.append(np.c_[x, xy[:, 1], z])
    verts = np.concatenate(rings)
    faces: list[tuple[int, ...]] = []
    for k in range(steps):
        for j in range(sides):
            a, b = k * sides + j, k * sides + (j + 1) % sides
            faces.append((a, b, b + sides, a + sides))
    faces += [tuple(range(sides)[::-1]), tuple(steps * sides + j for j in range(sides))]
    return verts, faces


def bend_reach(radius: float, angle: float) -> float:
    """How far a bend's ports lie from the corner of the two axes."""
    return radius * math.tan(angle / 2)


# ---------------------------------------------------------------- the writer
class _Network:
    def __init__(self, schema: str, seed: int) -> None:
        self.w = w = _Writer(seed, schema)
        self.f = f = w.f
        self.ifc4 = schema != "IFC2X3"
        app = w.history.OwningApplication
        app.ApplicationFullName, app.ApplicationIdentifier, app.Version = "BlenderBIM Add-on", "BlenderBIM", "0.7"
        self.project = w.root("IfcProject", "Heating")
        units = [f.createIfcSIUnit(None, "LENGTHUNIT", "MILLI", "METRE"),
                 f.createIfcSIUnit(None, "PLANEANGLEUNIT", None, "RADIAN")]
        self.project.UnitsInContext = f.createIfcUnitAssignment(units)
        model = f.createIfcGeometricRepresentationContext(None, "Model", 3, 1e-5, w.identity, None)
        self.body = f.createIfcGeometricRepresentationSubContext("Body", "Model", None, None, None, None, model, None,
                                                                 "MODEL_VIEW", None)
        self.project.RepresentationContexts = [model]
        self.rng = np.random.default_rng(seed + 1)
        self.types: dict[tuple, tuple] = {}  # key -> (type entity, representation map)
        self.occurrences: dict = {}
        self.by_class: dict[str, int] = {}
        self.here: list = []
        self.storey_placement = None

    # -- placements
    def frame(self, origin, z_axis, x_axis, tilt: bool = True):
        """A local placement at ``origin`` (world mm) with the given axes, turned by up to TILT_DEG when ``tilt``."""
        z = np.asarray(z_axis, float) / np.linalg.norm(z_axis)
        x = np.asarray(x_axis, float) - np.dot(x_axis, z) * z
        x /= np.linalg.norm(x)
        if tilt:
            axis = self.rng.normal(size=3)
            axis /= np.linalg.norm(axis)
            t = math.radians(self.rng.uniform(0, TILT_DEG))
            k = np.array([[0, -axis[2], axis[1]], [axis[2], 0, -axis[0]], [-axis[1], axis[0], 0]])
            rot = np.eye(3) + math.sin(t) * k + (1 - math.cos(t)) * k @ k
            z, x = rot @ z, rot @ x
        w = self.w
        axes = self.f.createIfcAxis2Placement3D(w.point(*origin), w.direction(*z), w.direction(*x))
        return self.f.createIfcLocalPlacement(self.storey_placement, axes)

    # -- elements
    def element(self, ifc4_class: str, ifc2x3_class: str, name: str, placement, items: list, kind: str,
                predefined: str | None = None):
        ifc_class = ifc4_class if self.ifc4 else ifc2x3_class
        extra = {"PredefinedType": predefined} if self.ifc4 and predefined else {}
        rep = self.f.createIfcShapeRepresentation(self.body, "Body", kind, items)
        product = self.w.root(ifc_class, name, ObjectPlacement=placement,
                              Representation=self.f.createIfcProductDefinitionShape(None, None, [rep]), **extra)
        self.here.append(product)
        self.by_class[ifc_class] = self.by_class.get(ifc_class, 0) + 1
        self.w.n_elements += 1
        return product

    def type_of(self, key: tuple, type_class: str, name: str, predefined: str, meshes=None):
        """The type ``key`` (made once): its entity and, for ``meshes``, the representation map they form."""
        if key not in self.types:
            rep_map = None
            if meshes is not None:
                items = [self.w.brep(*m) for m in meshes]
                rep_map = self.f.createIfcRepresentationMap(self.w.identity, self.f.createIfcShapeRepresentation(
                    self.body, "Body", "Brep", items))
            t = self.w.root(type_class, name, PredefinedType=predefined,
                            RepresentationMaps=[rep_map] if rep_map else None)
            self.types[key] = (t, rep_map)
            self.occurrences[t] = []
        return self.types[key]

    def typed(self, product, type_entity) -> None:
        self.occurrences[type_entity].append(product)

    def mapped(self, ifc4_class, ifc2x3_class, name, placement, key, type_class, predefined, meshes):
        t, rep_map = self.type_of(key, type_class, f"{key[0]} {key[1]}", predefined, meshes)
        item = self.f.createIfcMappedItem(rep_map, self.w.identity_op)
        product = self.element(ifc4_class, ifc2x3_class, name, placement, [item], "MappedRepresentation", predefined)
        self.typed(product, t)
        return product

    def segment(self, spec, start, direction, ref, length: float, phase: float) -> None:
        name, r, sides = spec[:3]
        f, w = self.f, self.w
        if sides:
            pts = [w.point(*p) for p in np.round(ring(r, sides, phase), 4)]
            profile = f.createIfcArbitraryClosedProfileDef("AREA", None, f.createIfcPolyline(pts + pts[:1]))
        else:
            profile = f.createIfcCircleProfileDef("AREA", None, w.centre2, r)
        solid = f.createIfcExtrudedAreaSolid(profile, w.identity, w.z, float(length))
        product = self.element("IfcPipeSegment", "IfcFlowSegment", f"Pipe {name}", self.frame(start, direction, ref,
                                                                                               tilt=False),
                               [solid], "SweptSolid", "RIGIDSEGMENT")
        self.typed(product, self.type_of(("segment", name), "IfcPipeSegmentType", f"Pipe {name}", "RIGIDSEGMENT")[0])

    # -- fittings: meshes in the fitting's frame (z along the run)
    def coupling(self, spec, centre, direction, ref) -> None:
        """A sleeve over two segments' ends, which meet at ``centre``."""
        _, r, _, m, gap = spec
        self.mapped("IfcPipeFitting", "IfcFlowFitting", f"Coupling {spec[0]}", self.frame(centre, direction, ref),
                    ("coupling", spec[0]), "IfcPipeFittingType", "CONNECTOR", [prism(r + gap, m, -2.5 * r, 2.5 * r)])

    def valve(self, spec, centre, direction, stem, kind: str) -> float:
        """An inline valve: a body whose end faces the segments meet, sleeves over them, a stem and a handwheel.
        Returns the body's half-length (where the segments end)."""
        _, r, _, m, gap = spec
        half = 2.0 * r
        up = turned(prism(0.35 * r, 12, 0.0, 2.6 * r), Z_TO_X)
        wheel = turned(prism(1.4 * r, 20, 2.6 * r, 2.9 * r), Z_TO_X)
        meshes = [prism(1.5 * r, m + 4, -half, half, 0.1), up, wheel,
                  prism(r + gap, m, half, half + 1.5 * r, 0.05), prism(r + gap, m, -half - 1.5 * r, -half, 0.05)]
        self.mapped("IfcValve", "IfcFlowController", f"{kind.title()} valve {spec[0]}",
                    self.frame(centre, direction, stem), ("valve", spec[0], kind), "IfcValveType", "ISOLATING", meshes)
        return half

    def tee(self, spec, branch_spec, centre, direction, branch_dir) -> tuple[float, float]:
        """A tee: a body along the run, a stub along ``branch_dir``. Returns (half-length along the run, stub
        length)."""
        _, r, _, m, _ = spec
        half, stub = branch_spec[1] + 20.0, r + 30.0
        meshes = [prism(r, m, -half, half, math.pi / m), turned(prism(branch_spec[1], branch_spec[3], 0.0, stub),
                                                               Z_TO_X)]
        self.mapped("IfcPipeFitting", "IfcFlowFitting", f"Tee {spec[0]}/{branch_spec[0]}",
                    self.frame(centre, direction, branch_dir), ("tee", spec[0], branch_spec[0]), "IfcPipeFittingType",
                    "JUNCTION", meshes)
        return half, stub

    def elbow(self, spec, corner, d1, d2) -> float:
        """A bend at ``corner`` from direction d1 to d2. Returns how far its ports lie from the corner."""
        _, r, _, m, _ = spec
        angle = math.acos(max(-1.0, min(1.0, float(np.dot(d1, d2)))))
        radius = 3.0 * r
        reach = bend_reach(radius, angle)
        turn = np.asarray(d2) - np.dot(d2, d1) * np.asarray(d1)
        deg = round(math.degrees(angle))
        self.mapped("IfcPipeFitting", "IfcFlowFitting", f"Elbow {spec[0]} {deg}°",
                    self.frame(np.asarray(corner) - reach * np.asarray(d1), d1, turn),
                    ("elbow", spec[0], deg), "IfcPipeFittingType", "BEND",
                    [bend(r, m, radius, angle, max(2, round(8 * angle / math.pi)))])
        return reach

    def heater(self, width: float, at, along) -> None:
        """A panel radiator, its back 0.3 mm off the wall face at ``at`` (the middle of its bottom edge)."""
        w2, t = width / 2, HEATER_T
        meshes = [box((-w2, 0.3, 0.0), (w2, 20.0, HEATER_H - 5.0)), box((-w2, t - 20.0, 0.0), (w2, t, HEATER_H - 5.0)),
                  box((-w2, 0.3, HEATER_H - 5.0), (w2, t, HEATER_H))]
        meshes += [box((x - 1.0, 20.0, 20.0), (x + 1.0, t - 20.0, HEATER_H - 25.0))
                   for x in np.arange(-w2 + 50.0, w2 - 25.0, 50.0)]  # convector fins
        self.mapped("IfcSpaceHeater", "IfcEnergyConversionDevice", f"Radiator {int(width)}",
                    self.frame(at, (0, 0, 1), along, tilt=False), ("heater", int(width)), "IfcSpaceHeaterType",
                    "RADIATOR" if self.ifc4 else "PANELRADIATOR", meshes)

    # -- runs
    def run(self, spec, points, stops=None, start_gap: float = 0.0, end_gap: float = 0.0) -> None:
        """Pipe along the polyline ``points`` (world mm): elbows at its corners; ``stops`` {leg: [(u, kind, data)]}
        puts tees ('tee', (branch spec, branch direction, then(branch start))), valves ('valve', name) and
        couplings ('coupling') at u mm along a leg; segments fill the rest, couplings every SEGMENT_MAX at most.
        ``start_gap`` and ``end_gap`` keep the run's first and last segment off its ends (a tee's stub)."""
        pts = [np.asarray(p, float) for p in points]
        legs = [(a, b) for a, b in zip(pts, pts[1:])]
        dirs = [(b - a) / np.linalg.norm(b - a) for a, b in legs]
        phase = self.rng.choice([0.0, 0.5, 1.0, 0.25]) * 2 * np.pi / max(spec[2], 8)
        reach_in = [start_gap] + [0.0] * (len(legs) - 1)
        reach_out = [0.0] * (len(legs) - 1) + [end_gap]
        for k in range(1, len(pts) - 1):
            reach = self.elbow(spec, pts[k], dirs[k - 1], dirs[k])
            reach_out[k - 1] = reach_in[k] = reach
        for k, ((a, b), d) in enumerate(zip(legs, dirs)):
            ref = np.array([0.0, 0.0, 1.0]) if abs(d[2]) < 0.9 else np.array([1.0, 0.0, 0.0])
            length = float(np.linalg.norm(b - a))
            ports = [(reach_in[k], reach_in[k])]  # (where a segment may start, where the previous one ends)
            for u, kind, data in sorted((stops or {}).get(k, []), key=lambda s: s[0]):
                at = a + u * d
                if kind == "tee":
                    branch_spec, branch_dir, then = data
                    half, stub = self.tee(spec, branch_spec, at, d, branch_dir)
                    then(at + stub * np.asarray(branch_dir))
                elif kind == "valve":
                    half = self.valve(spec, at, d, ref, data)
                else:
                    half = 0.0
                    self.coupling(spec, at, d, ref)
                ports.append((u - half, u + half))
            ports.append((length - reach_out[k], length))
            for (_, u0), (u1, _) in zip(ports, ports[1:]):
                pieces = max(1, math.ceil((u1 - u0) / SEGMENT_MAX - 1e-9))
                cuts = np.linspace(u0, u1, pieces + 1)
                for c0, c1 in zip(cuts, cuts[1:]):
                    self.segment(spec, a + c0 * d, d, ref, c1 - c0, phase)
                for c in cuts[1:-1]:
                    self.coupling(spec, a + c * d, d, ref)


def write_pipes_ifc(path: str | Path, *, storeys: int = 4, bays: int = 14, schema: str = "IFC4", seed: int = 0) -> dict:
    """Write the network to ``path`` (see the module docstring); returns its counts: elements, by_class, storeys,
    entities, bytes, write_s."""
    t0 = time.perf_counter()
    net = _Network(schema, seed)
    w, f = net.w, net.f
    width, depth = bays * BAY + 2 * RETURN_INSET, max(2, bays // 2) * BAY + 2 * RETURN_INSET
    site = w.root("IfcSite", "Site", ObjectPlacement=w.placement(None), CompositionType="ELEMENT")
    building = w.root("IfcBuilding", "Plant room and offices", ObjectPlacement=w.placement(site.ObjectPlacement),
                      CompositionType="ELEMENT")
    f.createIfcRelAggregates(w.guid(), w.history, None, None, net.project, [site])
    f.createIfcRelAggregates(w.guid(), w.history, None, None, site, [building])
    chamfer = 1000.0

    def main_line(inset: float, z: float) -> list:
        lo_x, lo_y, hi_x, hi_y = inset, inset, width - inset, depth - inset
        return [(lo_x, lo_y, z), (hi_x, lo_y, z), (hi_x, hi_y - chamfer, z), (hi_x - chamfer, hi_y, z),
                (lo_x, hi_y, z), (lo_x, lo_y + 1200.0, z)]

    wall_class = ("IfcWall", "IfcWallStandardCase")
    risers: list = []
    for s in range(storeys):
        z0 = s * STOREY_H
        storey = w.root("IfcBuildingStorey", f"Level {s}", Elevation=z0, CompositionType="ELEMENT",
                        ObjectPlacement=w.placement(building.ObjectPlacement, 0, 0, z0))
        f.createIfcRelAggregates(w.guid(), w.history, None, None, building, [storey])
        net.here = []
        net.storey_placement = storey.ObjectPlacement
        level = w.placement(storey.ObjectPlacement)
        net.element("IfcSlab", "IfcSlab", f"Slab {s}", level, [w.block((-WALL_T, -WALL_T, -SLAB_T),
                                                                       (width + WALL_T, depth + WALL_T, 0.0))],
                    "SweptSolid", "FLOOR")
        for k, (lo, hi) in enumerate((((-WALL_T, -WALL_T), (width + WALL_T, 0.0)),
                                      ((-WALL_T, depth), (width + WALL_T, depth + WALL_T)),
                                      ((-WALL_T, 0.0), (0.0, depth)), ((width, 0.0), (width + WALL_T, depth)))):
            net.element(*wall_class, f"Wall {s}.{k}", w.placement(storey.ObjectPlacement),
                        [w.block((*lo, 0.0), (*hi, STOREY_H - SLAB_T))], "SweptSolid", "SOLIDWALL")
        supply_line = main_line(SUPPLY_INSET, SUPPLY_Z)
        heaters = []  # (leg, centre on the wall face, width, along, toward the wall)
        for leg in (0, 1, 3):  # radiators along the long walls and one end wall
            a, b = np.array(supply_line[leg][:2]), np.array(supply_line[leg + 1][:2])
            d = (b - a) / np.linalg.norm(b - a)
            out = np.array([d[1], -d[0]])  # toward the wall (the network runs counter-clockwise)
            for u in np.arange(BAY / 2 + 500.0, np.linalg.norm(b - a) - 1200.0, BAY):
                heaters.append((leg, a + out * SUPPLY_INSET + d * u, (800.0, 1000.0, 1200.0)[int(u // BAY) % 3], d, out))
        for spec, riser, inset, z, branch, side in ((SUPPLY, RISER, SUPPLY_INSET, SUPPLY_Z, BRANCH, -1.0),
                                                    (RETURN, RISER_RETURN, RETURN_INSET, RETURN_Z, BRANCH_RETURN, 1.0)):
            line = main_line(inset, z)
            stops: dict[int, list] = {0: [(800.0, "valve", "isolating")]}
            for leg, centre, hw, d, out in heaters:
                drop = centre + d * side * (hw / 2 - 100.0) - out * (HEATER_T / 2)
                u = float(np.dot(drop - np.array(line[leg][:2]), d))
                if spec is SUPPLY:
                    net.heater(hw, (*centre, HEATER_Z), (*d, 0.0))
                top = HEATER_Z + HEATER_H + net.rng.uniform(-0.3, 0.3)

                def then(start, drop=drop, branch=branch, z=z, top=top):
                    net.run(branch, [start, (*drop, z), (*drop, top)], {1: [(z - top - 150.0, "valve", "radiator")]})

                stops.setdefault(leg, []).append((u, "tee", (branch, (*out, 0.0), then)))
            if s == 0:
                risers.append((riser, spec, np.array(line[0][:2]), z))
            net.run(spec, line, stops, start_gap=riser[1] + 30.0)  # from the stub of the riser's tee
        f.createIfcRelContainedInSpatialStructure(w.guid(), w.history, None, None, net.here, storey)
        if s == 0:
            first_storey, first_here = storey, net.here
    # the risers, from the ground floor through every storey: a tee whose stub meets each storey's main, a coupling
    # in every slab
    net.here = first_here
    net.storey_placement = first_storey.ObjectPlacement
    for riser, spec, xy, z in risers:
        stops = {0: [(z + k * STOREY_H - 200.0, "tee", (spec, (1.0, 0.0, 0.0), lambda start: None))
                     for k in range(storeys)] + [(k * STOREY_H - SLAB_T / 2 - 200.0, "coupling", None)
                                                 for k in range(1, storeys)]}
        net.run(riser, [(*xy, 200.0), (*xy, z + (storeys - 1) * STOREY_H + 400.0)], stops)
    for type_, products in net.occurrences.items():
        if products:
            f.createIfcRelDefinesByType(w.guid(), w.history, None, None, products, type_)
    path = Path(path)
    f.write(str(path))
    return {"elements": w.n_elements, "by_class": dict(sorted(net.by_class.items())), "storeys": storeys,
            "schema": schema, "entities": len(list(f)), "bytes": path.stat().st_size,
            "write_s": time.perf_counter() - t0}


def generated(path: Path, **options) -> tuple[Path, dict]:
    """The model :func:`write_pipes_ifc` writes for ``options`` at ``path``, written once (its facts beside it in a
    .json) and reused by later runs."""
    import json
    import os

    meta = path.with_suffix(".json")
    if path.is_file() and meta.is_file() and json.loads(meta.read_text()).get("options") == options:
        return path, json.loads(meta.read_text())
    tmp = path.with_suffix(".tmp.ifc")
    info = write_pipes_ifc(tmp, **options)
    os.replace(tmp, path)
    info["options"] = options
    meta.write_text(json.dumps(info))
    return path, info


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("path", nargs="?", default="pipes.ifc")
    ap.add_argument("--storeys", type=int, default=BIG["storeys"])
    ap.add_argument("--bays", type=int, default=BIG["bays"], help="radiator bays along the long walls")
    ap.add_argument("--schema", choices=("IFC4", "IFC2X3"), default="IFC4")
    ap.add_argument("--small", action="store_true", help=f"the test model: {SMALL}")
    ap.add_argument("--seed", type=int, default=0)
    args = ap.parse_args(argv)
    options = SMALL if args.small else {"storeys": args.storeys, "bays": args.bays}
    info = write_pipes_ifc(args.path, schema=args.schema, seed=args.seed, **options)
    print(f"{args.path}: {info['bytes'] / 2**20:.1f} MB, {info['entities']:,} entities, {info['elements']:,} elements "
          f"({', '.join(f'{k} {v}' for k, v in info['by_class'].items())}), written in {info['write_s']:.1f} s")
    return 0


if __name__ == "__main__":
    sys.exit(main())
