"""Cameras the user describes: a camera JSON file, or a ``--camera`` option with ``--focal-mm``.

A camera file holds one JSON object, in one of these forms (pixels in sightplan's convention,
pixel centres at +½, as in a plan file's ``cameras``):

- ``{"model": "pinhole", "width", "height", "fx", "fy", "cx", "cy", "name"}``: intrinsics in px;
  ``"convention": "opencv"`` marks ``cx, cy`` with pixel centres at integers (shifted by +½);
- ``{"model": "pinhole", "width", "height", "sensor_width_mm", "focal_mm", "name"}``: the sensor
  width and the lens in mm, square pixels, the principal point at the image centre; with
  ``"sensor_height_mm"`` the pixels follow the sensor's aspect;
- ``{"model": "equirectangular", "width", "height", "name"}``: a 360° camera (width = 2 × height);
- without ``"model"``: any other form :func:`~sightplan.camera.catalogue.parse_camera_spec` takes,
  e.g. ``{"catalogue": "p1", "focal_mm": 24}``.

``"name"`` is optional. Every camera read here is checked (:func:`check_camera`) and refused with
one error naming what is impossible: a size that is not a positive whole number of pixels, a
value that is not a finite number, a principal point outside the image, a field of view under
0.1° or over 170°, or pixels more than 4 times taller than wide (or wider than tall).
"""

from __future__ import annotations

import json
import math
import os
from dataclasses import replace
from pathlib import Path
from typing import Any

from ..errors import CameraError
from .catalogue import get_camera
from .models import Camera, EquirectangularCamera, PinholeCamera, camera_from_dict

MIN_FOV_DEG = 0.1
MAX_PIXEL_ASPECT = 4.0

_PINHOLE_PX = {"fx", "fy", "cx", "cy"}
_PINHOLE_MM = {"sensor_width_mm", "focal_mm"}
_ALLOWED = {
    "pinhole": {"model", "name", "width", "height", "fx", "fy", "cx", "cy", "convention", "sensor_width_mm",
                "sensor_height_mm", "focal_mm"},
    "equirectangular": {"model", "name", "width", "height"},
}
_INFORMATIVE = {"format", "version", "notes", "source", "kind"}


def _value(spec: dict, key: str, where: str, *, positive: bool = False) -> float:
    value = spec[key]
    if isinstance(value, bool) or not isinstance(value, (int, float)):
        raise CameraError(f"{where}: impossible camera: {key} must be a number, got {value!r}")
    if not math.isfinite(value):
        raise CameraError(f"{where}: impossible camera: {key} is {value}, not a finite number")
    if positive and value <= 0:
        raise CameraError(f"{where}: impossible camera: {key} must be positive, got {value:g}")
    return float(value)


def _size(spec: dict, key: str, where: str) -> int:
    if key not in spec:
        raise CameraError(f"{where}: a {spec.get('model', 'camera')} camera needs {key!r} (image size in px)")
    value = _value(spec, key, where, positive=True)
    if not value.is_integer():
        raise CameraError(f"{where}: impossible camera: {key} must be a whole number of pixels, got {value:g}")
    return int(value)


def check_camera(cam: Camera, where: str = "camera") -> Camera:
    """``cam`` itself when it is a camera that can exist; else one :class:`CameraError` saying why."""
    if isinstance(cam, EquirectangularCamera):
        return cam
    W, H = cam.width, cam.height
    if not (0 <= cam.cx <= W and 0 <= cam.cy <= H):
        raise CameraError(f"{where}: impossible camera: the principal point (cx, cy) = ({cam.cx:g}, {cam.cy:g}) px "
                          f"lies outside the {W} × {H} px image")
    aspect = cam.fy / cam.fx
    if not (1 / MAX_PIXEL_ASPECT <= aspect <= MAX_PIXEL_ASPECT):
        raise CameraError(f"{where}: impossible camera: fy / fx = {aspect:.3g} (pixels {aspect:.3g} times as tall as "
                          "wide); check fx and fy, or the sensor height")
    fov = min(cam.hfov_deg, cam.vfov_deg)
    if fov < MIN_FOV_DEG:
        raise CameraError(f"{where}: impossible camera: a field of view of {fov:.3g}° (fx = {cam.fx:g} px on "
                          f"{W} px); check the units: focal lengths in px, or focal_mm with sensor_width_mm in mm")
    return cam


