"""IFC (IFC2X3, IFC4, IFC4X3) → :class:`Scene`, tessellated by IfcOpenShell's multi-core iterator.

Which products become elements (``METRICS.md`` §1):

- products of :data:`EXCLUDED_CLASSES` (and their subtypes) are left out entirely and
  counted in ``LoadReport.excluded``;
- spatial containers (building, storey) and aggregates without a Body of their own
  (an IfcStair made of flights, an IfcElementAssembly of beams) are not elements, their
  parts are; they are counted in ``LoadReport.containers``;
- every other product that yields triangles is an element; classes in ``occluders``
  (site, terrain, furniture by default) are elements with ``is_target=False``; one whose
  geometry blows up (more than ``max_triangles``) is its bounding box instead, or is skipped
  (``oversize``), and is listed in ``LoadReport.fallbacks``;
- every other product is listed in ``LoadReport.skipped`` with the reason.

Coordinates are world coordinates in metres whatever the file's length unit.
"""

from __future__ import annotations

import math
import os
import tempfile
import time
from collections import Counter
from collections.abc import Callable, Iterable
from pathlib import Path

import ifcopenshell
import ifcopenshell.geom
import ifcopenshell.util.element as uel
import ifcopenshell.util.placement as uplacement
import ifcopenshell.util.unit as uunit
import numpy as np

from ..archive import copy_entry, open_zip
from ..errors import ModelError
from .cache import content_hash
from .disciplines import discipline_of, lineage
from .scene import ElementTable, Scene
from .summary import LoadProgress, LoadReport, SkippedProduct
from .summary import peak_rss_mb as _peak_rss_mb
from .unpack import max_unpacked_bytes, too_big

#: Left out entirely (with subtypes): no physical extent, or not a construction product.
EXCLUDED_CLASSES: tuple[str, ...] = (
    "IfcSpace",
    "IfcOpeningElement",
    "IfcVirtualElement",
    "IfcAnnotation",
    "IfcGrid",  # not physical, like the classes METRICS.md §1 names
    "IfcSpatialZone",
    "IfcExternalSpatialElement",  # space-like volumes
    "IfcPort",
    "IfcStructuralItem",
    "IfcStructuralActivity",  # MEP connection points, analysis model
    "IfcPositioningElement",  # IFC4X3 alignments, referents (and IfcGrid)
)
#: Spatial containers whose own geometry (rare) is never an element; IfcSite is one only without geometry.
CONTAINER_CLASSES: tuple[str, ...] = ("IfcBuilding", "IfcBuildingStorey", "IfcFacility", "IfcFacilityPart")
DEFAULT_OCCLUDERS: tuple[str, ...] = ("IfcSite", "IfcGeographicElement", "IfcFurnishingElement")
#: Representation identifiers that carry an element's 3D shape.
BODY_IDENTIFIERS = frozenset({"Body", "Facetation", "Body-FallBack"})
#: A product tessellated into more triangles than this is taken as a geometry blow-up (a curved
#: surface meshed far too finely, a broken boolean): see ``oversize``. A whole 3 M-triangle building
#: is well under it; None turns the guard off.
DEFAULT_MAX_TRIANGLES = 1_000_000
#: What becomes of a product over ``max_triangles``: its bounding box (in its own axes), or nothing.
OVERSIZE_ACTIONS = ("box", "skip")


def ifc_options(occluders: Iterable[str] = DEFAULT_OCCLUDERS, include_occluders_as_targets: bool = False,
                max_triangles: int | None = DEFAULT_MAX_TRIANGLES, oversize: str = "box") -> dict:
    """The loader options that change the scene, canonicalised (part of the content hash)."""
    if oversize not in OVERSIZE_ACTIONS:
        raise ValueError(f"oversize must be one of {', '.join(OVERSIZE_ACTIONS)}, not {oversize!r}")
    return {
        "loader": "ifc",
        "occluders": sorted(set(occluders)),
        "include_occluders_as_targets": bool(include_occluders_as_targets),
        "max_triangles": None if max_triangles is None else int(max_triangles),
        "oversize": oversize,
    }


