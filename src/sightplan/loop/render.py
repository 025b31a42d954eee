"""Synthetic photographs of a plan: every frame rendered through a visibility engine's own rays, each surface in its
element's procedural texture (:mod:`.texture`), with exact intrinsics and the true poses beside the images.

A render directory holds

- ``frame_00000.png`` …: one 8-bit RGB image per plan frame, in plan order (the scaled camera's size);
- ``render.json``: the frame and image names, the cameras (scaled), each frame's pose (``R_world_camera``,
  ``C_world``), the scene's size, the engine, the scale, the texture's cell size, the elements' GlobalIds in the
  scene's element order, and the frames that show no element; with a photo-realism preset (:mod:`.photo`) also
  ``photo`` (the preset, the seed, every option, the sun, the ground's height, the materials) and ``distortion``
  (per camera, OpenCV's k1, k2, p1, p2 the images are drawn through);
- ``poses/``: the true poses as a COLMAP text model (``cameras.txt`` PINHOLE with the scaled intrinsics,
  ``images.txt``, an empty ``points3D.txt``), which ``load_plan(..., fmt="colmap")`` reads back;
- ``elements.npz``: per frame (key ``frame_00000`` …) the (H, W) int32 element index each pixel shows (−1: sky),
  exactly the engine's :meth:`~sightplan.engines.base.Engine.element_map` of the frame (ties rule included);
- ``depth.npz``: per frame the (H, W) float32 distance along each pixel's ray to the surface it shows (inf: sky),
  from which :func:`surface_samples` gives the world points the renders saw.

The pixel at the centre of pixel (u, v) is the surface its centre ray meets first, as the evaluator counts it: no
anti-aliasing across pixels, so the element map and the image agree pixel for pixel. Through a distorted lens the
centre ray of a pixel is its undistorted ray (:func:`.photo.lens_directions`), for the image, the element map and the
depths alike. With the ground drawn (presets ``shaded`` and ``full``) a surface below the ground's height that the
ground hides (a footing) shows the ground, and the element map says −1 there.

Without ``photo`` (the Python default) each element is drawn in its own procedural noise and colour, seeded by its
GlobalId, shaded by the angle to the view over a smooth sky (the preset ``noise``, the command line's default too).
"""

from __future__ import annotations

import json
import math
import time
from collections.abc import Callable
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np
from numpy.typing import NDArray

from ..camera.models import PinholeCamera
from ..errors import SightplanError
from ..geometry.poses import quaternion_from_R
from ..model.scene import Scene
from ..plan.types import Plan
from . import materials, photo, texture
from .photo import PhotoOptions

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
    photo: dict = field(default_factory=dict)
    distortion: dict[str, tuple[float, float, float, float]] = field(default_factory=dict)

    def __len__(self) -> int:
        return len(self.image_names)

    def camera(self, i: int) -> PinholeCamera:
        return self.cameras[self.camera_of[i]]

    def lens(self, i: int) -> tuple[float, float, float, float] | None:
        """OpenCV's (k1, k2, p1, p2) frame i was drawn through, None for an ideal pinhole."""
        return self.distortion.get(self.camera_of[i])

    @property
    def preset(self) -> str:
        """The photo-realism preset of the renders ('noise' for the procedural element noise)."""
        return str(self.photo.get("preset", "noise"))


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
                 names: list[str], lens: tuple[float, float, float, float] | None = None) -> None:
    """The true poses as a COLMAP text model: cameras.txt, images.txt, an empty points3D.txt; the cameras OPENCV
    with the distortion ``lens`` when the images were drawn through one."""
    directory.mkdir(parents=True, exist_ok=True)
    ids = {cid: k + 1 for k, cid in enumerate(cameras)}
    lines = ["# CAMERA_ID MODEL WIDTH HEIGHT PARAMS[] (PINHOLE: fx fy cx cy; OPENCV: fx fy cx cy k1 k2 p1 p2; "
             "top-left pixel centre at 0.5)"]
    model = "PINHOLE" if lens is None else "OPENCV"
    extra = "" if lens is None else " " + " ".join(repr(float(x)) for x in lens)
    lines += [f"{ids[cid]} {model} {c.width} {c.height} {c.fx!r} {c.fy!r} {c.cx!r} {c.cy!r}{extra}"
              for cid, c in cameras.items()]
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