def camera_from_json(spec: Any, where: str = "camera") -> Camera:
    """A checked camera from a camera object (see the module docstring); errors start with ``where``."""
    if not isinstance(spec, dict):
        raise CameraError(f"{where}: a camera is a JSON object such as {{\"model\": \"pinhole\", \"width\": …}}, "
                          f"got {type(spec).__name__}")
    model = spec.get("model")
    if model is None:
        try:
            return check_camera(parse_camera_spec(spec), where)
        except CameraError as exc:
            raise CameraError(f"{where}: {exc}") from None
    if model not in _ALLOWED:
        raise CameraError(f"{where}: unknown camera model {model!r}; expected 'pinhole' or 'equirectangular'")
    unknown = sorted(set(spec) - _ALLOWED[model] - _INFORMATIVE)
    if unknown:
        raise CameraError(f"{where}: a {model} camera has no field(s) {', '.join(map(repr, unknown))}; "
                          f"expected {', '.join(sorted(_ALLOWED[model] - {'model'}))}")
    name = spec.get("name", "")
    if not isinstance(name, str):
        raise CameraError(f"{where}: the camera's name must be a string, got {name!r}")
    width, height = _size(spec, "width", where), _size(spec, "height", where)
    try:
        if model == "equirectangular":
            return EquirectangularCamera(width, height, name)
        px, mm = _PINHOLE_PX & set(spec), _PINHOLE_MM & set(spec)
        if px and mm:
            raise CameraError(f"{where}: give a pinhole camera either in px (fx, fy, cx, cy) or in mm "
                              "(sensor_width_mm, focal_mm), not both")
        if mm:
            if mm != _PINHOLE_MM:
                raise CameraError(f"{where}: a pinhole camera in mm needs sensor_width_mm and focal_mm")
            sw = _value(spec, "sensor_width_mm", where, positive=True)
            f = _value(spec, "focal_mm", where, positive=True)
            sh = _value(spec, "sensor_height_mm", where, positive=True) if "sensor_height_mm" in spec else None
            return check_camera(PinholeCamera.from_sensor(sw, f, width, height, sh, name), where)
        if px != _PINHOLE_PX:
            raise CameraError(f"{where}: a pinhole camera needs fx, fy, cx and cy in px (missing "
                              f"{', '.join(sorted(_PINHOLE_PX - px))}), or sensor_width_mm and focal_mm in mm")
        fx, fy = _value(spec, "fx", where, positive=True), _value(spec, "fy", where, positive=True)
        cx, cy = _value(spec, "cx", where), _value(spec, "cy", where)
        convention = spec.get("convention", "sightplan")
        if convention == "opencv":
            cam = PinholeCamera.from_opencv(fx, fy, cx, cy, width, height, name)
        elif convention == "sightplan":
            cam = PinholeCamera(width, height, fx, fy, cx, cy, name)
        else:
            raise CameraError(f"{where}: convention must be 'sightplan' (pixel centres at +0.5, the default) or "
                              f"'opencv' (pixel centres at integers), got {convention!r}")
        return check_camera(cam, where)
    except CameraError as exc:
        text = str(exc)
        raise CameraError(text if text.startswith(where) else f"{where}: impossible camera: {text}") from None


def read_camera_file(path: str | Path) -> Camera:
    """The checked camera in the JSON file ``path`` (see the module docstring)."""
    path = Path(path)
    try:
        text = path.read_text(encoding="utf-8")
    except FileNotFoundError:
        raise CameraError(f"no camera file {path}") from None
    except (OSError, UnicodeDecodeError) as exc:
        raise CameraError(f"cannot read the camera file {path}: {getattr(exc, 'strerror', None) or exc}") from None
    try:
        data = json.loads(text)
    except ValueError as exc:
        raise CameraError(f"{path.name} is not a JSON camera: {exc}") from None
    cam = camera_from_json(data, path.name)
    if not cam.name:
        cam = replace(cam, name=path.stem)
    return cam


def is_camera_file(text: str) -> bool:
    """Whether a ``--camera`` value names a file (a ``.json`` name or a path) rather than a camera."""
    text = str(text)
    return text.lower().endswith(".json") or os.sep in text or (os.altsep is not None and os.altsep in text)


