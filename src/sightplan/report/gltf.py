"""The model as a coloured binary glTF (.glb): one node per element, coloured by a metric.

Each element with geometry becomes one mesh and one node named by its GlobalId, whose
``extras`` hold the element's index, name, IFC class, storey and metric values. Target
elements are coloured by the chosen metric on a traffic-light gradient (green good →
yellow → red bad) between two bounds; target elements the plan does not see are red;
occluders are grey and semi-transparent. Coordinates are centred on the model's box and
turned from the model's Z-up to glTF's Y-up: (x, y, z) → (x − cx, z − cz, −(y − cy)).
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from pathlib import Path
from typing import Literal, get_args

import numpy as np
from numpy.typing import NDArray

from ..errors import ReportError
from ..geometry.axes import z_up_to_y_up
from ..metrics import Metrics
from ..metrics.elements import ElementMetrics
from ..model.scene import Scene
from .overview import OBSERVED_ONLY, OCCLUDER, UNSEEN, VISIBLE
from .tables import json_number

ColourBy = Literal["visibility", "vr", "ssd", "orientation"]
COLOUR_BY: tuple[str, ...] = get_args(ColourBy)

# What each metric colours by, its unit, and whether a larger value is better.
METRIC_LABELS: dict[str, tuple[str, str, bool]] = {
    "visibility": ("visibility (seen ≥ Ω px / observed only / unseen)", "", True),
    "vr": ("VR_i, frames seeing the element by ≥ Ω px", "frames", True),
    "ssd": ("R_i, surface sampling distance", "m/px", False),
    "orientation": ("O_i, viewpoint orientation", "°", False),
}
OCCLUDER_ALPHA = 0.35
GRADIENT = (VISIBLE, OBSERVED_ONLY, UNSEEN)  # good → middle → bad, sRGB
VISIBILITY_CLASSES = ("visible", "observed", "unseen", "occluder")


def check_colour_by(colour_by: str) -> ColourBy:
    """``colour_by`` if it is a known metric, else a ReportError listing them."""
    if colour_by not in COLOUR_BY:
        raise ReportError(f"unknown metric to colour by: {colour_by!r}; choose one of {', '.join(COLOUR_BY)}")
    return colour_by  # type: ignore[return-value]


def parse_bounds(text: str) -> tuple[float, float]:
    """``"LO,HI"`` as two finite floats with LO < HI."""
    parts = text.split(",")
    try:
        if len(parts) != 2:
            raise ValueError
        lo, hi = float(parts[0]), float(parts[1])
    except ValueError:
        raise ReportError(f"bounds must be two numbers LO,HI (e.g. 0.002,0.01), got {text!r}") from None
    return check_bounds((lo, hi))


def check_bounds(bounds: tuple[float, float]) -> tuple[float, float]:
    lo, hi = float(bounds[0]), float(bounds[1])
    if not (math.isfinite(lo) and math.isfinite(hi)):
        raise ReportError(f"bounds must be finite numbers, got {lo:g},{hi:g}")
    if lo >= hi:
        raise ReportError(f"bounds need LO < HI, got {lo:g},{hi:g}")
    return lo, hi


def check_writable(path: str | Path) -> Path:
    """``path`` if a file can be written there, else a ReportError; creates its folder, leaves no file behind."""
    path = Path(path)
    if path.is_dir():
        raise ReportError(f"cannot write {path}: it is a folder")
    ancestor = path.parent
    while not ancestor.exists() and ancestor != ancestor.parent:
        ancestor = ancestor.parent
    if ancestor.exists() and not ancestor.is_dir():
        raise ReportError(f"cannot write {path}: {ancestor} is not a folder")
    existed = path.exists()
    try:
        path.parent.mkdir(parents=True, exist_ok=True)
        with open(path, "ab"):
            pass
    except OSError as exc:
        raise ReportError(f"cannot write {path}: {exc.strerror or exc}") from None
    if not existed:
        path.unlink(missing_ok=True)
    return path


def write_bytes(path: str | Path, data: bytes | str) -> Path:
    """Write ``data`` to ``path`` (creating its folder); an OSError becomes one ReportError line."""
    path = Path(path)
    try:
        path.parent.mkdir(parents=True, exist_ok=True)
        if isinstance(data, str):
            path.write_text(data, encoding="utf-8")
        else:
            path.write_bytes(data)
    except OSError as exc:
        raise ReportError(f"cannot write {path}: {exc.strerror or exc}") from None
    return path


# --------------------------------------------------------------------------- values and colours
def visibility_class(em: ElementMetrics) -> NDArray[np.int8]:
    """(z,) index into VISIBILITY_CLASSES: 0 visible, 1 observed only, 2 unseen, 3 occluder."""
    cls = np.full(len(em.is_target), 2, np.int8)
    cls[em.observed] = 1
    cls[em.visible] = 0
    cls[~em.is_target] = 3
    return cls


def element_values(em: ElementMetrics, colour_by: ColourBy) -> NDArray[np.float64]:
    """(z,) the value an element is coloured by; NaN for target elements the metric is undefined on."""
    if colour_by == "visibility":
        return visibility_class(em).astype(np.float64)
    if colour_by == "vr":
        return np.where(em.visible, em.VR, np.nan).astype(np.float64)
    return np.asarray(em.R if colour_by == "ssd" else em.O, np.float64)


def default_bounds(em: ElementMetrics, colour_by: ColourBy) -> tuple[float, float]:
    """The range of a gradient metric (vr, ssd, orientation) over the visible target elements."""
    v = element_values(em, colour_by)[em.visible & em.is_target]
    v = v[np.isfinite(v)]
    if not len(v):
        return (0.0, 1.0)
    lo, hi = float(v.min()), float(v.max())
    if hi <= lo:  # one value: it sits in the middle of the gradient
        pad = max(abs(lo) * 0.5, 1e-9)
        return (lo - pad, hi + pad)
    return (lo, hi)


def colour_bounds(em: ElementMetrics, colour_by: ColourBy,
                  bounds: tuple[float, float] | None = None) -> tuple[float, float] | None:
    """The gradient's ends: ``bounds`` checked, else the default range; None for ``visibility`` (which takes none)."""
    if colour_by == "visibility":
        if bounds is not None:
            raise ReportError("bounds apply to vr, ssd and orientation, not to visibility")
        return None
    return check_bounds(bounds) if bounds is not None else default_bounds(em, colour_by)


