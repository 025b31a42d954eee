"""Structure from motion on a plan's renders, with pycolmap on the CPU, registered to the model.

SIFT features are extracted with the renders' exact intrinsics (one PINHOLE camera per plan camera, held fixed; an
OPENCV camera when the renders were drawn through a distorted lens, its focal length and principal point held and
its k1, k2, p1, p2 started at zero and estimated by the bundle adjustment, :func:`estimated_distortion`),
matched exhaustively (small sets) or between the views that see the same surface (:mod:`.pairs`), and the images
registered by incremental mapping, every random choice seeded (:data:`SEED`: the RANSAC of the matches' geometric
verification, the mapper's and the triangulator's). The result does not depend on the thread count: the images are
numbered in frame order before their features are extracted (:func:`_register_images`), SIFT and matching give each
image and each pair the same result on any thread, and the mapping runs on :data:`MAPPER_THREADS` (with more, its
bundle adjustment splits large problems, and their floating-point sums, by thread, and its search for the initial
pair and its structure-less registration run their trials on several).
When the mapper ends with several models, each that shares at least :data:`MIN_REGISTERED` images with the largest
is merged into it, aligned by the reprojections of their common images
(``pycolmap.align_reconstructions_via_reprojections``, as COLMAP's model merger aligns; the true poses play no
part), and its other images count as registered.
The SfM model's frame is arbitrary: a similarity (scale, rotation, translation; Umeyama's least squares) maps it
onto the model, fitted to the registered frames' camera centres and to a point ahead of and beside each of them
along its axes (so a row of collinear centres, as a one-layer facade flies, still fixes the rotation about the
row). The residual reported is the RMS distance between the mapped and the true centres.

Writes into the output folder: ``points.npz`` and ``registration.json`` (:mod:`.files`), ``sparse/`` (the SfM model
mapped into the model's frame, COLMAP binary; the models merged into it in ``sparse/merged/1``, …) and
``database.db`` (pycolmap's features and matches).
"""

from __future__ import annotations

import contextlib
import math
import os
import time
from collections.abc import Callable
from pathlib import Path

import numpy as np
from numpy.typing import NDArray

from ..errors import SightplanError
from .files import Reconstruction, write_reconstruction
from .pairs import overlap_pairs, shared_samples
from .render import DEPTH_FILE, read_renders

MATCHERS = ("auto", "exhaustive", "spatial", "sequential")
EXHAUSTIVE_MAX_IMAGES = 60  # "auto" matches every pair up to this many images, the views sharing surface beyond
SEQUENTIAL_OVERLAP = 10
MAX_FEATURES = 8192
MIN_REGISTERED = 3
SEED = 1  # pycolmap's random seeds: the same images give the same reconstruction
MAPPER_THREADS = 1  # the incremental mapping's, whatever ``threads`` says: its result varies with the count

Progress = Callable[[int, int], None]
Stage = Callable[[str], None]


def umeyama(src: NDArray, dst: NDArray) -> tuple[float, NDArray[np.float64], NDArray[np.float64]]:
    """(s, R, t) minimising Σ|s·R·src + t − dst|² over rotations R (Umeyama 1991); src, dst (n, 3), n ≥ 3 not all
    on one line."""
    src, dst = np.asarray(src, float), np.asarray(dst, float)
    mu_s, mu_d = src.mean(0), dst.mean(0)
    a, b = src - mu_s, dst - mu_d
    var_s = float((a**2).sum()) / len(src)
    if var_s <= 0:
        raise SightplanError("the registered frames share one camera centre: no similarity to the model can be fitted")
    cov = b.T @ a / len(src)
    U, D, Vt = np.linalg.svd(cov)
    S = np.eye(3)
    if np.linalg.det(U) * np.linalg.det(Vt) < 0:
        S[2, 2] = -1
    R = U @ S @ Vt
    s = float(np.trace(np.diag(D) @ S)) / var_s
    t = mu_d - s * R @ mu_s
    return s, R, t


