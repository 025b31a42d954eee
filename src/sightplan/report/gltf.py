"""The model as a coloured binary glTF (.glb): one node per element, coloured by a metric.

Each element with geometry becomes one mesh and one node named by its GlobalId, whose
``extras`` hold the element's index, name, IFC class, storey and metric values. Target
elements are coloured by the chosen metric on a traffic-light gradient (green good →
yellow → red bad) between two bounds; target elements the plan does not see are red;
occluders are grey and semi-transparent. Coordinates are centred on the model's box and
turned from the model's Z-up to glTF's Y-up: (x, y, z) → (x − cx, z − cz, −(y − cy)).
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

import numpy as np
from numpy.typing import NDArray

from ..errors import ReportError
from ..geometry.axes import z_up_to_y_up
from ..metrics import Metrics
from ..metrics.elements import ElementMetrics
from ..model.scene import Scene
from .colours import (
    VISIBILITY_CLASSES,
    ColourBy,
    check_colour_by,
    colour_bounds,
    metric_colours,
    srgb_to_linear,
    visibility_class,
)
from .files import write_bytes
from .tables import json_number


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