def _unzip_ifc(path: Path, folder: Path) -> Path:
    """The IFC inside an .ifczip, unpacked into ``folder`` with its size checked before and while it is written."""
    with open_zip(path, ModelError, "readable .ifczip") as z:
        entries = [i for i in z.infolist() if i.filename.lower().endswith(".ifc") and not i.is_dir()]
        if not entries:
            raise ModelError(f"{path.name}: no .ifc file inside the archive")
        target = folder / "model.ifc"
        with open(target, "wb") as dst:  # counted as it is inflated: the declared size can lie
            copy_entry(z, entries[0], dst, max_unpacked_bytes(), ModelError, path.name,
                       lambda size: too_big(path.name, size))
    return target


def _check_spf(path: Path, name: str) -> None:
    """A STEP physical file starts with ISO-10303-21 and ends with END-ISO-10303-21;."""
    size = path.stat().st_size
    with open(path, "rb") as fh:
        head = fh.read(64).lstrip(b"\xef\xbb\xbf \t\r\n")
        fh.seek(max(0, size - 4096))
        tail = fh.read()
    if not head.startswith(b"ISO-10303-21"):
        raise ModelError(f"{name} is not an IFC file (no ISO-10303-21 header)")
    if b"END-ISO-10303-21" not in tail:
        raise ModelError(f"{name} is truncated: it does not end with END-ISO-10303-21;")


def open_ifc(path: str | Path) -> ifcopenshell.file:
    """Open an IFC file (.ifc, or .ifczip unpacked within :func:`max_unpacked_bytes`), turning every way it can be
    unreadable into one ModelError."""
    path = Path(path)
    if not path.is_file():
        raise ModelError(f"model file not found: {path}")
    if path.stat().st_size == 0:
        raise ModelError(f"{path.name} is empty")
    with tempfile.TemporaryDirectory(prefix="sightplan-ifczip-") as tmp:
        source = _unzip_ifc(path, Path(tmp)) if path.suffix.lower() == ".ifczip" else path
        if source.suffix.lower() == ".ifc":
            _check_spf(source, path.name)
        try:
            return ifcopenshell.open(str(source))
        except Exception as exc:  # ifcopenshell raises Error, OSError, RuntimeError, SchemaError, ...
            raise ModelError(f"{path.name} cannot be read as IFC: {exc}") from exc