SUN_LIGHT = np.array([1.0, 0.96, 0.90])  # the sun's irradiance on a surface facing it (linear, relative)
SKY_LIGHT = np.array([0.26, 0.30, 0.36])  # the clear sky's on a horizontal surface facing up
GLASS_F0 = 0.06  # glass's reflectance head-on (Schlick)
METAL_MIRROR = 0.3  # the share of a metal surface's light that is the sky mirrored
SUN_GLOW = np.array([0.5, 0.45, 0.35])  # the sky's brightening around the sun
GROUND_TOLERANCE_M = 0.02  # a surface this far below the ground's height is buried (a model's own ground is not)


@dataclass(frozen=True)
class Lighting:
    """The light of a photograph-like scene: ``sun`` (3,) unit vector towards it, ``ground_z`` the ground's height,
    ``ground_colour`` its mean linear albedo (for the light it throws back and for reflections)."""

    sun: NDArray[np.float64]
    ground_z: float
    ground_colour: NDArray[np.float64]


def _sky_radiance(dirs: NDArray, light: Lighting) -> NDArray[np.float64]:
    """(n, 3) linear radiance of the sky along ``dirs``: the smooth gradient, brighter about the sun; rays
    below the horizon see the ground's mean colour, lit by sun and sky."""
    sky = photo.to_linear(texture.sky(dirs))
    cos = np.clip(dirs @ light.sun, -1.0, 1.0)
    sky = sky + SUN_GLOW * np.exp((cos - 1.0) / 0.02)[:, None]
    ground = light.ground_colour * (SUN_LIGHT * max(light.sun[2], 0.0) + SKY_LIGHT)
    below = dirs[:, 2] < 0
    sky[below] = ground
    return sky


def _ground_z(scene: Scene) -> float:
    """The height of the ground the renders draw: the plan's ground under the model's centre (:mod:`..plan.ground`:
    a height given, the terrain, the outside ground level), else the model's lowest point."""
    lo, hi = scene.bounds()
    try:
        from ..plan.ground import ground_z

        z = float(ground_z(scene, [0.5 * (lo[:2] + hi[:2])])[0])
        if math.isfinite(z):
            return z
    except Exception:  # a model the ground rules cannot read: its base
        pass
    return float(lo[2])


