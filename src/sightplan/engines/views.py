"""Whole-image views of a scene, for pictures: the engine stage's part of the overview.

The report stage colours a :class:`SceneView` without touching the engine again.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from ..camera.models import PinholeCamera
from ..geometry.poses import R_from_gimbal
from .base import Engine


@dataclass(frozen=True)
class SceneView:
    """element: (H, W) int32 id per pixel (−1 background); shade: (H, W) |cos| of ray and surface;
    camera, R_world_camera (3, 3), C_world (3,): the view's pose, to project more points into it."""

    element: NDArray[np.int32]
    shade: NDArray[np.float64]
    camera: PinholeCamera
    R_world_camera: NDArray[np.float64]
    C_world: NDArray[np.float64]

    def project(self, points: NDArray) -> tuple[NDArray, NDArray]:
        """(k,) column and row (pixel-centre convention) of the (k, 3) points in front of the camera."""
        rel = (np.asarray(points, float).reshape(-1, 3) - self.C_world) @ self.R_world_camera
        front = rel[:, 2] > 0
        cam = self.camera
        return (cam.fx * rel[front, 0] / rel[front, 2] + cam.cx - 0.5,
                cam.fy * rel[front, 1] / rel[front, 2] + cam.cy - 0.5)


def fit_pose(points: NDArray, heading_deg: float, pitch_deg: float, width: int = 1200, height: int = 800
             ) -> tuple[PinholeCamera, NDArray, NDArray]:
    """A camera with this heading and pitch, as close as it can be with all (k, 3) points in view."""
    lo, hi = points.min(axis=0), points.max(axis=0)
    centre = (lo + hi) / 2
    cam = PinholeCamera(width, height, 1.1 * width, 1.1 * width, width / 2, height / 2, "overview")
    R = R_from_gimbal(heading_deg, pitch_deg, 0.0)[0]
    rel = (points - centre) @ R  # coordinates in camera axes, camera at the centre
    # a point fits when |x| / (z + d) ≤ (W/2)/fx (and likewise for y): solve for the distance d
    d = max(np.max(np.abs(rel[:, 0]) * cam.fx / (0.47 * width) - rel[:, 2]),
            np.max(np.abs(rel[:, 1]) * cam.fy / (0.47 * height) - rel[:, 2]), 1.0)
    return cam, R, centre - d * R[:, 2]


def overview_pose(points: NDArray, width: int = 1200, height: int = 800) -> tuple[PinholeCamera, NDArray, NDArray]:
    """A camera looking down at 35° from the south-west with all (k, 3) points in view."""
    return fit_pose(points, 45.0, -35.0, width, height)


def overview_view(engine: Engine, extra_points: NDArray | None = None) -> SceneView:
    """The overview of the engine's scene framing the model's box and ``extra_points`` (e.g. camera centres)."""
    lo, hi = engine.scene.bounds()
    points = np.array([[x, y, z] for x in (lo[0], hi[0]) for y in (lo[1], hi[1]) for z in (lo[2], hi[2])])
    if extra_points is not None and len(extra_points):
        points = np.concatenate([points, np.asarray(extra_points, float).reshape(-1, 3)])
    cam, R, C = overview_pose(points)
    ids, _, cos = engine.shaded_view(cam, R, C)
    return SceneView(ids, cos, cam, R, C)


CUT_ABOVE_FLOOR_M = 1.2


def storey_views(scene, engine_name: str = "auto", threads: int | None = None, max_storeys: int = 6
                 ) -> list[tuple[str, SceneView]]:
    """Cutaway views, one per storey (lowest first): the elements that start below
    ``CUT_ABOVE_FLOOR_M`` above the storey's floor, seen from above at 60°.

    A storey's floor is the lowest point of its target elements. Walls of the storey stand
    at full height; slabs, roofs and storeys above are removed, so interior elements show.
    Scenes without storey names (meshes) give no views.
    """
    from .registry import make_engine

    storeys = scene.elements.storey
    tri_z = scene.vertices[scene.faces][:, :, 2]
    n = scene.n_elements
    el_min = np.full(n, np.inf)
    el_max = np.full(n, -np.inf)
    np.minimum.at(el_min, scene.face_element, tri_z.min(axis=1))
    np.maximum.at(el_max, scene.face_element, tri_z.max(axis=1))
    floors = {}
    for name in set(storeys[scene.targets].tolist()) - {""}:
        members = scene.targets & (storeys == name) & np.isfinite(el_min)
        if members.any():
            floors[name] = float(el_min[members].min())
    views = []
    for name, floor in sorted(floors.items(), key=lambda kv: kv[1])[:max_storeys]:
        keep = scene.present & (el_min < floor + CUT_ABOVE_FLOOR_M)
        cut = scene.with_present(keep)
        if len(cut.faces) == 0:
            continue
        members = keep & (storeys == name)
        sel = members[cut.face_element]
        pts = cut.vertices[cut.faces[sel]].reshape(-1, 3) if sel.any() else cut.vertices[cut.faces].reshape(-1, 3)
        cam, R, C = fit_pose(pts, 45.0, -60.0)
        with make_engine(engine_name, cut, threads=threads) as eng:
            ids, _, cos = eng.shaded_view(cam, R, C)
        views.append((name, SceneView(ids, cos, cam, R, C)))
    return views