def traffic_light(badness: NDArray) -> NDArray[np.float64]:
    """(n, 3) sRGB in [0, 1]: 0 green (good), 0.5 yellow, 1 red (bad); clipped to [0, 1]."""
    t = np.clip(np.asarray(badness, np.float64), 0.0, 1.0)
    stops = np.array(GRADIENT)
    x = np.linspace(0.0, 1.0, len(stops))
    return np.column_stack([np.interp(t, x, stops[:, c]) for c in range(3)])


def metric_colours(em: ElementMetrics, colour_by: ColourBy = "visibility",
                   bounds: tuple[float, float] | None = None) -> NDArray[np.float64]:
    """(z, 4) sRGB colour and alpha per element, as the model is drawn in the glTF and the HTML report."""
    colour_by = check_colour_by(colour_by)
    ends = colour_bounds(em, colour_by, bounds)
    rgba = np.ones((len(em.is_target), 4))
    if ends is None:
        rgba[:, :3] = np.array((VISIBLE, OBSERVED_ONLY, UNSEEN, OCCLUDER))[visibility_class(em)]
    else:
        lo, hi = ends
        v = element_values(em, colour_by)
        higher_better = METRIC_LABELS[colour_by][2]
        with np.errstate(invalid="ignore"):
            badness = (hi - v) / (hi - lo) if higher_better else (v - lo) / (hi - lo)
        rgba[:, :3] = traffic_light(np.nan_to_num(badness, nan=1.0))
        rgba[~np.isfinite(v), :3] = UNSEEN
    rgba[~em.is_target, :3] = OCCLUDER
    rgba[~em.is_target, 3] = OCCLUDER_ALPHA
    return rgba


def srgb_to_linear(c: NDArray) -> NDArray[np.float64]:
    """glTF stores colour factors in linear light."""
    c = np.asarray(c, np.float64)
    return np.where(c <= 0.04045, c / 12.92, ((c + 0.055) / 1.055) ** 2.4)


# --------------------------------------------------------------------------- geometry
@dataclass(frozen=True)
class ViewerFrame:
    """Model coordinates (Z up, metres) → the viewer's (Y up, centred on the model's box)."""

    origin: NDArray[np.float64]

    @classmethod
    def of(cls, scene: Scene) -> ViewerFrame:
        """Centred on the box of the vertices that faces use (as :meth:`Scene.bounds`, without sorting)."""
        if not len(scene.faces):
            return cls(np.zeros(3))
        used = np.zeros(len(scene.vertices), bool)
        used[scene.faces.ravel()] = True
        v = scene.vertices[used]
        return cls((v.min(0) + v.max(0)) / 2)

    def apply(self, points: NDArray) -> NDArray[np.float64]:
        return z_up_to_y_up(points, self.origin)


@dataclass(frozen=True)
class ElementGeometry:
    """Per-element sub-meshes of a scene, split in one pass.

    elements: (m,) element indices that have faces. vertices: (V', 3) float32 in the viewer
    frame, grouped by element; faces: (F, 3) local indices into the element's own vertices,
    grouped like ``elements``. vertex_start / face_start: (m + 1,) offsets of each group.
    """

    elements: NDArray[np.int64]
    vertices: NDArray[np.float32]
    faces: NDArray[np.uint32]
    vertex_start: NDArray[np.int64]
    face_start: NDArray[np.int64]

    def part(self, k: int) -> tuple[NDArray[np.float32], NDArray[np.uint32]]:
        v0, v1 = self.vertex_start[k], self.vertex_start[k + 1]
        f0, f1 = self.face_start[k], self.face_start[k + 1]
        return self.vertices[v0:v1], self.faces[f0:f1]


