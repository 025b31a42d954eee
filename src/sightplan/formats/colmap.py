"""COLMAP sparse models: ``cameras.{txt,bin}`` and ``images.{txt,bin}``, and with COLMAP ≥ 3.12
also ``rigs.{txt,bin}`` and ``frames.{txt,bin}``.

Read with our own parser (no pycolmap at run time). COLMAP stores per image the
world-to-camera rotation as a quaternion ``qvec = (w, x, y, z)`` and translation ``tvec``,
with OpenCV camera axes, so ``R_world_camera = R_cwᵀ`` and the centre is ``C = −R_cwᵀ t``.
COLMAP puts the centre of the top-left pixel at (0.5, 0.5), as sightplan does: focal
lengths and principal points are taken unchanged. Lens distortion is dropped, with a
warning in ``plan.parameters["warnings"]``; fisheye models are approximated by a pinhole
of the same focal length (wrong far from the image centre). COLMAP's EQUIRECTANGULAR model
uses sightplan's equirectangular convention (checked against pycolmap 4.2) and is read as
an :class:`EquirectangularCamera`. Points3D are not read.

COLMAP 3.12 groups images into frames: a *rig* is a set of sensors (a reference sensor and
others at a fixed ``sensor_from_rig`` pose), and a *frame* is one capture of a rig, with its
``rig_from_world`` pose and the data ids of its images (sensor type CAMERA, sensor id = camera
id, data id = image id). ``images`` still holds every registered image's name, camera and own
``cam_from_world`` pose, so the poses are read from it as before; ``rigs`` and ``frames`` are read
to check that every frame refers to a rig, camera and image the model has, and that the pose a
frame gives an image (``sensor_from_rig · rig_from_world``) agrees with the image's own (a
warning otherwise). Each image becomes one sightplan frame; ``parameters["source"]`` records the
rig and frame counts and ``parameters["colmap_frames"]`` the COLMAP frame of each image.
"""

from __future__ import annotations

import re
import struct
from pathlib import Path
from typing import Literal, NamedTuple

import numpy as np

from ..camera.models import Camera, EquirectangularCamera, PinholeCamera
from ..errors import CameraError, PlanError
from ..plan.format import quaternions_to_R
from ..plan.types import Plan
from .base import FlightFormat, ReadOptions, Source

# model id → (name, number of params, leading intrinsics: "f" = f, cx, cy; "fxfy" = fx, fy, cx, cy)
_MODELS: dict[int, tuple[str, int, str]] = {
    0: ("SIMPLE_PINHOLE", 3, "f"), 1: ("PINHOLE", 4, "fxfy"), 2: ("SIMPLE_RADIAL", 4, "f"), 3: ("RADIAL", 5, "f"),
    4: ("OPENCV", 8, "fxfy"), 5: ("OPENCV_FISHEYE", 8, "fxfy"), 6: ("FULL_OPENCV", 12, "fxfy"), 7: ("FOV", 5, "fxfy"),
    8: ("SIMPLE_RADIAL_FISHEYE", 4, "f"), 9: ("RADIAL_FISHEYE", 5, "f"), 10: ("THIN_PRISM_FISHEYE", 12, "fxfy"),
    11: ("RAD_TAN_THIN_PRISM_FISHEYE", 16, "fxfy"), 12: ("SIMPLE_DIVISION", 4, "f"), 13: ("DIVISION", 5, "fxfy"),
    14: ("SIMPLE_FISHEYE", 3, "f"), 15: ("FISHEYE", 4, "fxfy"), 16: ("EUCM", 6, "fxfy"), 17: ("EQUIRECTANGULAR", 2, "equirect"),
}
_BY_NAME = {name: (mid, n, kind) for mid, (name, n, kind) in _MODELS.items()}
_FISHEYE = {"OPENCV_FISHEYE", "FOV", "SIMPLE_RADIAL_FISHEYE", "RADIAL_FISHEYE", "THIN_PRISM_FISHEYE",
            "RAD_TAN_THIN_PRISM_FISHEYE", "SIMPLE_FISHEYE", "FISHEYE", "EUCM"}

