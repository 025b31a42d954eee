"""Whole-image views of a scene, for pictures: the engine stage's part of the overview.

The report stage colours a :class:`SceneView` without touching the engine again. :func:`picture_views` keeps the
views of a report's pictures in a cache of their own, so a re-evaluation draws its pictures without building an
engine: a view depends on the scene and on where its camera stands, not on the metrics that colour it.
"""

from __future__ import annotations

import hashlib
import os
from dataclasses import dataclass
from pathlib import Path

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


def overview_framing(scene, extra_points: NDArray | None = None) -> tuple[PinholeCamera, NDArray, NDArray]:
    """The overview's camera and pose: framing the scene's box and ``extra_points`` (e.g. camera centres)."""
    lo, hi = scene.bounds()
    points = np.array([[x, y, z] for x in (lo[0], hi[0]) for y in (lo[1], hi[1]) for z in (lo[2], hi[2])])
    if extra_points is not None and len(extra_points):
        points = np.concatenate([points, np.asarray(extra_points, float).reshape(-1, 3)])
    return overview_pose(points)


def overview_view(engine: Engine, extra_points: NDArray | None = None) -> SceneView:
    """The overview of the engine's scene framing the model's box and ``extra_points`` (e.g. camera centres)."""
    cam, R, C = overview_framing(engine.scene, extra_points)
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


#: Bump when what a picture's view holds changes (framing, cutaways, shading): cached views are then cast again.
VIEW_RULES = 1
MAX_STOREYS = 6


def default_views_dir() -> Path:
    """Where the views of pictures are cached: ``views`` under :func:`~sightplan.model.cache.cache_root`."""
    from ..model.cache import cache_root

    return cache_root() / "views"


def _stored(view: SceneView) -> SceneView:
    """The view as the cache holds it (shade in float32), so a first run and a cached one draw the same picture."""
    return SceneView(np.asarray(view.element, np.int32), np.asarray(view.shade, np.float32), view.camera,
                     view.R_world_camera, view.C_world)


def views_key(scene, engine_name: str, framing: tuple[PinholeCamera, NDArray, NDArray] | None = None) -> str:
    """The cache key of a picture's views: the version and view rules, the scene (geometry, which elements stand,
    which are targets), the engine that casts them (its resolved name) and, for the overview, its camera and pose
    (``framing``); without one, the storeys' cutaways (which the scene alone frames)."""
    from ..version import __version__

    parts: tuple = (__version__, VIEW_RULES, scene.key, engine_name)
    if framing is None:
        parts += ("storeys", CUT_ABOVE_FLOOR_M, MAX_STOREYS)
    else:
        cam, R, C = framing
        parts += ("overview", (cam.width, cam.height, cam.fx, cam.fy, cam.cx, cam.cy), np.asarray(R, float).tobytes(),
                  np.asarray(C, float).tobytes())
    return hashlib.sha256(repr(parts).encode()).hexdigest()[:32]


def _read_views(path: Path | None) -> list[tuple[str, SceneView]] | None:
    if path is None:
        return None
    try:
        with np.load(path, allow_pickle=False) as z:
            views = []
            for k, name in enumerate(str(x) for x in z["names"]):
                w, h, fx, fy, cx, cy = (float(x) for x in z[f"camera_{k}"])
                cam = PinholeCamera(int(w), int(h), fx, fy, cx, cy, "overview")
                views.append((name, SceneView(z[f"element_{k}"], z[f"shade_{k}"], cam, z[f"R_{k}"], z[f"C_{k}"])))
    except (OSError, ValueError, KeyError):
        return None
    return views


def _write_views(path: Path | None, views: list[tuple[str, SceneView]]) -> None:
    if path is None:
        return
    arrays: dict[str, NDArray] = {"names": np.array([name for name, _ in views], dtype=str)}
    for k, (_, view) in enumerate(views):
        cam = view.camera
        arrays |= {f"element_{k}": view.element, f"shade_{k}": view.shade, f"R_{k}": view.R_world_camera,
                   f"C_{k}": view.C_world,
                   f"camera_{k}": np.array([cam.width, cam.height, cam.fx, cam.fy, cam.cx, cam.cy], float)}
    try:
        path.parent.mkdir(parents=True, exist_ok=True)
        tmp = path.with_suffix(f".{os.getpid()}.tmp.npz")
        np.savez_compressed(tmp, **arrays)
        os.replace(tmp, path)
    except OSError:
        pass  # a cache that cannot be written only costs time


def picture_views(scene, extra_points: NDArray | None = None, engine_name: str = "auto", threads: int | None = None,
                  cache_dir: str | Path | None | bool = None) -> tuple[SceneView, list[tuple[str, SceneView]], int]:
    """(overview, storey cutaways, how many of the two were read from the cache) of a report's pictures: the
    overview framing the scene and ``extra_points`` (:func:`overview_view`) and the storeys' cutaways
    (:func:`storey_views`).

    Each is read from the views cache when it holds it, and no engine is built for it; else cast (an engine for the
    overview, one per storey cutaway) and cached. The overview's entry is keyed by its framing too, so a plan whose
    frames stand elsewhere casts a new overview but reads the cutaways. ``cache_dir``: a folder, None for the default
    one, False for none.
    """
    from .registry import make_engine, resolve_engine

    engine_name = resolve_engine(engine_name)
    framing = overview_framing(scene, extra_points)
    folder = None if cache_dir is False else default_views_dir() if cache_dir is None else Path(cache_dir)

    def entry(key: str) -> Path | None:
        return None if folder is None else folder / key[:2] / f"{key}.npz"

    hits = 0
    overview_path = entry(views_key(scene, engine_name, framing))
    known = _read_views(overview_path)
    if known is not None and len(known) == 1:
        overview, hits = known[0][1], hits + 1
    else:
        cam, R, C = framing
        with make_engine(engine_name, scene, threads=threads) as eng:
            ids, _, cos = eng.shaded_view(cam, R, C)
        overview = _stored(SceneView(ids, cos, cam, R, C))
        _write_views(overview_path, [("overview", overview)])
    storeys_path = entry(views_key(scene, engine_name))
    storeys = _read_views(storeys_path)
    if storeys is not None:
        hits += 1
    else:
        storeys = [(name, _stored(view)) for name, view in storey_views(scene, engine_name, threads, MAX_STOREYS)]
        _write_views(storeys_path, storeys)
    return overview, storeys, hits
