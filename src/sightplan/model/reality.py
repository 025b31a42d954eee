"""Reality models: a reconstructed mesh or point cloud as the a-priori model of the site as it is.

A reconstruction has no objects, so its elements are surface patches (:mod:`.patches`); a point cloud is first
turned into a surface (:mod:`.pointcloud`). :func:`load_reality` loads one into a model's frame, and
:func:`combine` puts a BIM and a reality scene together, the reality usually as occluder-only context (existing
structures, scaffolding, terrain, neighbours) that hides BIM elements but is not scored.

Units: metres, Z up (a glTF reality mesh is turned Z up as in :mod:`.mesh`). ``origin_m`` shifts a georeferenced
cloud into a model's local frame.
"""

from __future__ import annotations

import hashlib
import json
from dataclasses import replace
from pathlib import Path
from typing import Literal

import numpy as np
from numpy.typing import ArrayLike

from ..errors import ModelError
from .formats import MESH_EXTENSIONS, POINT_CLOUD_EXTENSIONS
from .load import load_model
from .patches import NORMAL_ANGLE_DEG, PATCH_AREA_M2
from .pointcloud import MeshMethod, is_point_cloud
from .scene import ElementTable, Scene

REALITY_MESH_EXTENSIONS: tuple[str, ...] = MESH_EXTENSIONS

RealityRole = Literal["occluder", "target"]

def _shift(scene: Scene, origin_m: ArrayLike) -> Scene:
    origin = np.asarray(origin_m, np.float64).reshape(3)
    if not np.isfinite(origin).all():
        raise ModelError(f"origin_m must be three finite numbers, got {origin_m!r}")
    h = hashlib.sha256(scene.content_hash.encode())
    h.update(origin.tobytes())
    reality = dict(scene.metadata.get("reality") or {})
    reality["origin_m"] = origin.tolist()
    return replace(scene, vertices=scene.vertices - origin, content_hash=h.hexdigest(),
                   metadata={**scene.metadata, "reality": reality})

def load_reality(path: str | Path, patch_area_m2: float = PATCH_AREA_M2, spacing_m: float | None = None, *,
                 normal_angle_deg: float = NORMAL_ANGLE_DEG, method: MeshMethod = "voxel", solid: bool = False,
                 scale: float = 1.0, up: Literal["auto", "y", "z"] = "auto", origin_m: ArrayLike | None = None,
                 cache: bool = True, cache_dir: str | Path | None = None) -> Scene:
    """A reality model (mesh or point cloud) as a Scene of surface patches, all targets.

    .las/.laz and face-less .ply are point clouds, meshed by :func:`points_to_mesh`
    (``spacing_m``, ``method``, ``solid``); .obj/.ply/.stl/.gltf/.glb are meshes (``up`` as in
    :mod:`.mesh`). Elements are named 'patch 00001', ..., class RealityPatch, no discipline.
    ``origin_m`` (after ``scale``) is subtracted from every coordinate. Cached like :func:`load_model`.
    """
    path = Path(path).expanduser()
    if not path.is_file():
        raise ModelError(f"reality model file not found: {path}")
    common = {"elements": "patches", "patch_area_m2": patch_area_m2, "normal_angle_deg": normal_angle_deg, "scale": scale}
    if is_point_cloud(path):
        opts = {**common, "spacing_m": spacing_m, "method": method, "solid": solid}
    elif path.suffix.lower() in REALITY_MESH_EXTENSIONS:
        opts = {**common, "up": up}
    else:
        supported = ", ".join(REALITY_MESH_EXTENSIONS + POINT_CLOUD_EXTENSIONS)
        raise ModelError(f"{path.name}: unsupported reality model format {path.suffix or '(no extension)'!r}; "
                         f"supported: {supported}")
    scene, _ = load_model(path, cache=cache, cache_dir=cache_dir, **opts)
    if "reality" not in scene.metadata:
        scene = replace(scene, metadata={**scene.metadata, "reality": {
            "kind": "mesh", "patch_area_m2": float(patch_area_m2), "normal_angle_deg": float(normal_angle_deg)}})
    return scene if origin_m is None else _shift(scene, origin_m)

# =========================================================================== BIM + reality
def combine(bim: Scene, reality: Scene, reality_role: RealityRole = "occluder") -> Scene:
    """One scene of a BIM model and a reality model in the same frame.

    Elements: the BIM's first (their indices are unchanged), then the reality's. With
    ``reality_role="occluder"`` the reality elements are occluder-only (``is_target``
    False): they hide BIM elements behind them but do not count in ``z``; ``"target"``
    keeps them as they are. The BIM's metadata, source and date are kept; metadata
    ``"reality"`` records the reality source, role and element range. Reality elements have
    no schedule dates, so they exist at every date of :meth:`Scene.at` (default ``unscheduled``).
    """
    if reality_role not in ("occluder", "target"):
        raise ModelError(f"reality role must be 'occluder' or 'target', got {reality_role!r}")
    if reality.date is not None:
        raise ModelError("the reality scene has a date of its own; combine the undated reality model")
    _check_same_frame(bim, reality)
    z_bim = bim.n_elements
    rel = reality.elements
    is_target = np.zeros(len(rel), bool) if reality_role == "occluder" else rel.is_target
    elements = ElementTable(
        *(np.concatenate([getattr(bim.elements, c), getattr(rel, c)])
          for c in ("global_id", "name", "ifc_class", "discipline", "storey")),
        is_target=np.concatenate([bim.elements.is_target, is_target]),
        start=np.concatenate([bim.elements.start, rel.start]).astype("datetime64[s]"),
        finish=np.concatenate([bim.elements.finish, rel.finish]).astype("datetime64[s]"),
    )
    vertices = np.concatenate([bim.vertices, reality.vertices])
    faces = np.concatenate([bim.faces, reality.faces + len(bim.vertices)])
    face_element = np.concatenate([bim.face_element, reality.face_element + z_bim])
    h = hashlib.sha256(b"combine\0")
    for part in (bim.content_hash, reality.content_hash, reality_role):
        h.update(part.encode() + b"\0")
    record = {"source": reality.source, "content_hash": reality.content_hash, "role": reality_role,
              "elements": [z_bim, z_bim + len(rel)], "metadata": json.loads(json.dumps(reality.metadata, default=str))}
    scene = Scene.from_arrays(vertices, faces, face_element, elements, bim.source, h.hexdigest(),
                              {**bim.metadata, "reality": record})
    return replace(scene, present=np.concatenate([bim.present, reality.present]), date=bim.date)

def _check_same_frame(bim: Scene, reality: Scene) -> None:
    """A ModelError when the two scenes' boxes lie over 1 km and ten times their size apart (different frames)."""
    if len(bim.faces) == 0 or len(reality.faces) == 0:
        return
    a, b = bim.bounds(), reality.bounds()
    gap = float(np.linalg.norm(np.maximum(0.0, np.maximum(a[0] - b[1], b[0] - a[1]))))
    size = max(float(np.linalg.norm(a[1] - a[0])), float(np.linalg.norm(b[1] - b[0])))
    if gap > max(1000.0, 10 * size):
        raise ModelError(f"the reality model lies {gap:.0f} m from the BIM model: are they in the same frame? "
                         "(load_reality's origin_m moves a georeferenced reality into the model's frame)")
