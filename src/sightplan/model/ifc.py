"""IFC (IFC2X3, IFC4, IFC4X3) → :class:`Scene`, tessellated by IfcOpenShell's multi-core iterator.

Which products become elements (``METRICS.md`` §1):

- products of :data:`EXCLUDED_CLASSES` (and their subtypes) are left out entirely and
  counted in ``LoadReport.excluded``;
- spatial containers (building, storey) and aggregates without a Body of their own
  (an IfcStair made of flights, an IfcElementAssembly of beams) are not elements, their
  parts are; they are counted in ``LoadReport.containers``;
- every other product that yields triangles is an element; classes in ``occluders``
  (site, terrain, furniture by default) are elements with ``is_target=False``;
- every other product is listed in ``LoadReport.skipped`` with the reason.

Coordinates are world coordinates in metres whatever the file's length unit.
"""

from __future__ import annotations

import math
import os
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

from ..errors import ModelError
from .cache import content_hash
from .disciplines import discipline_of, lineage
from .scene import ElementTable, Scene
from .summary import LoadReport, SkippedProduct

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


def ifc_options(occluders: Iterable[str] = DEFAULT_OCCLUDERS, include_occluders_as_targets: bool = False) -> dict:
    """The loader options that change the scene, canonicalised (part of the content hash)."""
    return {
        "loader": "ifc",
        "occluders": sorted(set(occluders)),
        "include_occluders_as_targets": bool(include_occluders_as_targets),
    }


def _open(path: Path) -> ifcopenshell.file:
    """Open an IFC file, turning every way it can be unreadable into one ModelError."""
    if not path.is_file():
        raise ModelError(f"model file not found: {path}")
    if path.stat().st_size == 0:
        raise ModelError(f"{path.name} is empty")
    if path.suffix.lower() == ".ifc":
        with open(path, "rb") as fh:
            head = fh.read(64).lstrip(b"\xef\xbb\xbf \t\r\n")
            fh.seek(max(0, path.stat().st_size - 4096))
            tail = fh.read()
        if not head.startswith(b"ISO-10303-21"):
            raise ModelError(f"{path.name} is not an IFC file (no ISO-10303-21 header)")
        if b"END-ISO-10303-21" not in tail:
            raise ModelError(f"{path.name} is truncated: it does not end with END-ISO-10303-21;")
    try:
        return ifcopenshell.open(str(path))
    except Exception as exc:  # ifcopenshell raises Error, OSError, RuntimeError, SchemaError, ...
        raise ModelError(f"{path.name} cannot be read as IFC: {exc}") from exc


def _tessellate(f: ifcopenshell.file, skip_classes: list[str], num_threads: int,
                progress: Callable[[float], None] | None = None) -> dict[int, tuple[np.ndarray, np.ndarray]]:
    """{product step id: ((n, 3) float64 world metres, (m, 3) int32 local indices)} for every product with triangles."""
    settings = ifcopenshell.geom.settings()
    settings.set("use-world-coords", True)
    settings.set("no-normals", True)  # only triangles are used: no normals, no default materials
    settings.set("apply-default-materials", False)
    shapes: dict[int, tuple[np.ndarray, np.ndarray]] = {}
    try:
        it = ifcopenshell.geom.iterator(settings, f, max(1, int(num_threads)), exclude=skip_classes)
        if not it.initialize():
            return shapes
        while True:
            shape = it.get()
            geom = shape.geometry
            verts = np.frombuffer(geom.verts_buffer, dtype=np.float64).reshape(-1, 3)
            faces = np.frombuffer(geom.faces_buffer, dtype=np.int32).reshape(-1, 3)
            if len(faces) and shape.id not in shapes:
                shapes[shape.id] = (verts, faces)
            if progress is not None:
                progress(it.progress() / 100.0)
            if not it.next():
                break
    except ModelError:
        raise
    except Exception as exc:  # the geometry kernel may raise anything; report it as the model's fault
        raise ModelError(f"IfcOpenShell could not tessellate the model: {exc}") from exc
    if progress is not None:
        progress(1.0)  # the kernel's own count includes products it skips, so it may stop short of 100 %
    return shapes


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
) -> tuple[Scene, LoadReport]:
    """Load an IFC file (.ifc, .ifczip) as a Scene in world metres, with its :class:`LoadReport`.

    ``progress``: called with the tessellated share (0..1) as the work goes on.

    Elements are ordered by STEP id, so the element index is stable between loads.
    ``occluders``: IFC classes (with subtypes) loaded with ``is_target=False`` unless
    ``include_occluders_as_targets``. ``num_threads``: tessellation threads (default: every core).
    ``scene.metadata``: ``georeference`` (see :func:`georeference`), ``site_location``,
    ``schema``, ``unit_scale``. Raises :class:`ModelError` for unreadable files and for
    models without any element geometry.
    """
    t0 = time.perf_counter()
    path = Path(path)
    occluders = tuple(occluders)
    f = _open(path)
    schema = f.schema_identifier
    try:
        unit_scale = float(uunit.calculate_unit_scale(f))
    except Exception:  # a file without IfcUnitAssignment: IfcOpenShell assumes metres too
        unit_scale = 1.0

    def in_schema(names: Iterable[str]) -> list[str]:
        return [n for n in names if lineage(schema, n)]

    excluded_names = in_schema(EXCLUDED_CLASSES)
    shapes = _tessellate(f, excluded_names + in_schema(CONTAINER_CLASSES), num_threads or os.cpu_count() or 1, progress)

    products = sorted(f.by_type("IfcProduct"), key=lambda p: p.id())
    excluded: Counter[str] = Counter()
    containers: Counter[str] = Counter()
    skipped: list[SkippedProduct] = []
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
        elif p.id() in shapes:
            kept.append(p)
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
    offsets = np.cumsum([0] + [len(v) for v in verts[:-1]])
    counts = np.array([len(fc) for fc in faces])
    all_faces = np.concatenate(faces).astype(np.int64) + np.repeat(offsets, counts)[:, None]
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
    key = content_hash(path, ifc_options(occluders, include_occluders_as_targets))
    metadata: dict = {"schema": schema, "unit_scale": unit_scale}
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
    )
    return scene, report
