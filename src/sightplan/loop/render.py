"""Synthetic photographs of a plan: every frame rendered through a visibility engine's own rays, each surface in its
element's procedural texture (:mod:`.texture`), with exact intrinsics and the true poses beside the images.

A render directory holds

- ``frame_00000.png`` …: one 8-bit RGB image per plan frame, in plan order (the scaled camera's size);
- ``render.json``: the frame and image names, the cameras (scaled), each frame's pose (``R_world_camera``,
  ``C_world``), the scene's size, the engine, the scale, the texture's cell size, the elements' GlobalIds in the
  scene's element order, and the frames that show no element;
- ``poses/``: the true poses as a COLMAP text model (``cameras.txt`` PINHOLE with the scaled intrinsics,
  ``images.txt``, an empty ``points3D.txt``), which ``load_plan(..., fmt="colmap")`` reads back;
- ``elements.npz``: per frame (key ``frame_00000`` …) the (H, W) int32 element index each pixel shows (−1: sky),
  exactly the engine's :meth:`~sightplan.engines.base.Engine.element_map` of the frame (ties rule included);
- ``depth.npz``: per frame the (H, W) float32 distance along each pixel's ray to the surface it shows (inf: sky),
  from which :func:`surface_samples` gives the world points the renders saw.

The pixel at the centre of pixel (u, v) is the surface its centre ray meets first, as the evaluator counts it: no
anti-aliasing across pixels, so the element map and the image agree pixel for pixel.
"""

from __future__ import annotations

import json
import math
import time
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path

import numpy as np
from numpy.typing import NDArray

from ..camera.models import PinholeCamera
from ..errors import SightplanError
from ..geometry.poses import quaternion_from_R
from ..model.scene import Scene
from ..plan.types import Plan
from . import texture

RENDER_FILE = "render.json"
ELEMENTS_FILE = "elements.npz"
DEPTH_FILE = "depth.npz"
POSES_DIR = "poses"
FORMAT = "sightplan-render"
CELL_PER_SSD = 6.0  # the finest texture octave's cell, in surface sampling distances of the plan's typical view
PREVIEW_PX = 96  # the width of the quick views that measure the plan's typical sampling distance
PREVIEW_FRAMES = 16

Progress = Callable[[int, int], None]


@dataclass(frozen=True)
class Renders:
    """What :func:`render_plan` wrote into ``directory``.

    image_names: one file name per plan frame, in plan order (``directory / name``). frame_names: the plan's own
    frame names. scene_size_m: the scene's bounding-box diagonal. blank_frames: indices of frames whose render shows
    no element. cameras, camera_of, R_world_camera, C_world: the scaled cameras and the true poses. global_ids: the
    scene's elements in index order (element maps index them).
    """

    directory: Path
    image_names: tuple[str, ...]
    frame_names: tuple[str, ...]
    scene_size_m: float
    blank_frames: tuple[int, ...]
    cameras: dict[str, PinholeCamera]
    camera_of: tuple[str, ...]
    R_world_camera: NDArray[np.float64]
    C_world: NDArray[np.float64]
    global_ids: tuple[str, ...]
    engine: str = ""
    scale: float = 1.0
    texture_cell_m: float = 0.0

    def __len__(self) -> int:
        return len(self.image_names)

    def camera(self, i: int) -> PinholeCamera:
        return self.cameras[self.camera_of[i]]


def _image_name(i: int) -> str:
    return f"frame_{i:05d}.png"


def _key(i: int) -> str:
    return f"frame_{i:05d}"


def scene_size(scene: Scene) -> float:
    """The scene's bounding-box diagonal in metres."""
    lo, hi = scene.bounds()
    return float(np.linalg.norm(hi - lo))


def _check_cameras(plan: Plan) -> None:
    for cid, cam in plan.cameras.items():
        if not isinstance(cam, PinholeCamera):
            raise SightplanError(f"camera {cid!r} is {cam.kind}: the renderer draws pinhole frames only (an "
                                 "equirectangular frame cannot be reconstructed with a pinhole SfM); render a plan "
                                 "of pinhole cameras")


def _rays(cam: PinholeCamera, R: NDArray) -> NDArray[np.float32]:
    from ..engines.base import Engine

    n = cam.width * cam.height
    dirs = np.empty((n, 3), np.float32)
    Engine.pixel_directions(cam, np.ascontiguousarray(R, np.float64), 0, n, dirs)
    return dirs