ColmapOrder = Literal["name", "id"]


class _RawCamera(NamedTuple):
    model: str
    width: int
    height: int
    params: tuple[float, ...]


class _RawImages(NamedTuple):
    ids: np.ndarray  # (n,) int
    qvec: np.ndarray  # (n, 4) w, x, y, z of R_camera_world
    tvec: np.ndarray  # (n, 3)
    camera_ids: np.ndarray  # (n,) int
    names: list[str]


_PARTS = ("cameras", "images", "rigs", "frames")


def find_colmap_model(path: str | Path) -> tuple[Path, str]:
    """(folder, ".bin" or ".txt") of the COLMAP model at ``path``: a folder (also ``sparse/0``
    or ``sparse`` inside it) or one of its files. Binary wins when both are present,
    unless ``path`` names a ``.txt`` file. ``rigs`` and ``frames`` (COLMAP ≥ 3.12) are optional."""
    path = Path(path)
    base = path.parent if path.is_file() else path
    exts = (".txt", ".bin") if path.is_file() and path.suffix == ".txt" else (".bin", ".txt")
    partial: list[str] = []
    for folder in (base, base / "sparse" / "0", base / "sparse"):
        for ext in exts:
            if (folder / f"cameras{ext}").is_file() and (folder / f"images{ext}").is_file():
                return folder, ext
            have = [f"{p}{ext}" for p in _PARTS if (folder / f"{p}{ext}").is_file()]
            if have and not partial:
                missing = [f"{p}{ext}" for p in ("cameras", "images") if f"{p}{ext}" not in have]
                where = folder if folder == base else folder.relative_to(base)
                partial = [f"{where} has {', '.join(have)} but no {' or '.join(missing)}"]
    if partial:
        raise PlanError(f"incomplete COLMAP model at {path}: {partial[0]}. sightplan reads a model as cameras + images, "
                        "with rigs + frames beside them from COLMAP 3.12 on (which still writes images with every "
                        "image's name and pose); export the whole model (colmap model_converter) and try again")
    raise PlanError(f"no COLMAP model at {path}: expected cameras.bin + images.bin or cameras.txt + images.txt "
                    "(with rigs + frames from COLMAP 3.12 on), in the folder or in sparse/0")


def _data_lines(path: Path) -> list[tuple[int, str]]:
    try:
        lines = path.read_text(encoding="utf-8").splitlines()
    except (OSError, UnicodeDecodeError) as exc:
        raise PlanError(f"cannot read {path}: {exc}") from None
    return [(i + 1, line.strip()) for i, line in enumerate(lines)]


def _read_cameras_txt(path: Path) -> dict[int, _RawCamera]:
    cams = {}
    for lineno, line in _data_lines(path):
        if not line or line.startswith("#"):
            continue
        parts = line.split()
        try:
            cid, model, w, h = int(parts[0]), parts[1], int(parts[2]), int(parts[3])
            params = tuple(float(p) for p in parts[4:])
        except (IndexError, ValueError):
            raise PlanError(f"{path.name}, line {lineno}: expected CAMERA_ID MODEL WIDTH HEIGHT PARAMS...") from None
        cams[cid] = _RawCamera(model, w, h, params)
    return cams


def _read_images_txt(path: Path) -> _RawImages:
    ids, qt, cams, names = [], [], [], []
    lines = _data_lines(path)
    k = 0
    while k < len(lines):
        lineno, line = lines[k]
        k += 1
        if not line or line.startswith("#"):
            continue
        parts = line.split(maxsplit=9)
        try:
            ids.append(int(parts[0]))
            qt.append([float(p) for p in parts[1:8]])
            cams.append(int(parts[8]))
            names.append(parts[9])
        except (IndexError, ValueError):
            raise PlanError(f"{path.name}, line {lineno}: expected IMAGE_ID QW QX QY QZ TX TY TZ CAMERA_ID NAME") from None
        k += 1  # the POINTS2D line that follows every image line (possibly empty)
    qt_arr = np.array(qt, float).reshape(-1, 7)
    return _RawImages(np.array(ids, int), qt_arr[:, :4], qt_arr[:, 4:], np.array(cams, int), names)