def fit_similarity(C_sfm: NDArray, R_sfm: NDArray, C_true: NDArray, R_true: NDArray
                   ) -> tuple[float, NDArray[np.float64], NDArray[np.float64]]:
    """The similarity model = s·R·x + t from SfM camera centres ``C_sfm`` (n, 3) and world-from-camera rotations
    ``R_sfm`` (n, 3, 3) onto the true ones: fitted to the centres and to points one arm's length along each camera's
    x and z axes (the arm: the RMS spread of the true centres, in the SfM frame divided by the centres' scale)."""
    C_sfm, C_true = np.asarray(C_sfm, float), np.asarray(C_true, float)
    spread_true = math.sqrt(float(((C_true - C_true.mean(0)) ** 2).sum(1).mean()))
    spread_sfm = math.sqrt(float(((C_sfm - C_sfm.mean(0)) ** 2).sum(1).mean()))
    if spread_true <= 0 or spread_sfm <= 0:
        raise SightplanError("the registered frames share one camera centre: no similarity to the model can be fitted")
    arm_true, arm_sfm = spread_true, spread_sfm
    src = [C_sfm] + [C_sfm + arm_sfm * R_sfm[:, :, k] for k in (0, 2)]
    dst = [C_true] + [C_true + arm_true * R_true[:, :, k] for k in (0, 2)]
    return umeyama(np.concatenate(src), np.concatenate(dst))


def rotation_angle_deg(Ra: NDArray, Rb: NDArray) -> NDArray[np.float64]:
    """(n,) angle in degrees of the rotation between each pair of (n, 3, 3) rotations."""
    c = (np.einsum("nij,nij->n", Ra, Rb) - 1) / 2  # trace(Raᵀ Rb)
    return np.degrees(np.arccos(np.clip(c, -1.0, 1.0)))


def spatial_pairs(images_dir: str | Path) -> list[tuple[int, int]]:
    """Image pairs (i < j) of a render folder whose views see the same surface (:func:`.pairs.overlap_pairs`), from
    the true poses and the renders' depth maps."""
    renders = read_renders(images_dir)
    path = Path(images_dir) / DEPTH_FILE
    if not path.is_file():
        raise SightplanError(f"{images_dir} has no {DEPTH_FILE}: render the plan again with `sightplan render`")
    cams = [renders.camera(i) for i in range(len(renders))]
    try:
        with np.load(path) as z:
            shared = shared_samples(cams, renders.R_world_camera, renders.C_world,
                                    (z[f"frame_{i:05d}"] for i in range(len(renders))))
    except (OSError, ValueError, KeyError) as exc:
        raise SightplanError(f"{path} is not readable: {exc}") from None
    return overlap_pairs(shared, renders.R_world_camera[:, :, 2])


def _pycolmap():
    from ..extras import require

    require("loop", "sightplan reconstruct")
    import pycolmap

    if not hasattr(pycolmap, "FeatureExtractionOptions"):
        raise SightplanError(f"sightplan reconstruct needs pycolmap 4.0 or later, this is {pycolmap.__version__}: "
                             "pip install -U 'sightplan[loop]'")
    return pycolmap


def _chunks(names: list[str], parts: int) -> list[list[str]]:
    size = max(1, math.ceil(len(names) / parts))
    return [names[k:k + size] for k in range(0, len(names), size)]


@contextlib.contextmanager
def _quiet(pycolmap, verbose: bool):
    """COLMAP's log lines (several per image) only with ``verbose``; warnings and errors always."""
    before = pycolmap.logging.minloglevel
    if not verbose:
        pycolmap.logging.minloglevel = max(before, 2)
    try:
        yield
    finally:
        pycolmap.logging.minloglevel = before