def split_elements(scene: Scene, frame: ViewerFrame) -> ElementGeometry:
    """Each element's own vertices and faces, without a Python loop over faces or vertices."""
    order = np.argsort(scene.face_element, kind="stable")
    face_el = scene.face_element[order].astype(np.int64)
    faces = scene.faces[order].astype(np.int64)
    n_vertices = max(len(scene.vertices), 1)
    key = np.repeat(face_el, 3) * n_vertices + faces.ravel()
    unique_key, local_flat = np.unique(key, return_inverse=True)
    vert_el, vert_id = np.divmod(unique_key, n_vertices)
    elements = np.unique(face_el)
    vertex_start = np.r_[np.searchsorted(vert_el, elements), len(vert_el)]
    face_start = np.r_[np.searchsorted(face_el, elements), len(face_el)]
    first_vertex = vertex_start[np.searchsorted(elements, face_el)]
    local = local_flat.reshape(-1, 3) - first_vertex[:, None]
    return ElementGeometry(elements, frame.apply(scene.vertices[vert_id]).astype(np.float32), local.astype(np.uint32),
                           vertex_start, face_start)




def element_extras(scene: Scene, em: ElementMetrics, classes: NDArray[np.int8], i: int) -> dict:
    """What a node's ``extras`` say about element ``i`` (``classes``: :func:`visibility_class`)."""
    el = scene.elements
    return {
        "element": int(i), "global_id": str(el.global_id[i]), "name": str(el.name[i]), "ifc_class": str(el.ifc_class[i]),
        "storey": str(el.storey[i]), "target": bool(em.is_target[i]), "visibility": VISIBILITY_CLASSES[int(classes[i])],
        "VR_i": int(em.VR[i]), "R_i_m_per_px": json_number(em.R[i]), "O_i_deg": json_number(em.O[i]),
        "frames_observed": int(em.frames_observed[i]), "pixels_total": json_number(em.pixels_total[i]),
    }


def node_names(scene: Scene, elements: NDArray[np.int64]) -> list[str]:
    """The GlobalId of each element, made unique with a ``#n`` suffix where a mesh file repeats a name."""
    seen: dict[str, int] = {}
    names = []
    for i in elements:
        gid = str(scene.elements.global_id[i]) or f"element{int(i)}"
        n = seen.get(gid, 0)
        seen[gid] = n + 1
        names.append(gid if n == 0 else f"{gid}#{n}")
    return names


def scene_glb(scene: Scene, metrics: Metrics, colour_by: ColourBy = "visibility",
              bounds: tuple[float, float] | None = None) -> bytes:
    """The scene as GLB bytes, one node per element with geometry, coloured by ``colour_by``."""
    import trimesh
    from trimesh.visual.material import PBRMaterial
    from trimesh.visual.texture import TextureVisuals

    colour_by = check_colour_by(colour_by)
    em = metrics.elements
    if len(em.is_target) != scene.n_elements:
        raise ReportError(f"the metrics cover {len(em.is_target)} elements, the model has {scene.n_elements}")
    rgba = metric_colours(em, colour_by, bounds)
    linear = np.column_stack([srgb_to_linear(rgba[:, :3]), rgba[:, 3]])
    colour_bytes = np.round(linear * 255).astype(np.uint8)
    frame = ViewerFrame.of(scene)
    geometry = split_elements(scene, frame)
    classes = visibility_class(em)
    materials: dict[bytes, PBRMaterial] = {}
    out = trimesh.Scene()
    for k, (i, name) in enumerate(zip(geometry.elements, node_names(scene, geometry.elements))):
        key = colour_bytes[i].tobytes()
        if key not in materials:  # elements of one colour share one material
            opaque = colour_bytes[i, 3] == 255
            materials[key] = PBRMaterial(name=f"#{key.hex()}", baseColorFactor=colour_bytes[i], metallicFactor=0.0,
                                         roughnessFactor=0.9, doubleSided=True, alphaMode="OPAQUE" if opaque else "BLEND")
        vertices, faces = geometry.part(k)
        mesh = trimesh.Trimesh(vertices=vertices, faces=faces, process=False, validate=False,
                               visual=TextureVisuals(material=materials[key]))
        out.add_geometry(mesh, node_name=name, geom_name=name, metadata=element_extras(scene, em, classes, int(i)))
    ends = colour_bounds(em, colour_by, bounds)
    out.metadata["sightplan"] = {
        "colour_by": colour_by, "bounds": None if ends is None else list(ends),
        "origin_m": frame.origin.tolist(), "axes": "x east, y up (model z), z = -(model y)",
        "source": scene.source, "date": None if scene.date is None else str(scene.date)[:10],
    }
    return out.export(file_type="glb", include_normals=False)


def write_gltf(scene: Scene, metrics: Metrics, path: str | Path, colour_by: ColourBy = "visibility",
               bounds: tuple[float, float] | None = None) -> Path:
    """Write the coloured model as binary glTF to ``path``; see :func:`scene_glb`."""
    return write_bytes(path, scene_glb(scene, metrics, colour_by, bounds))