def _read_cameras_bin(path: Path) -> dict[int, _RawCamera]:
    data = path.read_bytes()
    cams = {}
    try:
        (count,), off = struct.unpack_from("<Q", data, 0), 8
        for _ in range(count):
            cid, mid, w, h = struct.unpack_from("<IiQQ", data, off)
            off += 24
            if mid not in _MODELS:
                raise PlanError(f"{path.name}: camera {cid} has unknown COLMAP model id {mid}")
            name, n, _ = _MODELS[mid]
            cams[cid] = _RawCamera(name, w, h, struct.unpack_from(f"<{n}d", data, off))
            off += 8 * n
    except struct.error:
        raise PlanError(f"{path}: truncated, or not a COLMAP cameras.bin") from None
    return cams


def _read_images_bin(path: Path) -> _RawImages:
    data = path.read_bytes()
    ids, qt, cams, names = [], [], [], []
    try:
        (count,), off = struct.unpack_from("<Q", data, 0), 8
        for _ in range(count):
            image_id, *pose, cid = struct.unpack_from("<I7dI", data, off)
            off += 64
            end = data.index(b"\0", off)
            names.append(data[off:end].decode("utf-8"))
            (npoints,) = struct.unpack_from("<Q", data, end + 1)
            off = end + 9 + 24 * npoints  # skip POINTS2D: x, y (double), point3D_id (int64)
            ids.append(image_id)
            qt.append(pose)
            cams.append(cid)
    except (struct.error, ValueError, UnicodeDecodeError):
        raise PlanError(f"{path}: truncated, or not a COLMAP images.bin") from None
    qt_arr = np.array(qt, float).reshape(-1, 7)
    return _RawImages(np.array(ids, int), qt_arr[:, :4], qt_arr[:, 4:], np.array(cams, int), names)


# COLMAP's SensorType: written by name in the text files, as an int32 in the binary ones
_SENSOR_TYPES = {"INVALID": -1, "CAMERA": 0, "IMU": 1}
_CAMERA = _SENSOR_TYPES["CAMERA"]
_RIG_LINE = ("RIG_ID NUM_SENSORS REF_SENSOR_TYPE REF_SENSOR_ID, then per other sensor SENSOR_TYPE SENSOR_ID HAS_POSE "
             "[QW QX QY QZ TX TY TZ]")
_FRAME_LINE = "FRAME_ID RIG_ID QW QX QY QZ TX TY TZ NUM_DATA_IDS, then per data SENSOR_TYPE SENSOR_ID DATA_ID"

Sensor = tuple[int, int]  # (sensor type, sensor id)
Pose = tuple[tuple[float, ...], tuple[float, ...]]  # (qw, qx, qy, qz), (tx, ty, tz)


class _RawRig(NamedTuple):
    ref: Sensor | None
    sensors: dict[Sensor, Pose | None]  # the other sensors: sensor_from_rig, None where unknown


class _RawFrame(NamedTuple):
    rig_id: int
    rig_from_world: Pose
    data: list[tuple[int, int, int]]  # (sensor type, sensor id, data id); for a camera, data id = image id


def _sensor_type(token: str) -> int:
    name = token.strip().upper()
    return _SENSOR_TYPES[name] if name in _SENSOR_TYPES else int(token)