def reconstruct(images_dir: str | Path, out_dir: str | Path, *, matcher: str = "auto", threads: int | None = None,
                progress: Progress | None = None, stage: Stage | None = None, verbose: bool = False) -> Reconstruction:
    """Run SfM on the renders in ``images_dir`` (a folder written by :func:`~.render.render_plan`) and register it to
    the model; the result is also written into ``out_dir``.

    matcher: "exhaustive" (every pair), "spatial" (each image with the views that see most of the same surface,
    round corners too: :func:`spatial_pairs`), "sequential" (each image with its next images in plan order), or
    "auto" (exhaustive up to :data:`EXHAUSTIVE_MAX_IMAGES` images, spatial beyond). threads: CPU threads for SIFT
    and matching (default all; the mapping runs on :data:`MAPPER_THREADS` whatever it is).
    progress(done, total): work units over the whole run: one per image extracted, one per image matched (reported
    when matching ends), one per image registered. stage(text): called as each step begins. verbose: let COLMAP
    log its progress to stderr."""
    renders = read_renders(images_dir)
    if matcher not in MATCHERS:
        raise SightplanError(f"unknown matcher {matcher!r}; choose one of {', '.join(MATCHERS)}")
    pycolmap = _pycolmap()
    with _quiet(pycolmap, verbose):
        return _run(pycolmap, renders, Path(images_dir), Path(out_dir), matcher, threads, progress, stage)