def camera_from_option(spec: str, focal_mm: float | None = None) -> Camera:
    """The camera a user names: a catalogue id or name, a sensor-table "Make Model" with ``focal_mm``
    (the lens, in mm; it also replaces a catalogue camera's lens), or a camera JSON file."""
    if focal_mm is not None and (isinstance(focal_mm, bool) or not math.isfinite(focal_mm) or focal_mm <= 0):
        raise CameraError(f"--focal-mm must be a positive number of millimetres, got {focal_mm!r}")
    if is_camera_file(spec):
        if focal_mm is not None:
            raise CameraError(f"--focal-mm is for a catalogue or sensor-table camera, not a camera file ({spec}): "
                              "put focal_mm (with sensor_width_mm) in the file")
        return read_camera_file(spec)
    return check_camera(get_camera(spec, focal_mm=focal_mm), spec if focal_mm is None else f"{spec} with {focal_mm:g} mm")


def _number(spec: dict, key: str) -> float:
    value = spec[key]
    if isinstance(value, bool) or not isinstance(value, (int, float)):
        raise CameraError(f"camera field {key!r} must be a number, got {value!r}")
    return float(value)


def _pixels(spec: dict, key: str) -> int:
    value = _number(spec, key)
    if value != int(value):
        raise CameraError(f"camera field {key!r} must be whole pixels, got {value!r}")
    return int(value)


_SENSOR_KEYS = {"sensor_width_mm", "focal_mm", "width", "height"}
_INTRINSIC_KEYS = {"fx", "fy", "cx", "cy", "width", "height"}


def parse_camera_spec(spec: str | Path | dict | Camera) -> Camera:
    """A camera from any of the forms a user may write.

    - a catalogue (or sensor-table) name: ``"p4p"``;
    - the path of a camera JSON file (a ``.json`` name, or with a folder): see :mod:`.files`;
    - ``{"catalogue": "p1", "focal_mm": 24}``;
    - a camera dict as written by ``Camera.to_dict``: ``{"model": "pinhole", ...}``;
    - a physical camera: ``{"sensor_width_mm", "focal_mm", "width", "height"}`` (+ optional
      ``"sensor_height_mm"``, ``"name"``), mm and px;
    - intrinsics in px: ``{"fx", "fy", "cx", "cy", "width", "height", "convention"}`` with
      convention ``"opencv"`` (pixel centres at integers, shifted by +½) or ``"sightplan"``
      (pixel centres at +½, as COLMAP).
    """
    if isinstance(spec, (PinholeCamera, EquirectangularCamera)):
        return spec
    if isinstance(spec, str | Path):
        if isinstance(spec, Path) or is_camera_file(spec):
            return read_camera_file(spec)
        return get_camera(spec)
    if not isinstance(spec, dict):
        raise CameraError(f"a camera spec must be a name or an object, got {type(spec).__name__}")
    name = str(spec.get("name", ""))
    if "model" in spec:
        return camera_from_dict(spec)
    if "catalogue" in spec:
        focal = _number(spec, "focal_mm") if "focal_mm" in spec else None
        return get_camera(str(spec["catalogue"]), focal_mm=focal)
    if _SENSOR_KEYS <= set(spec):
        sh = _number(spec, "sensor_height_mm") if "sensor_height_mm" in spec else None
        return PinholeCamera.from_sensor(_number(spec, "sensor_width_mm"), _number(spec, "focal_mm"),
                                         _pixels(spec, "width"), _pixels(spec, "height"), sh, name)
    if _INTRINSIC_KEYS <= set(spec):
        fx, fy, cx, cy = (_number(spec, k) for k in ("fx", "fy", "cx", "cy"))
        w, h = _pixels(spec, "width"), _pixels(spec, "height")
        convention = spec.get("convention")
        if convention == "opencv":
            return PinholeCamera.from_opencv(fx, fy, cx, cy, w, h, name)
        if convention == "sightplan":
            return PinholeCamera(w, h, fx, fy, cx, cy, name)
        raise CameraError(
            f"camera intrinsics need \"convention\": \"opencv\" (pixel centres at integers) or \"sightplan\" "
            f"(pixel centres at +0.5, as COLMAP), got {convention!r}"
        )
    raise CameraError(
        f"a camera spec with fields {sorted(spec)} matches no known form: give a catalogue name, "
        "{'model': 'pinhole'|'equirectangular', ...}, {'sensor_width_mm', 'focal_mm', 'width', 'height'} "
        "or {'fx', 'fy', 'cx', 'cy', 'width', 'height', 'convention'}"
    )