def _read_rigs_txt(path: Path) -> dict[int, _RawRig]:
    rigs = {}
    for lineno, line in _data_lines(path):
        if not line or line.startswith("#"):
            continue
        parts = line.split()
        try:
            rid, n = int(parts[0]), int(parts[1])
            k, ref, sensors = 2, None, {}
            if n > 0:
                ref, k = (_sensor_type(parts[2]), int(parts[3])), 4
            for _ in range(n - 1):
                key, has_pose = (_sensor_type(parts[k]), int(parts[k + 1])), parts[k + 2] == "1"
                k += 3
                pose = None
                if has_pose:
                    values = tuple(float(v) for v in parts[k:k + 7])
                    if len(values) < 7:
                        raise IndexError
                    pose, k = (values[:4], values[4:]), k + 7
                sensors[key] = pose
            if k != len(parts):
                raise ValueError
        except (IndexError, ValueError):
            raise PlanError(f"{path.name}, line {lineno}: expected {_RIG_LINE}") from None
        rigs[rid] = _RawRig(ref, sensors)
    return rigs


def _read_frames_txt(path: Path) -> dict[int, _RawFrame]:
    frames = {}
    for lineno, line in _data_lines(path):
        if not line or line.startswith("#"):
            continue
        parts = line.split()
        try:
            fid, rid = int(parts[0]), int(parts[1])
            pose = tuple(float(v) for v in parts[2:9])
            n = int(parts[9])
            data = [(_sensor_type(parts[10 + 3 * j]), int(parts[11 + 3 * j]), int(parts[12 + 3 * j])) for j in range(n)]
            if len(pose) != 7 or len(parts) != 10 + 3 * n:
                raise ValueError
        except (IndexError, ValueError):
            raise PlanError(f"{path.name}, line {lineno}: expected {_FRAME_LINE}") from None
        frames[fid] = _RawFrame(rid, (pose[:4], pose[4:]), data)
    return frames


def _read_rigs_bin(path: Path) -> dict[int, _RawRig]:
    data = path.read_bytes()
    rigs = {}
    try:
        (count,), off = struct.unpack_from("<Q", data, 0), 8
        for _ in range(count):
            rid, n = struct.unpack_from("<II", data, off)
            off += 8
            ref = None
            if n > 0:
                ref = struct.unpack_from("<iI", data, off)
                off += 8
            sensors: dict[Sensor, Pose | None] = {}
            for _ in range(max(n, 1) - 1):
                stype, sid, has_pose = struct.unpack_from("<iIB", data, off)
                off += 9
                pose = None
                if has_pose:
                    values = struct.unpack_from("<7d", data, off)
                    pose, off = (values[:4], values[4:]), off + 56
                sensors[(stype, sid)] = pose
            rigs[rid] = _RawRig(ref, sensors)
    except struct.error:
        raise PlanError(f"{path}: truncated, or not a COLMAP rigs.bin") from None
    return rigs


def _read_frames_bin(path: Path) -> dict[int, _RawFrame]:
    data = path.read_bytes()
    frames = {}
    try:
        (count,), off = struct.unpack_from("<Q", data, 0), 8
        for _ in range(count):
            fid, rid, *pose = struct.unpack_from("<II7d", data, off)
            (n,) = struct.unpack_from("<I", data, off + 64)
            off += 68
            items = [struct.unpack_from("<iIQ", data, off + 16 * j) for j in range(n)]
            off += 16 * n
            frames[fid] = _RawFrame(rid, (tuple(pose[:4]), tuple(pose[4:])), items)
    except struct.error:
        raise PlanError(f"{path}: truncated, or not a COLMAP frames.bin") from None
    return frames


