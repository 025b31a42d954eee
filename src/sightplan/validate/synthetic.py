"""A reality model made from Γ with known defects (elements removed or moved, noise, a point sampling): test data
for the validation whose answers are known."""

from __future__ import annotations

import hashlib
import math
from collections.abc import Iterable, Mapping
from dataclasses import replace

import numpy as np
from numpy.typing import ArrayLike, NDArray

from ..errors import ModelError
from ..model.pointcloud import PointCloud
from ..model.scene import Scene
from .surface import sample_surface


# =========================================================================== synthetic reality
def outward_normal(scene: Scene, element: int) -> NDArray[np.float64]:
    """Unit normal of the element's largest flat side (faces grouped by normal to 10⁻³), turned away from the
    centre of the scene's bounding box (a tie keeps the winding normal)."""
    sel = scene.face_element == element
    if not sel.any():
        raise ModelError(f"element {element} has no faces in this scene")
    n = scene.face_normals()[sel]
    a = scene.face_areas()[sel]
    key, inv = np.unique(np.round(n, 3), axis=0, return_inverse=True)
    inv = inv.reshape(-1)
    best = int(np.argmax(np.bincount(inv, weights=a, minlength=len(key))))
    normal = (n[inv == best] * a[inv == best, None]).sum(axis=0)
    normal /= np.linalg.norm(normal)
    tri = scene.vertices[scene.faces[sel]]
    centroid = (tri.mean(axis=1) * a[:, None]).sum(axis=0) / max(a.sum(), 1e-300)
    box = scene.bounds()
    return -normal if normal @ (centroid - box.mean(axis=0)) < 0 else normal

def synthetic_reality(scene: Scene, remove: Iterable[int] = (), shift: Mapping[int, float | ArrayLike] | None = None,
                      noise_m: float = 0.0, points_per_m2: float | None = None, seed: int = 0) -> Scene | PointCloud:
    """The model as a reconstruction with known defects, for checks.

    remove: element indices left out. shift: element index → metres along its
    :func:`outward_normal`, or a (3,) vector in metres (its faces get vertices of their own,
    so neighbours stay put). With ``points_per_m2``: round(area·density) points drawn
    uniformly on the result (seeded), each moved by isotropic Gaussian noise of σ = ``noise_m``
    per axis, as a :class:`PointCloud` with the faces' winding normals; else a Scene.
    """
    z = scene.n_elements
    removed = np.zeros(z, bool)
    for i in remove:
        if not 0 <= int(i) < z:
            raise ModelError(f"element index {i} is out of range (0..{z - 1})")
        removed[int(i)] = True
    if not (noise_m >= 0 and math.isfinite(noise_m)):
        raise ModelError(f"noise must be a number of metres ≥ 0, got {noise_m!r}")
    if noise_m > 0 and points_per_m2 is None:
        raise ModelError("noise applies to a point sampling: give points_per_m2")
    keep = ~removed[scene.face_element]
    faces = scene.faces[keep].copy()
    fe = scene.face_element[keep]
    parts = [scene.vertices]
    count = len(scene.vertices)
    for i, amount in (shift or {}).items():
        if not 0 <= int(i) < z:
            raise ModelError(f"element index {i} is out of range (0..{z - 1})")
        vec = np.asarray(amount, np.float64)
        vec = float(vec) * outward_normal(scene, int(i)) if vec.ndim == 0 else vec.reshape(3)
        sel = fe == int(i)
        if not sel.any():
            continue
        corners = scene.vertices[faces[sel]].reshape(-1, 3) + vec
        faces[sel] = count + np.arange(len(corners)).reshape(-1, 3)
        count += len(corners)
        parts.append(corners)
    vertices = np.concatenate(parts)
    h = hashlib.sha256(b"synthetic reality\0")
    for arr in (vertices, faces, fe):
        h.update(np.ascontiguousarray(arr).tobytes())
    psi = replace(scene, vertices=vertices, faces=faces.astype(np.int32), face_element=fe.astype(np.int32),
                  present=scene.present & ~removed, content_hash=h.hexdigest(), source=f"synthetic reality of {scene.source}",
                  metadata={**scene.metadata, "synthetic_reality": {
                      "removed": np.flatnonzero(removed).tolist(),
                      "shift": {int(k): np.asarray(v, float).tolist() for k, v in (shift or {}).items()}}})
    if points_per_m2 is None:
        return psi
    if not (points_per_m2 > 0 and math.isfinite(points_per_m2)):
        raise ModelError(f"points per m² must be a positive number, got {points_per_m2!r}")
    rng = np.random.default_rng(seed)
    n = int(round(float(psi.face_areas().sum()) * points_per_m2))
    if n == 0:
        raise ModelError("the synthetic reality has no surface to sample")
    pts, face = sample_surface(psi.vertices, psi.faces, n, rng)
    if noise_m > 0:
        pts = pts + rng.normal(0.0, noise_m, pts.shape)
    return PointCloud(pts, psi.face_normals()[face])