def _run(pycolmap, renders, src: Path, out: Path, matcher: str, threads: int | None, progress: Progress | None,
         stage: Stage | None) -> Reconstruction:
    if out.resolve() == src.resolve():
        raise SightplanError("write the reconstruction into a folder other than the renders'")
    try:
        out.mkdir(parents=True, exist_ok=True)
    except OSError as exc:
        raise SightplanError(f"cannot create the reconstruction folder {out}: {exc}") from None
    missing = [name for name in renders.image_names if not (src / name).is_file()]
    if missing:
        raise SightplanError(f"{src} lacks {len(missing)} of its rendered images (e.g. {missing[0]}): render again")
    n = len(renders)
    n_threads = int(threads) if threads else (os.cpu_count() or 1)
    chosen = matcher if matcher != "auto" else ("exhaustive" if n <= EXHAUSTIVE_MAX_IMAGES else "spatial")
    done = 0
    total = 3 * n

    def tick(k: int = 1) -> None:
        nonlocal done
        done = min(total, done + k)
        if progress is not None:
            progress(done, total)

    def say(text: str) -> None:
        if stage is not None:
            stage(text)

    database = out / "database.db"
    database.unlink(missing_ok=True)
    timings: dict[str, float] = {}
    started = time.perf_counter()

    say("extracting SIFT features")
    distorted = bool(renders.distortion)
    _register_images(pycolmap, database, renders, distorted)
    extraction = pycolmap.FeatureExtractionOptions()
    extraction.num_threads = n_threads
    extraction.use_gpu = False
    extraction.sift.max_num_features = MAX_FEATURES
    for part in _chunks(list(renders.image_names), 20):
        pycolmap.extract_features(database, src, image_names=part, camera_mode=pycolmap.CameraMode.SINGLE,
                                  extraction_options=extraction, device=pycolmap.Device.cpu)
        tick(len(part))
    t1 = time.perf_counter()
    timings["extract_s"] = t1 - started

    say(f"matching ({chosen})")
    matching = pycolmap.FeatureMatchingOptions()
    matching.num_threads = n_threads
    matching.use_gpu = False
    verification = pycolmap.TwoViewGeometryOptions()
    verification.ransac.random_seed = SEED
    n_pairs = None
    if chosen == "exhaustive":
        n_pairs = n * (n - 1) // 2
        pycolmap.match_exhaustive(database, matching_options=matching, verification_options=verification,
                                  device=pycolmap.Device.cpu)
    elif chosen == "spatial":
        pairs = spatial_pairs(src)
        n_pairs = len(pairs)
        match_list = out / "pairs.txt"
        match_list.write_text("".join(f"{renders.image_names[i]} {renders.image_names[j]}\n" for i, j in pairs))
        pairing = pycolmap.ImportedPairingOptions()
        pairing.match_list_path = str(match_list)
        pycolmap.match_image_pairs(database, matching_options=matching, pairing_options=pairing,
                                   verification_options=verification, device=pycolmap.Device.cpu)
    else:
        pairing = pycolmap.SequentialPairingOptions()
        pairing.overlap = SEQUENTIAL_OVERLAP
        pairing.loop_detection = False
        pycolmap.match_sequential(database, matching_options=matching, pairing_options=pairing,
                                  verification_options=verification, device=pycolmap.Device.cpu)
    tick(n)
    t2 = time.perf_counter()
    timings["match_s"] = t2 - t1

    say("incremental mapping")
    options = pycolmap.IncrementalPipelineOptions()
    options.num_threads = MAPPER_THREADS
    options.random_seed = SEED
    options.mapper.random_seed = SEED
    options.triangulation.random_seed = SEED
    options.ba_refine_focal_length = False
    options.ba_refine_principal_point = False
    options.ba_refine_extra_params = distorted  # the lens's k1, k2, p1, p2, when the renders have one
    options.mapper.abs_pose_refine_focal_length = False
    options.mapper.abs_pose_refine_extra_params = distorted
    models_dir = out / "models"
    models_dir.mkdir(exist_ok=True)
    models = pycolmap.incremental_mapping(database, src, models_dir, options=options, next_image_callback=tick)
    t3 = time.perf_counter()
    timings["map_s"] = t3 - t2
    _remove_tree(models_dir)
    if not models or max(m.num_reg_images() for m in models.values()) == 0:
        raise SightplanError(f"structure from motion registered none of the {n} images in {src}: too little texture "
                             "or overlap between the frames (see the matches in database.db)")
    ranked = sorted(models.values(), key=lambda m: (m.num_reg_images(), m.num_points3D()), reverse=True)
    model, merged = ranked[0], _merged(pycolmap, ranked[0], ranked[1:])

    index = {name: i for i, name in enumerate(renders.image_names)}
    registered = np.zeros(n, bool)
    C_sfm = np.zeros((n, 3))
    R_sfm = np.zeros((n, 3, 3))
    for part in (model, *merged):
        for image in part.images.values():
            if not image.has_pose or image.name not in index or registered[index[image.name]]:
                continue
            i = index[image.name]
            pose = image.cam_from_world()
            R_cw = np.asarray(pose.rotation.matrix(), float)
            registered[i] = True
            R_sfm[i] = R_cw.T
            C_sfm[i] = -R_cw.T @ np.asarray(pose.translation, float)
    k = int(registered.sum())
    if k < MIN_REGISTERED:
        raise SightplanError(f"structure from motion registered only {k} of the {n} images in {src}: at least "
                             f"{MIN_REGISTERED} are needed to place the reconstruction on the model")
    reg = np.flatnonzero(registered)
    s, R, t = fit_similarity(C_sfm[reg], R_sfm[reg], renders.C_world[reg], renders.R_world_camera[reg])
    position_error = np.full(n, np.nan)
    rotation_error = np.full(n, np.nan)
    mapped = s * C_sfm[reg] @ R.T + t
    position_error[reg] = np.linalg.norm(mapped - renders.C_world[reg], axis=1)
    rotation_error[reg] = rotation_angle_deg(R @ R_sfm[reg], renders.R_world_camera[reg])
    residual = float(np.sqrt(np.mean(position_error[reg] ** 2)))

    xyz, track, err = [], [], []
    for part in (model, *merged):
        ids = sorted(part.points3D)
        xyz.append(np.array([part.points3D[p].xyz for p in ids], float).reshape(-1, 3))
        track.append(np.array([part.points3D[p].track.length() for p in ids], np.int32))
        err.append(np.array([part.points3D[p].error for p in ids], float))
    points = s * np.concatenate(xyz) @ R.T + t
    track, err = np.concatenate(track), np.concatenate(err)

    sparse = out / "sparse"
    sparse.mkdir(exist_ok=True)
    if (sparse / "merged").is_dir():
        _remove_tree(sparse / "merged")
    for m, part in enumerate((model, *merged)):
        part.transform(pycolmap.Sim3d(s, pycolmap.Rotation3d(R), t))
        where = sparse if m == 0 else sparse / "merged" / str(m)
        where.mkdir(parents=True, exist_ok=True)
        part.write(where)
    timings["total_s"] = time.perf_counter() - started
    info = {
        "images": n, "registered": k, "points": len(points), "matcher": chosen, "pairs": n_pairs,
        "threads": n_threads, "mapper_threads": MAPPER_THREADS,
        "models": len(models), "models_merged": len(merged), "largest_model_images": model.num_reg_images(),
        "pycolmap": str(pycolmap.__version__), "images_dir": str(src),
        "engine": renders.engine, "render_scale": renders.scale,
        "timings_s": {key: round(v, 3) for key, v in timings.items()},
        "mean_track_length": float(track.mean()) if len(track) else 0.0,
        "mean_reprojection_error_px": float(err.mean()) if len(err) else 0.0,
        "camera_model": "OPENCV" if distorted else "PINHOLE",
        "photo_realism": renders.preset, "photo_seed": renders.photo.get("seed"),
    }
    if distorted:
        info["distortion"] = {"true": {cid: list(k) for cid, k in renders.distortion.items()},
                              "estimated": estimated_distortion(model, renders)}
    rec = Reconstruction(points=points, track_length=track, error_px=err, frame_names=renders.frame_names,
                         registered=registered, position_error_m=position_error, rotation_error_deg=rotation_error,
                         scale=s, R=R, t=t, residual_m=residual, scene_size_m=renders.scene_size_m, info=info)
    write_reconstruction(rec, out)
    if progress is not None:
        progress(total, total)
    return rec