def _check_frames(rigs: dict[int, _RawRig], frames: dict[int, _RawFrame], raw_cams: dict[int, _RawCamera],
                  img: _RawImages, R_cw: np.ndarray, ext: str, warnings: list[str]) -> dict[int, int]:
    """image id → COLMAP frame id, after checking that the frames' rigs, cameras and images exist and
    that the pose a frame gives an image agrees with the image's own (a warning otherwise)."""
    index = {int(iid): k for k, iid in enumerate(img.ids)}
    frame_of: dict[int, int] = {}
    absent: list[int] = []
    disagree: list[tuple[str, float, float]] = []
    for fid, frame in frames.items():
        rig = rigs.get(frame.rig_id)
        if rig is None:
            raise PlanError(f"COLMAP frame {fid} (frames{ext}) belongs to rig {frame.rig_id}, which rigs{ext} lacks")
        R_rw = quaternions_to_R(np.array([frame.rig_from_world[0]]), lambda i, f=fid: f"COLMAP frame {f}")[0]
        t_rw = np.array(frame.rig_from_world[1])
        for stype, sid, did in frame.data:
            if stype != _CAMERA:
                continue
            key = (stype, sid)
            if key != rig.ref and key not in rig.sensors:
                raise PlanError(f"COLMAP frame {fid} (frames{ext}) holds an image of camera {sid}, which is not a "
                                f"sensor of its rig {frame.rig_id} in rigs{ext}")
            if sid not in raw_cams:
                raise PlanError(f"COLMAP frame {fid} (frames{ext}) holds an image of camera {sid}, which cameras{ext} "
                                "lacks")
            k = index.get(int(did))
            if k is None:
                absent.append(int(did))
                continue
            frame_of[int(did)] = fid
            if int(img.camera_ids[k]) != sid:
                warnings.append(f"COLMAP image {img.names[k]!r}: camera {img.camera_ids[k]} in images{ext}, "
                                f"camera {sid} in its frame {fid}; the image's own is used")
            if key == rig.ref:
                R, t = R_rw, t_rw
            elif rig.sensors[key] is not None:
                q_sr, t_sr = rig.sensors[key]  # type: ignore[misc]
                label = f"COLMAP rig {frame.rig_id}, camera {sid}"
                R_sr = quaternions_to_R(np.array([q_sr]), lambda i, w=label: w)[0]
                R, t = R_sr @ R_rw, R_sr @ t_rw + np.array(t_sr)
            else:
                continue  # the rig does not know where this camera sits
            C_frame, C_image = -R.T @ t, -R_cw[k].T @ img.tvec[k]
            angle = float(np.degrees(np.arccos(np.clip((np.trace(R.T @ R_cw[k]) - 1) / 2, -1, 1))))
            shift = float(np.linalg.norm(C_frame - C_image))
            if angle > 1e-4 or shift > 1e-6 * max(1.0, float(np.linalg.norm(C_image))):
                disagree.append((img.names[k], angle, shift))
    if absent:
        warnings.append(f"COLMAP frames refer to {len(absent)} image(s) that images{ext} lacks (ids "
                        f"{sorted(absent)[:10]}{'…' if len(absent) > 10 else ''}): unregistered, skipped")
    unframed = [img.names[k] for iid, k in index.items() if iid not in frame_of]
    if unframed:
        warnings.append(f"{len(unframed)} COLMAP image(s) in no frame of frames{ext} (e.g. {unframed[0]!r}): "
                        "read with their own poses")
    if disagree:
        worst = max(disagree, key=lambda d: (d[1], d[2]))
        warnings.append(f"{len(disagree)} COLMAP image(s) have a pose in images{ext} that differs from the one their "
                        f"frame and rig give (e.g. {worst[0]!r}: {worst[1]:.3g}°, {worst[2]:.3g} m): the image's own "
                        "pose is used")
    return frame_of


def _camera(cid: int, raw: _RawCamera, warnings: list[str]) -> Camera:
    """sightplan camera of COLMAP camera ``cid``; appends what is approximated to ``warnings``."""
    if raw.model not in _BY_NAME:
        raise PlanError(f"COLMAP camera {cid}: unknown model {raw.model!r}")
    _, n, kind = _BY_NAME[raw.model]
    p = raw.params
    if len(p) != n:
        raise PlanError(f"COLMAP camera {cid} ({raw.model}) has {len(p)} parameters, expected {n}")
    label = f"COLMAP camera {cid} ({raw.model})"
    try:
        if kind == "equirect":
            return EquirectangularCamera(raw.width, raw.height, label)
        fx, fy, cx, cy, rest = (p[0], p[0], p[1], p[2], p[3:]) if kind == "f" else (*p[:4], p[4:])
        camera = PinholeCamera(raw.width, raw.height, fx, fy, cx, cy, label)
    except CameraError as exc:
        raise PlanError(f"{label}: {exc}") from None
    if raw.model in _FISHEYE:
        warnings.append(f"{label}: fisheye projection approximated by a pinhole of the same focal length")
    elif any(rest):
        warnings.append(f"{label}: lens distortion {list(rest)} ignored")
    return camera