def _box(verts: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """The axis-aligned bounding box of ``verts`` as 8 vertices and 12 outward triangles."""
    lo, hi = verts.min(axis=0), verts.max(axis=0)
    corners = np.array([[(lo, hi)[(i >> k) & 1][k] for k in range(3)] for i in range(8)], dtype=np.float64)
    faces = np.array([[0, 2, 3], [0, 3, 1], [4, 5, 7], [4, 7, 6], [0, 1, 5], [0, 5, 4],
                      [2, 6, 7], [2, 7, 3], [0, 4, 6], [0, 6, 2], [1, 3, 7], [1, 7, 5]], dtype=np.int32)
    return corners, faces


def _outward(verts: np.ndarray, faces: np.ndarray) -> np.ndarray:
    """``faces``, wound the other way round when they form a closed solid turned inside out.

    The geometry kernel applies a mirroring mapping operator (a mirrored family instance) without
    turning the triangles' winding, so such a solid comes out with its normals inward, and every
    surface feature on its hidden side. A closed, consistently wound mesh (each edge walked once in
    each direction, vertices merged at 1 µm) with a negative signed volume is turned back; open
    sheets are left as they are.
    """
    if len(faces) < 4:
        return faces
    _, vid = np.unique(np.round(verts * 1e6).astype(np.int64), axis=0, return_inverse=True)
    tri = vid.ravel()[faces]
    directed = np.concatenate([tri[:, [0, 1]], tri[:, [1, 2]], tri[:, [2, 0]]])
    forward = np.unique(directed, axis=0)
    backward = np.unique(directed[:, ::-1], axis=0)
    if len(forward) != len(directed) or not np.array_equal(forward, backward):
        return faces  # open, or not consistently wound: no inside to tell
    t = verts[faces] - verts.mean(axis=0)
    volume = np.einsum("ij,ij->i", t[:, 0], np.cross(t[:, 1], t[:, 2])).sum()
    return faces[:, ::-1].copy() if volume < 0 else faces


class _Tracker:
    """Feeds both progress callbacks: the legacy tessellated share and the phase-aware :class:`LoadProgress`."""

    def __init__(self, progress: Callable[[float], None] | None, status: Callable[[LoadProgress], None] | None) -> None:
        self.progress, self.status = progress, status
        self.t0 = self.phase_t0 = time.perf_counter()
        self.share = 0.0

    def phase(self, name: str, total: int = 0, message: str = "") -> None:
        self.phase_t0 = time.perf_counter()
        self.update(name, 0, total, self.share, message)

    def update(self, phase: str, done: int, total: int, share: float, message: str = "") -> None:
        self.share = min(1.0, max(self.share, share))  # never backwards
        if self.progress is not None:
            self.progress(self.share)
        if self.status is not None:
            now = time.perf_counter()
            eta = (now - self.phase_t0) * (total - done) / done if 0 < done <= total else None
            self.status(LoadProgress(phase, done, total, self.share, now - self.t0, eta, message))


def _tessellation_total(f: ifcopenshell.file, skip_classes: list[str]) -> int:
    """How many products the iterator will be asked to tessellate (the denominator of the progress)."""
    skip = set(skip_classes)
    return sum(1 for p in f.by_type("IfcProduct")
               if p.Representation is not None and skip.isdisjoint(lineage(f.schema_identifier, p.is_a())))


def _style_areas(geom, verts: np.ndarray, faces: np.ndarray) -> list[tuple[str, tuple[float, float, float], float,
                                                                             float]]:
    """The surface styles of one tessellated geometry: (name, RGB diffuse colour in 0..1, transparency 0..1, m² of
    its triangles) for each style that colours some of them (areas in the geometry's own frame: placements are
    rigid). Empty where the file styles nothing."""
    try:
        materials = list(geom.materials)
        ids = np.asarray(geom.material_ids, np.int64)
    except Exception:  # a kernel without styles: nothing to keep
        return []
    if not materials or len(ids) != len(faces) or not len(faces):
        return []
    tri = verts[faces]
    area = 0.5 * np.linalg.norm(np.cross(tri[:, 1] - tri[:, 0], tri[:, 2] - tri[:, 0]), axis=1)
    out = []
    for k, m in enumerate(materials):
        a = float(area[ids == k].sum())
        if a <= 0:
            continue
        try:
            d = m.diffuse
            rgb = (float(d.r()), float(d.g()), float(d.b())) if d is not None else (math.nan,) * 3
            transparency = float(m.transparency) if m.transparency is not None else 0.0
        except Exception:
            rgb, transparency = (math.nan,) * 3, 0.0
        out.append((str(m.name or ""), rgb, 0.0 if not math.isfinite(transparency) else transparency, a))
    return out


def _tessellate(f: ifcopenshell.file, skip_classes: list[str], num_threads: int, tracker: _Tracker,
                max_triangles: int | None, styles: dict[int, list] | None = None
                ) -> tuple[dict[int, tuple[np.ndarray, np.ndarray]], dict[int, int]]:
    """({product step id: ((n, 3) float64 world metres, (m, 3) int32 local indices)} for every product with
    triangles, {product step id: its triangle count} for the products over ``max_triangles``, whose entry
    is then their bounding box in their own placement's axes). ``styles``, when given, receives each product's
    surface styles (:func:`_style_areas`).

    The kernel works in each product's local frame (``use-world-coords`` off), so a representation shared
    by many products (an IfcMappedItem of a type's IfcRepresentationMap, as exports share furniture,
    doors and windows) is built and triangulated once, and placed here by each product's matrix;
    in world coordinates the kernel would rebuild it for every occurrence.

    Its progress names the product finished last ("after IfcWall 'W1'"), not the one in progress: the iterator's
    threads report a product only once it is done (``get``), and it tells no one which products they work on now
    (``get_task_products`` lists every task, started or not, and a task that yields no shape is never reported, so
    which have started cannot be told from which have come back either).
    """
    settings = ifcopenshell.geom.settings()
    settings.set("use-world-coords", False)
    settings.set("no-normals", True)  # only triangles are used: no normals, no default materials
    settings.set("apply-default-materials", False)
    shapes: dict[int, tuple[np.ndarray, np.ndarray]] = {}
    oversize: dict[int, int] = {}
    local: dict[str, tuple[np.ndarray, np.ndarray, int]] = {}  # geometry id -> (verts, faces, kernel's triangles)
    local_styles: dict[str, list] = {}
    total = _tessellation_total(f, skip_classes)
    tracker.phase("tessellating", total, f"{total:,} products")
    done = 0
    try:
        it = ifcopenshell.geom.iterator(settings, f, max(1, int(num_threads)), exclude=skip_classes)
        started = it.initialize()
    except Exception as exc:  # the geometry kernel may raise anything; report it as the model's fault
        raise ModelError(f"IfcOpenShell could not tessellate the model: {exc}") from exc
    while started:
        try:
            shape = it.get()
            geom = shape.geometry
            key = geom.id
            if key not in local:
                verts = np.frombuffer(geom.verts_buffer, dtype=np.float64).reshape(-1, 3)
                faces = np.frombuffer(geom.faces_buffer, dtype=np.int32).reshape(-1, 3)
                n_faces = len(faces)
                if styles is not None:
                    local_styles[key] = _style_areas(geom, verts, faces)
                if max_triangles is not None and n_faces > max_triangles:
                    verts, faces = _box(verts)  # in the product's local frame: an oriented box once placed
                else:
                    faces = _outward(verts, faces)
                local[key] = (verts, faces, n_faces)
            verts, faces, n_faces = local[key]
            if len(faces) and shape.id not in shapes:
                m = np.frombuffer(shape.transformation_buffer, dtype=np.float64).reshape(4, 4, order="F")
                # a mirroring placement turns the winding inside out: wind back so normals stay outward
                placed = faces[:, ::-1] if np.linalg.det(m[:3, :3]) < 0 else faces
                shapes[shape.id] = (verts @ m[:3, :3].T + m[:3, 3], placed)
                if styles is not None and local_styles.get(key):
                    styles[shape.id] = local_styles[key]
                if n_faces > len(faces):
                    oversize[shape.id] = n_faces
            last = f"after {shape.type} {(shape.name or shape.guid)[:40]!r}"
            more = it.next()
            share = it.progress() / 100.0
        except Exception as exc:
            raise ModelError(f"IfcOpenShell could not tessellate the model: {exc}") from exc
        done += 1
        tracker.update("tessellating", min(done, total), total, share, last)
        if not more:
            break
    # the kernel's own count includes products it skips, so it may stop short of 100 %
    tracker.update("tessellating", total, total, 1.0)
    return shapes, oversize


def _storey(element: ifcopenshell.entity_instance) -> str:
    """Name of the IfcBuildingStorey containing ``element`` (through aggregates, nests and filled openings), or ''."""
    current = element
    for _ in range(32):
        container = uel.get_container(current)
        if container is not None:
            for _ in range(32):
                if container is None or container.is_a("IfcBuildingStorey"):
                    break
                container = uel.get_aggregate(container)
            if container is None:
                return ""
            return container.Name or container.LongName or f"unnamed storey {container.GlobalId}"
        parent = uel.get_aggregate(current) or uel.get_nest(current)
        if parent is None:
            fills = getattr(current, "FillsVoids", None) or ()
            parent = fills[0].RelatingOpeningElement.VoidsElements[0].RelatingBuildingElement if fills else None
        if parent is None:
            return ""
        current = parent
    return ""


def _representation_ids(product: ifcopenshell.entity_instance) -> list[str]:
    shape = product.Representation
    if shape is None:
        return []
    return [r.RepresentationIdentifier or "(unnamed)" for r in shape.Representations or ()]


def _skip_reason(product: ifcopenshell.entity_instance) -> str:
    ids = _representation_ids(product)
    if not ids:
        return "no representation"
    if not BODY_IDENTIFIERS.intersection(ids) and "(unnamed)" not in ids:
        return f"no Body representation (only {', '.join(sorted(set(ids)))})"
    return "geometry failed or empty"


def _map_unit_scale(crs: ifcopenshell.entity_instance, project_scale: float) -> float:
    """Metres per map unit of an IfcProjectedCRS (the project length unit when it names none)."""
    unit = getattr(crs, "MapUnit", None)
    if unit is None:
        return project_scale
    try:
        return float(uunit.get_named_unit_scale(unit))
    except Exception:  # an unusual unit definition: fall back to the project unit
        return project_scale


def georeference(f: ifcopenshell.file, unit_scale: float) -> dict | None:
    """The IfcMapConversion (IFC4+) or ePSet_MapConversion (IFC2X3) as a plain dict, or None.

    Keys: eastings_m, northings_m, orthogonal_height_m (in metres, from the map unit),
    x_axis_abscissa, x_axis_ordinate (direction of local +X in the map grid), scale,
    target_crs (e.g. 'EPSG:28992'), crs_description, geodetic_datum, vertical_datum, source.
    """
    conversions = f.by_type("IfcMapConversion") if f.schema != "IFC2X3" else []
    if conversions:
        conv = conversions[0]
        crs = conv.TargetCRS
        s = _map_unit_scale(crs, unit_scale)
        return {
            "eastings_m": float(conv.Eastings) * s,
            "northings_m": float(conv.Northings) * s,
            "orthogonal_height_m": float(conv.OrthogonalHeight) * s,
            "x_axis_abscissa": float(conv.XAxisAbscissa) if conv.XAxisAbscissa is not None else 1.0,
            "x_axis_ordinate": float(conv.XAxisOrdinate) if conv.XAxisOrdinate is not None else 0.0,
            "scale": float(conv.Scale) if conv.Scale is not None else 1.0,
            "target_crs": crs.Name,
            "crs_description": getattr(crs, "Description", None),
            "geodetic_datum": getattr(crs, "GeodeticDatum", None),
            "vertical_datum": getattr(crs, "VerticalDatum", None),
            "source": "IfcMapConversion",
        }
    projects = f.by_type("IfcProject")
    pset = uel.get_pset(projects[0], "ePSet_MapConversion") if projects else None
    if not pset or pset.get("Eastings") is None:
        return None
    crs = uel.get_pset(projects[0], "ePSet_ProjectedCRS") or {}

    def value(name: str, default: float) -> float:  # 0.0 is a value (an axis along +Y), not a missing one
        v = pset.get(name)
        return default if v is None else float(v)

    return {
        "eastings_m": float(pset["Eastings"]) * unit_scale,
        "northings_m": value("Northings", 0.0) * unit_scale,
        "orthogonal_height_m": value("OrthogonalHeight", 0.0) * unit_scale,
        "x_axis_abscissa": value("XAxisAbscissa", 1.0),
        "x_axis_ordinate": value("XAxisOrdinate", 0.0),
        "scale": value("Scale", 1.0),
        "target_crs": crs.get("Name"),
        "crs_description": crs.get("Description"),
        "geodetic_datum": crs.get("GeodeticDatum"),
        "vertical_datum": crs.get("VerticalDatum"),
        "source": "ePSet_MapConversion",
    }


def _true_north_deg(f: ifcopenshell.file) -> float | None:
    """True heading (degrees clockwise from true north) of the model's +Y axis, from the model
    context's TrueNorth, or None when no context gives one."""
    contexts = [c for c in f.by_type("IfcGeometricRepresentationContext")
                if not c.is_a("IfcGeometricRepresentationSubContext") and getattr(c, "TrueNorth", None) is not None]
    contexts.sort(key=lambda c: c.ContextType != "Model")
    for c in contexts:
        ratios = [float(v) for v in c.TrueNorth.DirectionRatios[:2]]
        if len(ratios) == 2 and math.hypot(*ratios) > 0:
            # TrueNorth is the direction of north in model XY; model +Y is that many degrees the other way
            return (-math.degrees(math.atan2(ratios[0], ratios[1]))) % 360.0
    return None


def _placement_origin(product: ifcopenshell.entity_instance, unit_scale: float) -> list[float]:
    """World position (metres) of a product's local placement origin."""
    try:
        m = uplacement.get_local_placement(product.ObjectPlacement)
        return [float(v) * unit_scale for v in m[:3, 3]]
    except Exception:  # no or unusual placement: the world origin
        return [0.0, 0.0, 0.0]


def site_location(f: ifcopenshell.file, unit_scale: float) -> dict | None:
    """IfcSite RefLatitude/RefLongitude/RefElevation as {latitude_deg, longitude_deg, elevation_m,
    origin_m (the site placement's world position, where that latitude/longitude lies), true_north_deg
    (true heading of model +Y, None when the file gives no TrueNorth)}, or None."""
    for site in f.by_type("IfcSite"):
        lat, lon = site.RefLatitude, site.RefLongitude
        if lat and lon:

            def deg(dms) -> float:
                parts = list(dms) + [0] * (4 - len(dms))
                return parts[0] + parts[1] / 60 + parts[2] / 3600 + parts[3] / 3.6e9

            elevation = float(site.RefElevation) * unit_scale if site.RefElevation is not None else None
            return {"latitude_deg": deg(lat), "longitude_deg": deg(lon), "elevation_m": elevation,
                    "origin_m": _placement_origin(site, unit_scale), "true_north_deg": _true_north_deg(f)}
    return None


def _style_names(f: ifcopenshell.file) -> dict[int, str]:
    """{step id of a style's rendering or shading: the IfcSurfaceStyle's Name}: the kernel names a style by the
    rendering it read ("IfcSurfaceStyleRendering-3791"), the file by the style that holds it ("Masonry - Brick")."""
    names: dict[int, str] = {}
    for style in f.by_type("IfcSurfaceStyle"):
        for item in style.Styles or ():
            if style.Name:
                names[item.id()] = str(style.Name)
    return names


def _material_name(product: ifcopenshell.entity_instance) -> str:
    """The name of the product's (or its type's) material: a layer set's first layer (a wall's exterior face), a
    constituent or profile set's first, a list's first; '' where none is assigned."""
    try:
        m = uel.get_material(product, should_skip_usage=True)
    except Exception:
        return ""
    if m is None:
        return ""
    for attr, inner in (("MaterialLayers", "Material"), ("MaterialConstituents", "Material"),
                        ("MaterialProfiles", "Material"), ("Materials", None)):
        items = getattr(m, attr, None)
        if items:
            first = items[0] if inner is None else getattr(items[0], inner, None)
            return str(getattr(first, "Name", "") or "") if first is not None else ""
    return str(getattr(m, "Name", "") or "")


def element_styles(f: ifcopenshell.file, kept: list, shape_styles: dict[int, list]) -> dict | None:
    """``scene.metadata["styles"]``: the surface styles the file gives each element, for renders that paint it as
    styled. ``styles``: one entry per distinct style, {name, rgb (0..1), transparency (0..1)}; ``elements``:
    {GlobalId: [index of the style over most of its area (−1: none), the share of its area in a style at least half
    transparent (glazing), its material's name]}. None when the file styles no element and names no material."""
    names = _style_names(f)
    index: dict[tuple, int] = {}
    table: list[dict] = []
    elements: dict[str, list] = {}
    for p in kept:
        parts = shape_styles.get(p.id(), [])
        material = _material_name(p)
        if not parts and not material:
            continue
        best, total, glazed = -1, 0.0, 0.0
        areas: dict[int, float] = {}
        for name, rgb, transparency, area in parts:
            step = name.rsplit("-", 1)[-1]
            label = names.get(int(step), name) if step.isdigit() else name
            k = (label, *(round(c, 4) for c in rgb), round(transparency, 4))
            if k not in index:
                index[k] = len(table)
                table.append({"name": label, "rgb": [None if not math.isfinite(c) else round(c, 4) for c in rgb],
                              "transparency": round(transparency, 4)})
            areas[index[k]] = areas.get(index[k], 0.0) + area
            total += area
            glazed += area if transparency >= 0.5 else 0.0
        if areas:
            best = max(areas, key=lambda j: areas[j])
        elements[str(p.GlobalId)] = [best, round(glazed / total, 4) if total > 0 else 0.0, material]
    if not elements:
        return None
    return {"format": 1, "styles": table, "elements": elements}


def _classify(schema: str, ifc_class: str, names: Iterable[str]) -> bool:
    chain = lineage(schema, ifc_class)
    return any(n in chain for n in names)


def load_ifc(
    path: str | Path,
    *,
    occluders: Iterable[str] = DEFAULT_OCCLUDERS,
    include_occluders_as_targets: bool = False,
    num_threads: int | None = None,
    progress: Callable[[float], None] | None = None,
    status: Callable[[LoadProgress], None] | None = None,
    max_triangles: int | None = DEFAULT_MAX_TRIANGLES,
    oversize: str = "box",
) -> tuple[Scene, LoadReport]:
    """Load an IFC file (.ifc, .ifczip) as a Scene in world metres, with its :class:`LoadReport`.

    ``progress``: called with the tessellated share (0..1) as the work goes on, 0.0 first (before
    the file is read), monotone, 1.0 last. ``status``: called with a :class:`LoadProgress` (phase
    'reading', 'tessellating' with products done / total and an ETA, 'assembling', 'done') at the
    start of each phase and after each product tessellated.
    ``max_triangles``: a product tessellated into more triangles is replaced by its bounding box in
    its own axes (``oversize='box'``) or left out (``'skip'``, listed in ``LoadReport.skipped``);
    either way ``LoadReport.fallbacks`` names it with its triangle count. The kernel cannot stop
    a product's tessellation after a time limit, so this guard acts on the result.

    Elements are ordered by STEP id, so the element index is stable between loads.
    ``occluders``: IFC classes (with subtypes) loaded with ``is_target=False`` unless
    ``include_occluders_as_targets``. ``num_threads``: tessellation threads (default: every core).
    ``scene.metadata``: ``georeference`` (see :func:`georeference`), ``site_location``,
    ``schema``, ``unit_scale``, ``styles`` (the elements' surface styles and materials, :func:`element_styles`).
    Raises :class:`ModelError` for unreadable files and for models without any element geometry.
    """
    t0 = time.perf_counter()
    path = Path(path)
    occluders = tuple(occluders)
    ifc_options(occluders, include_occluders_as_targets, max_triangles, oversize)  # validates
    tracker = _Tracker(progress, status)
    size_mb = path.stat().st_size / 2**20 if path.is_file() else 0.0
    tracker.phase("reading", 0, f"{path.name}, {size_mb:,.1f} MB")
    f = open_ifc(path)
    schema = f.schema_identifier
    try:
        unit_scale = float(uunit.calculate_unit_scale(f))
    except Exception:  # a file without IfcUnitAssignment: IfcOpenShell assumes metres too
        unit_scale = 1.0

    def in_schema(names: Iterable[str]) -> list[str]:
        return [n for n in names if lineage(schema, n)]

    excluded_names = in_schema(EXCLUDED_CLASSES)
    shape_styles: dict[int, list] = {}
    shapes, over = _tessellate(f, excluded_names + in_schema(CONTAINER_CLASSES), num_threads or os.cpu_count() or 1,
                               tracker, max_triangles, shape_styles)
    tracker.phase("assembling", len(shapes), f"{len(shapes):,} elements")

    products = sorted(f.by_type("IfcProduct"), key=lambda p: p.id())
    excluded: Counter[str] = Counter()
    containers: Counter[str] = Counter()
    skipped: list[SkippedProduct] = []
    fallbacks: list[SkippedProduct] = []
    warnings: list[str] = []
    kept: list[ifcopenshell.entity_instance] = []
    for p in products:
        cls = p.is_a()
        if _classify(schema, cls, excluded_names):
            excluded[cls] += 1
        elif _classify(schema, cls, CONTAINER_CLASSES):
            containers[cls] += 1
            if BODY_IDENTIFIERS.intersection(_representation_ids(p)):
                warnings.append(f"{cls} {p.Name or p.GlobalId} has Body geometry, ignored: spatial containers are not elements")
        elif p.id() in over and oversize == "skip":
            skipped.append(SkippedProduct(p.GlobalId, cls, p.Name or "",
                                          f"{over[p.id()]:,} triangles, over max_triangles {max_triangles:,}"))
            fallbacks.append(SkippedProduct(p.GlobalId, cls, p.Name or "",
                                            f"{over[p.id()]:,} triangles > {max_triangles:,}: skipped"))
        elif p.id() in shapes:
            kept.append(p)
            if p.id() in over:
                fallbacks.append(SkippedProduct(p.GlobalId, cls, p.Name or "",
                                                f"{over[p.id()]:,} triangles > {max_triangles:,}: bounding box"))
        elif any(len(rel.RelatedObjects) for rel in getattr(p, "IsDecomposedBy", None) or ()) or _classify(
            schema, cls, ("IfcSpatialElement", "IfcSpatialStructureElement")
        ):
            containers[cls] += 1
        else:
            skipped.append(SkippedProduct(p.GlobalId, cls, p.Name or "", _skip_reason(p)))
    if not kept:
        raise ModelError(f"{path.name}: the model has no elements with geometry ({len(products)} products, none tessellated)")

    verts = [shapes[p.id()][0] for p in kept]
    faces = [shapes[p.id()][1] for p in kept]
    counts = np.array([len(fc) for fc in faces], dtype=np.int64)
    all_faces = np.empty((int(counts.sum()), 3), dtype=np.int32)  # the scene's dtype: no int64 intermediate
    row = offset = 0
    for v, fc in zip(verts, faces):
        np.add(fc, offset, out=all_faces[row:row + len(fc)])
        row += len(fc)
        offset += len(v)
    if offset >= 2**31:
        raise ModelError(f"{path.name}: {offset:,} vertices, more than a scene can index")
    face_element = np.repeat(np.arange(len(kept), dtype=np.int32), counts)

    is_occluder = np.array([_classify(schema, p.is_a(), occluders) for p in kept], bool)
    elements = ElementTable.build(
        global_id=[p.GlobalId for p in kept],
        name=[p.Name or "" for p in kept],
        ifc_class=[p.is_a() for p in kept],
        discipline=[discipline_of(p, schema) for p in kept],
        storey=[_storey(p) for p in kept],
        is_target=np.ones(len(kept), bool) if include_occluders_as_targets else ~is_occluder,
    )
    key = content_hash(path, ifc_options(occluders, include_occluders_as_targets, max_triangles, oversize))
    metadata: dict = {"schema": schema, "unit_scale": unit_scale}
    try:
        metadata["styles"] = element_styles(f, kept, shape_styles)
    except (AttributeError, TypeError, ValueError, IndexError, RuntimeError) as exc:  # malformed, never fatal
        metadata["styles"] = None
        warnings.append(f"surface styles ignored: {type(exc).__name__}: {exc}")
    for name, read in (("georeference", georeference), ("site_location", site_location)):
        try:
            metadata[name] = read(f, unit_scale)
        except (AttributeError, TypeError, ValueError, IndexError, RuntimeError) as exc:  # malformed, never fatal
            metadata[name] = None
            warnings.append(f"{name} ignored: {type(exc).__name__}: {exc}")
    scene = Scene.from_arrays(np.concatenate(verts), all_faces, face_element, elements, str(path), key, metadata)
    report = LoadReport(
        source=str(path),
        schema=schema,
        unit_scale=unit_scale,
        n_products=len(products),
        n_elements=len(kept),
        n_targets=int(elements.is_target.sum()),
        n_triangles=len(scene.faces),
        skipped=tuple(skipped),
        excluded=dict(sorted(excluded.items())),
        containers=dict(sorted(containers.items())),
        warnings=tuple(warnings),
        elapsed_s=time.perf_counter() - t0,
        fallbacks=tuple(fallbacks),
        peak_rss_mb=round(_peak_rss_mb(), 1),
    )
    tracker.phase("done", len(kept), f"{len(kept):,} elements, {len(scene.faces):,} triangles")
    return scene, report