def estimated_distortion(model, renders) -> dict[str, list[float]]:
    """{plan camera: [k1, k2, p1, p2]} as the bundle adjustment of ``model`` left them (OPENCV cameras), for the
    plan cameras whose images it registered."""
    out: dict[str, list[float]] = {}
    index = {name: i for i, name in enumerate(renders.image_names)}
    for image in model.images.values():
        i = index.get(image.name)
        if i is None or not image.has_pose or renders.camera_of[i] in out:
            continue
        params = np.asarray(model.cameras[image.camera_id].params, float)
        if len(params) >= 8:
            out[renders.camera_of[i]] = [float(x) for x in params[4:8]]
    return out


def _merged(pycolmap, base, others) -> list:
    """The models of ``others`` (largest first) that share at least :data:`MIN_REGISTERED` registered images with
    ``base`` and align to it by their reprojections, each transformed into ``base``'s frame."""
    names = {im.name for im in base.images.values() if im.has_pose}
    merged = []
    for other in others:
        common = {im.name for im in other.images.values() if im.has_pose} & names
        if len(common) < MIN_REGISTERED:
            continue
        sim = pycolmap.align_reconstructions_via_reprojections(other, base)
        if sim is None:
            continue
        other.transform(sim)
        merged.append(other)
        names |= {im.name for im in other.images.values() if im.has_pose}
    return merged


def _register_images(pycolmap, database: Path, renders, distorted: bool) -> None:
    """Write the plan's cameras and every image into a new ``database``, image k + 1 being frame k, before the
    features are extracted: the extraction's threads finish the images in any order, and when they number the
    images as they finish, the ids (which break the mapper's ties) change with the thread count. Each plan camera
    has its exact intrinsics (PINHOLE, or OPENCV with k1, k2, p1, p2 at zero when the renders have a lens) and a
    rig of its own; each image a frame of its own, as the extraction would have made them."""
    with pycolmap.Database.open(database) as db:
        ids: dict[str, tuple[int, int]] = {}
        for cid, cam in renders.cameras.items():
            params = [cam.fx, cam.fy, cam.cx, cam.cy] + ([0.0, 0.0, 0.0, 0.0] if distorted else [])
            camera = pycolmap.Camera(model="OPENCV" if distorted else "PINHOLE", width=int(cam.width),
                                     height=int(cam.height), params=[float(x) for x in params])
            camera.has_prior_focal_length = True
            camera.camera_id = db.write_camera(camera)
            rig = pycolmap.Rig()
            rig.add_ref_sensor(camera.sensor_id)
            ids[cid] = camera.camera_id, db.write_rig(rig)
        for i, name in enumerate(renders.image_names):
            camera_id, rig_id = ids[renders.camera_of[i]]
            image = pycolmap.Image(name=name, camera_id=camera_id)
            image.image_id = db.write_image(image)
            frame = pycolmap.Frame()
            frame.rig_id = rig_id
            frame.add_data_id(image.data_id)
            db.write_frame(frame)


def _remove_tree(path: Path) -> None:
    for p in sorted(path.rglob("*"), key=lambda q: len(q.parts), reverse=True):
        p.rmdir() if p.is_dir() else p.unlink()
    path.rmdir()