def photo_frame(engine, cam: PinholeCamera, R: NDArray, C: NDArray, index: int, options: PhotoOptions,
                mats: materials.ElementMaterials, seeds: NDArray[np.uint64], normals: NDArray, light: Lighting | None,
                cell_m: float, velocity: NDArray | None = None) -> tuple[NDArray[np.uint8], NDArray[np.int32],
                                                                         NDArray[np.float32]]:
    """One photograph-like frame (:mod:`.photo`'s presets): (H, W, 3) uint8 image, (H, W) element map, (H, W)
    float32 distance, all along the lens's pixel rays. ``normals``: the scene's (F, 3) face normals; ``light``:
    None draws the angle-to-the-view shading and the sky gradient of ``flat`` and ``textured``."""
    H, W = cam.height, cam.width
    lens = options.lens
    dirs32 = lens_directions_or_pinhole(cam, R, lens)
    ids, t, prim = engine.trace(C, dirs32)
    dirs = dirs32.astype(np.float64)
    C = np.asarray(C, np.float64)
    n_px = H * W
    ground = np.zeros(n_px, bool)
    t_ground = np.full(n_px, np.inf)
    if light is not None:
        down = dirs[:, 2] < -1e-9
        t_ground[down] = (light.ground_z - C[2]) / dirs[down, 2]
        t_ground[t_ground < 0] = np.inf
        with np.errstate(invalid="ignore"):
            buried = (ids >= 0) & (C[2] + t * dirs[:, 2] < light.ground_z - GROUND_TOLERANCE_M) & (t_ground < t)
        ground = np.isfinite(t_ground) & (t_ground < engine.d_max) & ((ids < 0) | buried)
        ids = np.where(ground, -1, ids)
        t = np.where(ground, np.inf, t)
    hit = np.flatnonzero(ids >= 0)
    n_face = normals[prim[hit]]
    d_hit = dirs[hit]
    facing = np.where(np.einsum("ij,ij->i", n_face, d_hit) > 0, -1.0, 1.0)
    n_view = n_face * facing[:, None]  # the side of the surface the camera sees
    points = C + t[hit, None] * d_hit
    footprint = t[hit] / cam.sampling_focal_px
    e = ids[hit]
    k = mats.klass[e]
    albedo = np.empty((len(hit), 3))
    for j in np.unique(k):
        sel = np.flatnonzero(k == j)
        albedo[sel] = materials.class_albedo(mats.names[j], points[sel], n_face[sel], seeds[e[sel]],
                                             mats.colour[e[sel]], cell_m, footprint[sel], options.texture)
    if light is None:
        rgb = texture.sky(dirs)
        rgb[hit] = albedo * texture.shading(np.abs(np.einsum("ij,ij->i", n_face, d_hit)))[:, None]
        linear = photo.to_linear(rgb)
    else:
        linear = _sky_radiance(dirs, light)
        g = np.flatnonzero(ground)
        g_points = C + t_ground[g, None] * dirs[g]
        g_albedo = photo.to_linear(materials.ground_albedo(g_points, cell_m, t_ground[g] / cam.sampling_focal_px)
                                   if options.texture else np.tile(materials.CLASSES["ground"].colour, (len(g), 1)))
        # one shadow ray per lit pixel towards the sun, through the same engine
        all_points = np.concatenate([points, g_points])
        all_normals = np.concatenate([n_view, np.tile([0.0, 0.0, 1.0], (len(g), 1))])
        all_t = np.concatenate([t[hit], t_ground[g]])
        cos_sun = all_normals @ light.sun
        lit = np.zeros(len(all_points), bool)
        facing_sun = np.flatnonzero(cos_sun > 0)
        if len(facing_sun):
            origin = all_points[facing_sun] + all_normals[facing_sun] * (2e-3 + 2e-4 * all_t[facing_sun])[:, None]
            local = np.ascontiguousarray(origin - engine.centre, np.float32)
            sun32 = np.ascontiguousarray(np.broadcast_to(light.sun.astype(np.float32), local.shape))
            lit[facing_sun] = engine.unoccluded_rays(local, sun32, np.full(len(local), engine.d_max, np.float32))
        nz = all_normals[:, 2]
        irradiance = (SUN_LIGHT * (np.maximum(cos_sun, 0.0) * lit)[:, None]
                      + SKY_LIGHT * (0.5 + 0.5 * nz)[:, None]
                      + (light.ground_colour * (SUN_LIGHT * max(light.sun[2], 0.0) + SKY_LIGHT))
                      * (0.5 - 0.5 * nz)[:, None])
        a = np.concatenate([photo.to_linear(albedo), g_albedo])
        radiance = a * irradiance
        nh = len(hit)
        refl = mats.klass[e] if nh else np.zeros(0, np.int32)
        kinds = np.array([materials.CLASSES[n].reflectance for n in mats.names])[refl] if nh else np.zeros(0, str)
        mirror = np.flatnonzero((kinds == "glass") | (kinds == "metal"))
        if len(mirror):
            d = d_hit[mirror]
            nv = n_view[mirror]
            cos_i = np.clip(-np.einsum("ij,ij->i", d, nv), 0.0, 1.0)
            r = d + 2.0 * cos_i[:, None] * nv
            sky_r = _sky_radiance(r, light)
            glass = kinds[mirror] == "glass"
            fresnel = GLASS_F0 + (1 - GLASS_F0) * (1 - cos_i) ** 5
            share = np.where(glass, fresnel, METAL_MIRROR)
            radiance[mirror] = (1 - share)[:, None] * radiance[mirror] + share[:, None] * sky_r
        linear[hit] = radiance[:nh]
        linear[g] = radiance[nh:]
        # a little aerial perspective: far ground fades to the horizon's colour
        haze = 1.0 - np.exp(-t_ground[g] / 1500.0)
        linear[g] = (1 - haze)[:, None] * linear[g] + haze[:, None] * photo.to_linear(texture.sky(dirs[g]))
    image = linear.reshape(H, W, 3)
    if options.camera:
        if options.vignetting > 0:
            image = image * photo.vignette(cam, options.vignetting)[:, :, None]
        luminance = image @ np.array([0.2126, 0.7152, 0.0722])
        gain, balance = photo.exposure_and_balance(options, index, luminance)
        image = image * gain * balance
        if velocity is not None and options.shutter_s > 0 and np.isfinite(t).any():
            depth = float(np.median(t[np.isfinite(t)]))
            image = photo.motion_blur(image, photo.blur_kernel(*photo.image_motion(cam, R, velocity, depth,
                                                                                 options.shutter_s)))
        image = photo.sensor_noise(options, index, image)
    out = np.clip(np.rint(photo.to_srgb(image) * 255.0), 0, 255).astype(np.uint8)
    return out, ids.reshape(H, W).astype(np.int32), t.reshape(H, W).astype(np.float32)