def typical_sampling_distance(engine, plan: Plan, scale: float) -> float:
    """The median surface sampling distance (metres per pixel) of the plan's frames at ``scale``, from quick
    low-resolution views of up to :data:`PREVIEW_FRAMES` frames spread over the plan; NaN if none sees a surface."""
    n = len(plan)
    picks = np.unique(np.linspace(0, n - 1, min(n, PREVIEW_FRAMES)).round().astype(int)) if n else []
    ssd = []
    for i in picks:
        cam = plan.camera_of(int(i))
        full = cam.scaled(scale) if scale != 1 else cam
        s = min(1.0, PREVIEW_PX / cam.width)
        _, t, _ = engine.shaded_view(cam, plan.R_world_camera[i], plan.C_world[i], s)
        hit = np.isfinite(t)
        if hit.any():
            ssd.append(float(np.median(t[hit])) / full.sampling_focal_px)
    return float(np.median(ssd)) if ssd else math.nan


def _colmap_text(directory: Path, cameras: dict[str, PinholeCamera], camera_of: list[str], R: NDArray, C: NDArray,
                 names: list[str]) -> None:
    """The true poses as a COLMAP text model: cameras.txt, images.txt, an empty points3D.txt."""
    directory.mkdir(parents=True, exist_ok=True)
    ids = {cid: k + 1 for k, cid in enumerate(cameras)}
    lines = ["# CAMERA_ID MODEL WIDTH HEIGHT PARAMS[] (PINHOLE: fx fy cx cy, top-left pixel centre at 0.5)"]
    lines += [f"{ids[cid]} PINHOLE {c.width} {c.height} {c.fx!r} {c.fy!r} {c.cx!r} {c.cy!r}" for cid, c in cameras.items()]
    (directory / "cameras.txt").write_text("\n".join(lines) + "\n")
    R_cw = np.transpose(R, (0, 2, 1))
    t = -np.einsum("nij,nj->ni", R_cw, C)
    q = quaternion_from_R(R_cw)
    lines = ["# IMAGE_ID QW QX QY QZ TX TY TZ CAMERA_ID NAME", "# POINTS2D[] as (X, Y, POINT3D_ID)"]
    for k, name in enumerate(names):
        lines.append(" ".join([str(k + 1), *(repr(float(x)) for x in q[k]), *(repr(float(x)) for x in t[k]),
                               str(ids[camera_of[k]]), name]))
        lines.append("")
    (directory / "images.txt").write_text("\n".join(lines) + "\n")
    (directory / "points3D.txt").write_text("# POINT3D_ID X Y Z R G B ERROR TRACK[] as (IMAGE_ID, POINT2D_IDX)\n")


def shade_frame(engine, cam: PinholeCamera, R: NDArray, C: NDArray, seeds: NDArray[np.uint64],
                colours: NDArray[np.float64], cell_m: float) -> tuple[NDArray[np.uint8], NDArray[np.int32],
                                                                      NDArray[np.float32]]:
    """One frame at the camera's own size: (H, W, 3) uint8 image, (H, W) element map, (H, W) float32 distance.

    The element map and the distances are the engine's :meth:`shaded_view`; the colour of a pixel is its element's
    texture at the world point its centre ray meets (camera centre + distance · direction), times the shading."""
    ids, t, cos = engine.shaded_view(cam, R, C)
    H, W = ids.shape
    dirs = _rays(cam, R).astype(np.float64)
    flat_ids, flat_t = ids.reshape(-1), t.reshape(-1)
    hit = np.flatnonzero(flat_ids >= 0)
    rgb = texture.sky(dirs)
    if len(hit):
        e = flat_ids[hit]
        points = np.asarray(C, np.float64) + flat_t[hit, None] * dirs[hit]
        footprint = flat_t[hit] / cam.sampling_focal_px
        surface = texture.albedo(points, seeds[e], colours[e], cell_m, footprint)
        rgb[hit] = surface * texture.shading(cos.reshape(-1)[hit])[:, None]
    image = np.clip(np.rint(rgb * 255.0), 0, 255).astype(np.uint8).reshape(H, W, 3)
    return image, ids.astype(np.int32), t.astype(np.float32)


