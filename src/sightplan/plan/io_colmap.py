"""Import a COLMAP sparse model: ``cameras.{txt,bin}`` and ``images.{txt,bin}``.

Read with our own parser (no pycolmap at run time). COLMAP stores per image the
world-to-camera rotation as a quaternion ``qvec = (w, x, y, z)`` and translation ``tvec``,
with OpenCV camera axes, so ``R_world_camera = R_cwᵀ`` and the centre is ``C = −R_cwᵀ t``.
COLMAP puts the centre of the top-left pixel at (0.5, 0.5), as sightplan does: focal
lengths and principal points are taken unchanged. Lens distortion is dropped, with a
warning in ``plan.parameters["warnings"]``; fisheye models are approximated by a pinhole
of the same focal length (wrong far from the image centre). COLMAP's EQUIRECTANGULAR model
uses sightplan's equirectangular convention (checked against pycolmap 4.2) and is read as
an :class:`EquirectangularCamera`. Points3D are not read.
"""

from __future__ import annotations

import re
import struct
from pathlib import Path
from typing import Literal, NamedTuple

import numpy as np

from ..camera.models import Camera, EquirectangularCamera, PinholeCamera
from ..errors import CameraError, PlanError
from .format import quaternions_to_R
from .types import Plan

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


def find_colmap_model(path: str | Path) -> tuple[Path, str]:
    """(folder, ".bin" or ".txt") of the COLMAP model at ``path``: a folder (also ``sparse/0``
    or ``sparse`` inside it) or one of its files. Binary wins when both are present,
    unless ``path`` names a ``.txt`` file."""
    path = Path(path)
    base = path.parent if path.is_file() else path
    exts = (".txt", ".bin") if path.is_file() and path.suffix == ".txt" else (".bin", ".txt")
    for folder in (base, base / "sparse" / "0", base / "sparse"):
        for ext in exts:
            if (folder / f"cameras{ext}").is_file() and (folder / f"images{ext}").is_file():
                return folder, ext
    raise PlanError(f"no COLMAP model at {path}: expected cameras.bin + images.bin or cameras.txt + images.txt "
                    "(in the folder, or in sparse/0)")


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
    if order == "name":
        perm = np.array(sorted(range(len(img.names)), key=lambda i: _natural_key(img.names[i])), int)
    elif order == "id":
        perm = np.argsort(img.ids, kind="stable")
    else:
        raise PlanError(f"order must be 'name' or 'id', got {order!r}")
    names = [img.names[i] for i in perm]
    R_cw = quaternions_to_R(img.qvec[perm], lambda i: f"COLMAP image {names[i]!r}")
    R_wc = np.transpose(R_cw, (0, 2, 1))
    C = -np.einsum("nij,nj->ni", R_wc, img.tvec[perm])
    return Plan.build(cameras, R_wc, C, frame_camera=[str(c) for c in img.camera_ids[perm]], frame_names=names,
                      parameters={"source": {"format": "colmap", "path": str(folder)}, "warnings": warnings})
