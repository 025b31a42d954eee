"""Reality or design meshes (OBJ, PLY, STL, glTF/GLB) → :class:`Scene`, read with trimesh.

An element is, by ``elements``:

- ``"objects"``: one per geometry node of the file (OBJ ``o`` objects, glTF nodes; a
  PLY/STL file is one object), with the node transforms applied;
- ``"components"``: one per connected component of the whole mesh (faces sharing an
  edge after merging coincident vertices);
- ``"faces"``: one per triangle (a reality mesh used as a-priori model, METRICS.md §1);
- ``"patches"``: connected surface patches of about ``patch_area_m2`` whose normals stay
  within ``normal_angle_deg`` (:func:`sightplan.model.patches.patch_faces`), named
  'patch 00001', ... with class RealityPatch: a reconstruction without objects.

Units: the file is taken to be in metres; ``scale`` multiplies every coordinate.
Axes: the scene is Z-up. glTF is Y-up by specification, so ``up="auto"`` rotates .gltf
and .glb files by +90° about X ((x, y, z) → (x, −z, y)); other formats are taken as
Z-up. ``up="y"`` or ``"z"`` forces one convention.
"""

from __future__ import annotations

import time
from pathlib import Path
from typing import Literal

import numpy as np
import trimesh

from ..errors import ModelError
from ..geometry.axes import y_up_to_z_up
from .cache import content_hash
from .scene import ElementTable, Scene
from .summary import LoadReport, SkippedProduct

MeshGrouping = Literal["objects", "components", "faces", "patches"]
UpAxis = Literal["auto", "y", "z"]
_GROUPINGS = ("objects", "components", "faces", "patches")
_Y_UP_FORMATS = (".gltf", ".glb")


def mesh_options(path: str | Path, elements: MeshGrouping = "objects", scale: float = 1.0, up: UpAxis = "auto",
                 patch_area_m2: float | None = None, normal_angle_deg: float | None = None) -> dict:
    """The loader options that change the scene, canonicalised (part of the content hash).

    The patch options are part of it only for ``elements="patches"`` (defaults filled in).
    """
    if elements not in _GROUPINGS:
        raise ModelError(f"elements must be one of {', '.join(_GROUPINGS)}, got {elements!r}")
    if up not in ("auto", "y", "z"):
        raise ModelError(f"up must be 'auto', 'y' or 'z', got {up!r}")
    if not np.isfinite(scale) or scale <= 0:
        raise ModelError(f"scale must be a positive number, got {scale!r}")
    y_up = up == "y" or (up == "auto" and Path(path).suffix.lower() in _Y_UP_FORMATS)
    options = {"loader": "mesh", "elements": elements, "scale": float(scale), "y_up": y_up}
    if elements == "patches":
        from .patches import patch_options

        area, angle = patch_options(patch_area_m2, normal_angle_deg)
        options.update(patch_area_m2=area, normal_angle_deg=angle)
    elif patch_area_m2 is not None or normal_angle_deg is not None:
        raise ModelError(f"patch_area_m2 and normal_angle_deg apply to elements='patches', not {elements!r}")
    return options


def _read(path: Path) -> trimesh.Scene:
    """The file as a trimesh.Scene, every parser failure turned into a ModelError."""
    if not path.is_file():
        raise ModelError(f"model file not found: {path}")
    if path.stat().st_size == 0:
        raise ModelError(f"{path.name} is empty")
    kwargs = {"split_objects": True, "group_material": False} if path.suffix.lower() == ".obj" else {}
    try:
        return trimesh.load(str(path), force="scene", **kwargs)
    except Exception as exc:  # trimesh's parsers raise IndexError, ValueError, KeyError, struct.error, ...
        raise ModelError(f"{path.name} cannot be read as a mesh: {type(exc).__name__}: {exc}") from exc