def render_plan(scene: Scene, plan: Plan, out_dir: str | Path, *, scale: float = 1.0, engine: str = "embree",
                progress: Progress | None = None, texture_cell_m: float | None = None,
                threads: int | None = None, stages: Callable[[str, int, int], None] | None = None) -> Renders:
    """Render every frame of ``plan`` over ``scene`` into ``out_dir`` (see the module's description of the files).

    scale: resolution scale of the images (the cameras written are the scaled ones). engine: a visibility engine's
    name ("embree", "gl", "trimesh", "auto"). texture_cell_m: the finest texture octave's cell in metres (default:
    :data:`CELL_PER_SSD` times the plan's typical surface sampling distance at this scale). progress(done, total):
    called after each frame. stages(name, done, total): hears every stage by name: 'engine' (the engine and the
    texture cell), 'frames' (after each frame, as ``progress``) and 'writing' (the element maps and depths)."""
    from PIL import Image

    from ..engines import make_engine

    if not 0 < scale <= 1:
        raise SightplanError(f"--scale must be in (0, 1], got {scale}")
    if len(plan) == 0:
        raise SightplanError("the plan has no frames to render")
    _check_cameras(plan)
    if len(scene.faces) == 0:
        raise SightplanError("the scene has no surfaces to render (no element exists at this date?)")
    out = Path(out_dir)
    try:
        out.mkdir(parents=True, exist_ok=True)
    except OSError as exc:
        raise SightplanError(f"cannot create the render folder {out}: {exc}") from None
    global_ids = [str(g) for g in scene.elements.global_id]
    seeds = np.array([texture.element_seed(g) for g in global_ids], np.uint64)
    colours = np.array([texture.element_colour(int(s)) for s in seeds]).reshape(-1, 3)
    cams = {cid: (c.scaled(scale) if scale != 1 else c) for cid, c in plan.cameras.items()}
    camera_of = [str(c) for c in plan.frame_camera]
    names = [_image_name(i) for i in range(len(plan))]
    maps: dict[str, NDArray] = {}
    depths: dict[str, NDArray] = {}
    blank: list[int] = []
    started = time.perf_counter()

    def stage(name: str, done: int, total: int) -> None:
        if stages is not None:
            stages(name, done, total)

    stage("engine", 0, 1)
    with make_engine(engine, scene, threads=threads) as eng:
        engine_name = eng.name
        cell = texture_cell_m
        if cell is None:
            ssd = typical_sampling_distance(eng, plan, scale)
            cell = CELL_PER_SSD * ssd if math.isfinite(ssd) else scene_size(scene) / 200
        if not (cell > 0 and math.isfinite(cell)):
            raise SightplanError(f"the texture cell must be a positive length in metres, got {cell}")
        stage("engine", 1, 1)
        stage("frames", 0, len(plan))
        for i in range(len(plan)):
            cam = cams[camera_of[i]]
            image, ids, t = shade_frame(eng, cam, plan.R_world_camera[i], plan.C_world[i], seeds, colours, cell)
            Image.fromarray(image, "RGB").save(out / names[i], optimize=False, compress_level=1)
            maps[_key(i)] = ids
            depths[_key(i)] = t
            if not (ids >= 0).any():
                blank.append(i)
            if progress is not None:
                progress(i + 1, len(plan))
            stage("frames", i + 1, len(plan))
    stage("writing", 0, 0)
    np.savez_compressed(out / ELEMENTS_FILE, **maps)
    np.savez_compressed(out / DEPTH_FILE, **depths)
    _colmap_text(out / POSES_DIR, cams, camera_of, plan.R_world_camera, plan.C_world, names)
    frame_names = [str(n) for n in plan.frame_names]
    size = scene_size(scene)
    (out / RENDER_FILE).write_text(json.dumps({
        "format": FORMAT, "version": 1, "engine": engine_name, "scale": float(scale), "texture_cell_m": float(cell),
        "scene_size_m": size, "scene": scene.source, "cameras": {cid: c.to_dict() for cid, c in cams.items()},
        "frames": [{"name": frame_names[i], "image": names[i], "camera": camera_of[i],
                    "R_world_camera": np.asarray(plan.R_world_camera[i], float).tolist(),
                    "C_world": np.asarray(plan.C_world[i], float).tolist()} for i in range(len(plan))],
        "blank_frames": blank, "elements": global_ids, "seconds": round(time.perf_counter() - started, 3),
    }, indent=1))
    return read_renders(out)