def _natural_key(name: str) -> list:
    return [int(t) if t.isdigit() else t for t in re.split(r"(\d+)", name)]


def read_colmap(path: str | Path, *, order: ColmapOrder = "name") -> Plan:
    """A plan from the COLMAP model at ``path`` (folder or file); frames sorted by image
    name (natural order: img2 before img10) or by image id."""
    folder, ext = find_colmap_model(path)
    if order not in ("name", "id"):
        raise PlanError(f"order must be 'name' or 'id', got {order!r}")
    if ext == ".bin":
        raw_cams, img = _read_cameras_bin(folder / "cameras.bin"), _read_images_bin(folder / "images.bin")
    else:
        raw_cams, img = _read_cameras_txt(folder / "cameras.txt"), _read_images_txt(folder / "images.txt")
    if len(img.ids) == 0:
        raise PlanError(f"the COLMAP model in {folder} has no images")
    missing = sorted(set(img.camera_ids.tolist()) - set(raw_cams))
    if missing:
        raise PlanError(f"COLMAP images refer to camera(s) {missing} that cameras{ext} lacks")
    warnings: list[str] = []
    used = sorted(set(img.camera_ids.tolist()))
    cameras = {str(cid): _camera(cid, raw_cams[cid], warnings) for cid in used}
    R_cw = quaternions_to_R(img.qvec, lambda i: f"COLMAP image {img.names[i]!r}")
    source: dict = {"format": "colmap", "path": str(folder)}
    parameters: dict = {"source": source, "warnings": warnings}
    has_rigs, has_frames = (folder / f"rigs{ext}").is_file(), (folder / f"frames{ext}").is_file()
    if has_rigs and has_frames:
        rigs = _read_rigs_bin(folder / "rigs.bin") if ext == ".bin" else _read_rigs_txt(folder / "rigs.txt")
        frames = _read_frames_bin(folder / "frames.bin") if ext == ".bin" else _read_frames_txt(folder / "frames.txt")
        frame_of = _check_frames(rigs, frames, raw_cams, img, R_cw, ext, warnings)
        source.update(layout="rigs and frames (COLMAP 3.12 or later)", rigs=len(rigs), frames=len(frames))
        parameters["colmap_frames"] = {img.names[k]: frame_of.get(int(iid)) for k, iid in enumerate(img.ids)}
    elif has_rigs or has_frames:
        there, absent = ("rigs", "frames") if has_rigs else ("frames", "rigs")
        warnings.append(f"{there}{ext} without {absent}{ext}: ignored, the images' own poses are used")
    if order == "name":
        perm = np.array(sorted(range(len(img.names)), key=lambda i: _natural_key(img.names[i])), int)
    else:
        perm = np.argsort(img.ids, kind="stable")
    names = [img.names[i] for i in perm]
    R_wc = np.transpose(R_cw[perm], (0, 2, 1))
    C = -np.einsum("nij,nj->ni", R_wc, img.tvec[perm])
    return Plan.build(cameras, R_wc, C, frame_camera=[str(c) for c in img.camera_ids[perm]], frame_names=names,
                      parameters=parameters)


def _read(source: Source, options: ReadOptions) -> Plan:
    return read_colmap(source.path)


FORMAT = FlightFormat(name="colmap", label="COLMAP", order=3, read=_read, suffixes=(".bin", ".txt"), folder=True)