def lens_directions_or_pinhole(cam: PinholeCamera, R: NDArray, lens) -> NDArray[np.float32]:
    """The pixel rays of ``cam``: the engine's own pinhole rays, or through the distortion ``lens``."""
    if lens is None:
        return _rays(cam, np.ascontiguousarray(R, np.float64))
    return photo.lens_directions(cam, R, lens)


def render_plan(scene: Scene, plan: Plan, out_dir: str | Path, *, scale: float = 1.0, engine: str = "embree",
                progress: Progress | None = None, texture_cell_m: float | None = None,
                threads: int | None = None, stages: Callable[[str, int, int], None] | None = None,
                photo_options: PhotoOptions | None = None) -> Renders:
    """Render every frame of ``plan`` over ``scene`` into ``out_dir`` (see the module's description of the files).

    scale: resolution scale of the images (the cameras written are the scaled ones). engine: a visibility engine's
    name ("embree", "gl", "trimesh", "auto"). texture_cell_m: the finest texture octave's cell in metres (default:
    :data:`CELL_PER_SSD` times the plan's typical surface sampling distance at this scale). progress(done, total):
    called after each frame. stages(name, done, total): hears every stage by name: 'engine' (the engine and the
    texture cell), 'frames' (after each frame, as ``progress``) and 'writing' (the element maps and depths).
    photo_options: a photo-realism preset's options (:func:`.photo.photo_options`); None draws the procedural
    element noise."""
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
        record: dict = {}
        if photo_options is not None:
            mats = materials.element_materials(scene)
            normals = scene.face_normals()
            light = None
            record = {**photo_options.to_dict(), "materials": mats.summary()}
            if photo_options.sun:
                lo, hi = scene.bounds()
                sun, record["sun_position"] = photo.sun_direction(photo_options, scene.metadata, 0.5 * (lo + hi))
                ground_z = _ground_z(scene)
                ground_colour = photo.to_linear(materials.CLASSES["ground"].colour) * 0.5 + \
                    photo.to_linear(np.array([0.55, 0.52, 0.47])) * 0.5
                light = Lighting(sun, ground_z, ground_colour)
                record["ground_z_m"] = ground_z
                if sun[2] <= 0:
                    raise SightplanError(f"the sun is below the horizon (elevation {record['sun_position']['elevation_deg']}°)"
                                         ": choose another date, time or sun")
            velocities = photo.path_velocities(plan.C_world, photo_options.speed_m_s)
        stage("engine", 1, 1)
        stage("frames", 0, len(plan))
        for i in range(len(plan)):
            cam = cams[camera_of[i]]
            if photo_options is None:
                image, ids, t = shade_frame(eng, cam, plan.R_world_camera[i], plan.C_world[i], seeds, colours, cell)
            else:
                image, ids, t = photo_frame(eng, cam, plan.R_world_camera[i], plan.C_world[i], i, photo_options, mats,
                                            seeds, normals, light, cell, velocities[i])
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
    lens = photo_options.lens if photo_options is not None else None
    _colmap_text(out / POSES_DIR, cams, camera_of, plan.R_world_camera, plan.C_world, names, lens)
    frame_names = [str(n) for n in plan.frame_names]
    size = scene_size(scene)
    (out / RENDER_FILE).write_text(json.dumps({
        "format": FORMAT, "version": 2 if photo_options is not None else 1,
        **({"photo": record} if photo_options is not None else {}),
        **({"distortion": {cid: list(lens) for cid in cams}} if lens is not None else {}),
        "engine": engine_name, "scale": float(scale), "texture_cell_m": float(cell),
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
            scale=float(doc.get("scale", 1.0)), texture_cell_m=float(doc.get("texture_cell_m", 0.0)),
            photo=dict(doc.get("photo") or {}),
            distortion={str(k): tuple(float(x) for x in v) for k, v in (doc.get("distortion") or {}).items()})
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
        dirs = lens_directions_or_pinhole(cam, r.R_world_camera[i], r.lens(i))
        dirs = dirs.reshape(cam.height, cam.width, 3)[::stride, ::stride].reshape(-1, 3)
        e = ids[i][::stride, ::stride].reshape(-1)
        t = depth[i][::stride, ::stride].reshape(-1).astype(np.float64)
        hit = e >= 0
        pts.append(r.C_world[i] + t[hit, None] * dirs[hit].astype(np.float64))
        els.append(e[hit])
        frames.append(np.full(int(hit.sum()), i, np.int32))
    if not pts:
        return np.zeros((0, 3)), np.zeros(0, np.int32), np.zeros(0, np.int32)
    return np.concatenate(pts), np.concatenate(els).astype(np.int32), np.concatenate(frames)
