"""What a load produced: the :class:`LoadReport` and a JSON-ready summary of a scene.

Every IFC product of the file is accounted for in exactly one place of the report::

    n_products == n_elements + len(skipped) + sum(excluded.values()) + sum(containers.values())
"""

from __future__ import annotations

import sys
from collections import Counter
from dataclasses import asdict, dataclass, field

import numpy as np

from .scene import Scene


def peak_rss_mb() -> float:
    """This process's peak resident memory so far (MB); 0.0 where the platform does not tell.

    Linux: VmHWM, which starts afresh in a new program (ru_maxrss would carry a forking parent's peak over)."""
    try:
        with open("/proc/self/status", "rb") as fh:
            for line in fh:
                if line.startswith(b"VmHWM:"):
                    return int(line.split()[1]) / 1024.0  # kB
    except (OSError, ValueError, IndexError):
        pass
    try:
        import resource
    except ImportError:  # Windows
        return 0.0
    peak = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss
    return peak / 2**20 if sys.platform == "darwin" else peak / 1024.0  # bytes on macOS, KiB on Linux


@dataclass(frozen=True)
class SkippedProduct:
    """A product that should have been an element but yielded no triangles."""

    global_id: str
    ifc_class: str
    name: str
    reason: str  # "no representation", "no Body representation (only Axis)", "geometry failed", ...


@dataclass(frozen=True)
class LoadProgress:
    """Where a load stands, for a progress display.

    phase: 'reading' (parsing the file: no count), 'tessellating' (``done`` of ``total`` products),
        'assembling' (the scene and element table), 'ties' (finding the coincident faces), 'done'.
    share: tessellated share 0..1 (never decreases during a load).
    elapsed_s: since the load started; eta_s: seconds left in this phase at its pace so far, None
        while unknown.
    message: a short note (file name and size, counts).
    """

    phase: str
    done: int
    total: int
    share: float
    elapsed_s: float
    eta_s: float | None = None
    message: str = ""


@dataclass(frozen=True)
class LoadReport:
    """How a model file became a :class:`Scene`.

    schema: 'IFC2X3', 'IFC4', ... or the mesh format ('obj', 'glb', ...).
    unit_scale: metres per file length unit (0.0254 for inches); the scene is always metres.
    n_products: IfcProduct instances in the file (mesh: objects/nodes in the file).
    n_elements: rows of the scene's element table; n_targets of them count in the metrics.
    n_triangles: faces of the scene.
    skipped: products with no usable geometry, never dropped silently.
    excluded: products left out by class (IfcSpace, IfcOpeningElement, ...), count by class.
    containers: spatial containers and aggregates without geometry of their own, whose
        parts are the elements (IfcBuildingStorey, IfcElementAssembly, IfcStair, ...), by class.
    warnings: anything else the user should know, one line each.
    elapsed_s: wall-clock seconds of the load (of the cache read when ``from_cache``).
    fallbacks: products whose geometry blew up (over the loader's ``max_triangles``), each with
        what was done instead (its bounding box, or skipped) in ``reason``.
    peak_rss_mb: the loading process's peak resident memory at the end of the load, the tie pairs
        included (MB; read again on every load, cached or not; 0.0 where unknown).
    tied_faces, tied_elements: faces (and their elements) flush with another element's face
        (coincident surfaces, METRICS.md §2), whose pixels count for every element on them.
    """

    source: str
    schema: str
    unit_scale: float
    n_products: int
    n_elements: int
    n_targets: int
    n_triangles: int
    skipped: tuple[SkippedProduct, ...] = ()
    excluded: dict[str, int] = field(default_factory=dict)
    containers: dict[str, int] = field(default_factory=dict)
    warnings: tuple[str, ...] = ()
    elapsed_s: float = 0.0
    from_cache: bool = False
    fallbacks: tuple[SkippedProduct, ...] = ()
    peak_rss_mb: float = 0.0
    tied_faces: int = 0
    tied_elements: int = 0

    def to_dict(self) -> dict:
        """Plain JSON-serialisable dict (skipped products as dicts)."""
        d = asdict(self)
        d["skipped"] = [asdict(s) for s in self.skipped]
        d["fallbacks"] = [asdict(s) for s in self.fallbacks]
        d["warnings"] = list(self.warnings)
        return d

    @classmethod
    def from_dict(cls, d: dict) -> LoadReport:
        d = dict(d)
        d["skipped"] = tuple(SkippedProduct(**s) for s in d.get("skipped", ()))
        d["fallbacks"] = tuple(SkippedProduct(**s) for s in d.get("fallbacks", ()))
        d["warnings"] = tuple(d.get("warnings", ()))
        d["excluded"] = {str(k): int(v) for k, v in d.get("excluded", {}).items()}
        d["containers"] = {str(k): int(v) for k, v in d.get("containers", {}).items()}
        return cls(**d)


def _counts(keys: np.ndarray, targets: np.ndarray) -> dict[str, dict[str, int]]:
    """{key: {"elements": n, "targets": t, "occluders": n - t}} sorted by descending count."""
    total = Counter(keys.tolist())
    tgt = Counter(keys[targets].tolist())
    rows = sorted(total.items(), key=lambda kv: (-kv[1], kv[0]))
    return {k: {"elements": n, "targets": tgt.get(k, 0), "occluders": n - tgt.get(k, 0)} for k, n in rows}


def summarize(scene: Scene, report: LoadReport) -> dict:
    """A JSON-serialisable description of a loaded model, for ``sightplan info``.

    Keys: source, schema, unit_scale, elements / targets / occluders (counts),
    triangles, bounds_m ({"min": [x, y, z], "max": [...], "size": [...]}, metres),
    by_class / by_discipline / by_storey ({name: {"elements", "targets", "occluders"}};
    '' means unclassified / no storey), excluded and containers ({class: count}),
    skipped and fallbacks ([{global_id, ifc_class, name, reason}]), warnings, georeference and
    site_location (dict or None), elapsed_s, from_cache, peak_rss_mb, tied_faces and tied_elements.
    """
    el = scene.elements
    targets = np.asarray(el.is_target, bool)
    lo, hi = scene.bounds()
    n_tri = np.bincount(scene.face_element, minlength=len(el))
    return {
        "source": report.source or scene.source,
        "schema": report.schema,
        "unit_scale": float(report.unit_scale),
        "elements": int(len(el)),
        "targets": int(targets.sum()),
        "occluders": int((~targets).sum()),
        "triangles": int(len(scene.faces)),
        "bounds_m": {"min": lo.round(4).tolist(), "max": hi.round(4).tolist(), "size": (hi - lo).round(4).tolist()},
        "by_class": _counts(el.ifc_class, targets),
        "by_discipline": _counts(el.discipline, targets),
        "by_storey": _counts(el.storey, targets),
        "elements_without_triangles": int((n_tri == 0).sum()),
        "excluded": dict(report.excluded),
        "containers": dict(report.containers),
        "skipped": [asdict(s) for s in report.skipped],
        "fallbacks": [asdict(s) for s in report.fallbacks],
        "warnings": list(report.warnings),
        "georeference": scene.metadata.get("georeference"),
        "site_location": scene.metadata.get("site_location"),
        "elapsed_s": round(float(report.elapsed_s), 3),
        "from_cache": bool(report.from_cache),
        "peak_rss_mb": round(float(report.peak_rss_mb), 1),
        "tied_faces": int(report.tied_faces),
        "tied_elements": int(report.tied_elements),
    }