def _flatten(tm_scene: trimesh.Scene) -> tuple[list[str], list[np.ndarray], list[np.ndarray], list[SkippedProduct]]:
    """Per triangle-mesh node: name, (n, 3) world vertices, (m, 3) faces; other nodes as skipped."""
    names, verts, faces, skipped = [], [], [], []
    for node in tm_scene.graph.nodes_geometry:
        transform, geom_name = tm_scene.graph[node]
        geom = tm_scene.geometry[geom_name]
        if not isinstance(geom, trimesh.Trimesh):
            skipped.append(SkippedProduct(str(node), type(geom).__name__, str(node), "not a triangle mesh"))
            continue
        if len(geom.faces) == 0:
            skipped.append(SkippedProduct(str(node), "Trimesh", str(node), "no triangles"))
            continue
        v = np.asarray(geom.vertices, np.float64)
        verts.append(v @ transform[:3, :3].T + transform[:3, 3])
        faces.append(np.asarray(geom.faces, np.int64))
        names.append(str(node))
    return names, verts, faces, skipped


def _components(vertices: np.ndarray, faces: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Merge coincident vertices; return (vertices, faces, (F,) component label, dense from 0)."""
    mesh = trimesh.Trimesh(vertices, faces, process=True, validate=False)
    if len(mesh.faces) != len(faces):  # process must not drop faces, or labels would misalign
        raise ModelError("internal: vertex merging changed the face count")
    labels = trimesh.graph.connected_component_labels(mesh.face_adjacency, node_count=len(mesh.faces))
    _, dense = np.unique(labels, return_inverse=True)
    return np.asarray(mesh.vertices), np.asarray(mesh.faces), dense.astype(np.int32)


def load_mesh(
    path: str | Path, *, elements: MeshGrouping = "objects", scale: float = 1.0, up: UpAxis = "auto",
    patch_area_m2: float | None = None, normal_angle_deg: float | None = None,
) -> tuple[Scene, LoadReport]:
    """Load a mesh file as a Scene in metres (Z up), elements grouped by ``elements``; see the module docstring."""
    t0 = time.perf_counter()
    path = Path(path)
    options = mesh_options(path, elements, scale, up, patch_area_m2, normal_angle_deg)
    names, verts, faces, skipped = _flatten(_read(path))
    if not verts:
        raise ModelError(f"{path.name}: the mesh has no triangles")
    offsets = np.cumsum([0] + [len(v) for v in verts[:-1]])
    counts = np.array([len(f) for f in faces])
    vertices = np.concatenate(verts) * options["scale"]
    all_faces = np.concatenate(faces) + np.repeat(offsets, counts)[:, None]
    if options["y_up"]:
        vertices = y_up_to_z_up(vertices)

    if elements == "objects":
        face_element = np.repeat(np.arange(len(names), dtype=np.int32), counts)
        ids = names
    elif elements == "components":
        vertices, all_faces, face_element = _components(vertices, all_faces)
        ids = [f"component{i}" for i in range(int(face_element.max()) + 1)]
    elif elements == "patches":
        from .patches import patch_faces, patch_table

        face_element, n_patches = patch_faces(vertices, all_faces, options["patch_area_m2"], options["normal_angle_deg"])
        table = patch_table(n_patches)
        ids = table.global_id.tolist()
    else:
        face_element = np.arange(len(all_faces), dtype=np.int32)
        ids = [f"face{i}" for i in range(len(all_faces))]

    if elements != "patches":
        table = ElementTable.build(global_id=ids, name=ids)
    key = content_hash(path, options)
    fmt = path.suffix.lower().lstrip(".")
    metadata = {"schema": fmt, "unit_scale": options["scale"], "georeference": None, "y_up_converted": options["y_up"]}
    scene = Scene.from_arrays(vertices, all_faces, face_element, table, str(path), key, metadata)
    report = LoadReport(
        source=str(path),
        schema=fmt,
        unit_scale=options["scale"],
        n_products=len(ids) + len(skipped),
        n_elements=len(ids),
        n_targets=len(ids),
        n_triangles=len(scene.faces),
        skipped=tuple(skipped),
        warnings=(),
        elapsed_s=time.perf_counter() - t0,
    )
    return scene, report