def read_renders(directory: str | Path) -> Renders:
    """What ``render.json`` in ``directory`` says; a :class:`SightplanError` if it is not a render folder."""
    from ..camera.models import camera_from_dict

    d = Path(directory)
    path = d / RENDER_FILE
    if not path.is_file():
        raise SightplanError(f"{d} has no {RENDER_FILE}: it is not a folder written by `sightplan render`")
    try:
        doc = json.loads(path.read_text())
        if doc.get("format") != FORMAT:
            raise ValueError(f"format is {doc.get('format')!r}, not {FORMAT!r}")
        cameras = {str(k): camera_from_dict(v) for k, v in doc["cameras"].items()}
        frames = doc["frames"]
        renders = Renders(
            directory=d, image_names=tuple(str(f["image"]) for f in frames),
            frame_names=tuple(str(f["name"]) for f in frames), scene_size_m=float(doc["scene_size_m"]),
            blank_frames=tuple(int(i) for i in doc["blank_frames"]), cameras=cameras,  # type: ignore[arg-type]
            camera_of=tuple(str(f["camera"]) for f in frames),
            R_world_camera=np.array([f["R_world_camera"] for f in frames], np.float64).reshape(-1, 3, 3),
            C_world=np.array([f["C_world"] for f in frames], np.float64).reshape(-1, 3),
            global_ids=tuple(str(g) for g in doc["elements"]), engine=str(doc.get("engine", "")),
            scale=float(doc.get("scale", 1.0)), texture_cell_m=float(doc.get("texture_cell_m", 0.0)))
    except (OSError, ValueError, KeyError, TypeError, json.JSONDecodeError) as exc:
        raise SightplanError(f"{path} is not a readable render description: {exc}") from None
    if set(renders.camera_of) - set(cameras):
        raise SightplanError(f"{path}: frames use cameras it does not define")
    return renders


def _load_maps(directory: Path, file: str, n: int) -> list[NDArray]:
    path = directory / file
    if not path.is_file():
        raise SightplanError(f"{directory} has no {file}: render the plan again with `sightplan render`")
    try:
        with np.load(path) as z:
            return [np.asarray(z[_key(i)]) for i in range(n)]
    except (OSError, ValueError, KeyError) as exc:
        raise SightplanError(f"{path} is not readable: {exc}") from None


def element_maps(directory: str | Path) -> list[NDArray[np.int32]]:
    """Per plan frame, in plan order, the (H, W) int32 element index each pixel of its render shows (−1: sky).

    A list rather than one array because a plan's cameras may differ in size; ``np.stack`` it when they do not."""
    d = Path(directory)
    return [m.astype(np.int32) for m in _load_maps(d, ELEMENTS_FILE, len(read_renders(d)))]


def depth_maps(directory: str | Path) -> list[NDArray[np.float32]]:
    """Per plan frame the (H, W) float32 distance along each pixel's centre ray to the surface shown (inf: sky)."""
    d = Path(directory)
    return _load_maps(d, DEPTH_FILE, len(read_renders(d)))


def surface_samples(directory: str | Path, stride: int = 1) -> tuple[NDArray[np.float64], NDArray[np.int32],
                                                                   NDArray[np.int32]]:
    """The world points the renders saw: (n, 3) points, (n,) element index and (n,) frame index of every
    ``stride``-th pixel (in both directions) of every frame that shows a surface."""
    d = Path(directory)
    r = read_renders(d)
    ids, depth = element_maps(d), depth_maps(d)
    pts, els, frames = [], [], []
    for i in range(len(r)):
        cam = r.camera(i)
        dirs = _rays(cam, r.R_world_camera[i]).reshape(cam.height, cam.width, 3)[::stride, ::stride].reshape(-1, 3)
        e = ids[i][::stride, ::stride].reshape(-1)
        t = depth[i][::stride, ::stride].reshape(-1).astype(np.float64)
        hit = e >= 0
        pts.append(r.C_world[i] + t[hit, None] * dirs[hit].astype(np.float64))
        els.append(e[hit])
        frames.append(np.full(int(hit.sum()), i, np.int32))
    if not pts:
        return np.zeros((0, 3)), np.zeros(0, np.int32), np.zeros(0, np.int32)
    return np.concatenate(pts), np.concatenate(els).astype(np.int32), np.concatenate(frames)
