"""OpenSfM ``reconstruction.json`` files (a list of reconstructions).

- A shot's ``rotation`` is the axis-angle vector (radians) of the world-to-camera rotation
  ``R_cw`` and ``translation`` its ``t`` (``x_cam = R_cw x + t``, OpenCV camera axes), so
  ``R_world_camera = R_cwᵀ`` and the centre is ``C = −R_cwᵀ t``.
- Intrinsics are normalised by ``s = max(width, height)``: ``fx = focal_x · s``, and the
  principal point ``c_x`` is an offset from the image centre: ``cx = width/2 + c_x · s``
  (sightplan pixel convention: OpenSfM maps pixel index ``u`` to ``(u + ½ − width/2)/s``).
  Distortion is dropped with a warning; fisheye models are approximated by a pinhole.
  ``spherical``/``equirectangular`` cameras share sightplan's equirectangular convention.
- A georeferenced reconstruction (``reference_lla``) has its poses in the local
  topocentric ENU frame at that point (+X east, +Y north, +Z up, metres); the poses stay
  there and the reference goes to ``plan.parameters["georeference"]``.
- Frames are ordered by ``capture_time`` (shots without one last, by name).
"""

from __future__ import annotations

import math
from pathlib import Path
from typing import Any

import numpy as np

from ..camera.models import Camera, EquirectangularCamera, PinholeCamera
from ..errors import CameraError, PlanError
from ..geometry.poses import R_from_rotvec
from ..plan.format import read_json
from ..plan.types import Plan
from .base import FlightFormat, ReadOptions, Source

_SPHERICAL = {"spherical", "equirectangular"}
_FISHEYE = {"fisheye", "fisheye_opencv", "fisheye62", "fisheye624", "dual"}
_PERSPECTIVE = {"perspective", "brown", "radial", "simple_radial"}
_DISTORTION = ("k1", "k2", "k3", "k4", "k5", "k6", "p1", "p2", "s0", "s1", "s2", "s3")


def _camera(cid: str, d: Any, warnings: list[str]) -> Camera:
    """sightplan camera of OpenSfM camera ``cid``; appends what is approximated to ``warnings``."""
    if not isinstance(d, dict):
        raise PlanError(f"OpenSfM camera {cid!r} must be an object")
    kind = d.get("projection_type", "perspective")
    try:
        w, h = int(d["width"]), int(d["height"])
        if kind in _SPHERICAL:
            return EquirectangularCamera(w, h, cid)
        if kind not in _PERSPECTIVE | _FISHEYE:
            raise PlanError(f"OpenSfM camera {cid!r}: unsupported projection_type {kind!r}")
        s = max(w, h)
        fx = float(d.get("focal_x", d.get("focal"))) * s
        fy = float(d.get("focal_y", d.get("focal"))) * s
        camera = PinholeCamera(w, h, fx, fy, w / 2 + float(d.get("c_x", 0.0)) * s, h / 2 + float(d.get("c_y", 0.0)) * s, cid)
    except KeyError as exc:
        raise PlanError(f"OpenSfM camera {cid!r} lacks the field {exc.args[0]!r}") from None
    except (TypeError, ValueError):
        raise PlanError(f"OpenSfM camera {cid!r} lacks a numeric focal length ('focal' or 'focal_x'/'focal_y')") from None
    except CameraError as exc:
        raise PlanError(f"OpenSfM camera {cid!r}: {exc}") from None
    if kind in _FISHEYE:
        warnings.append(f"camera {cid!r}: {kind} projection approximated by a pinhole of the same focal length")
    elif any(d.get(k, 0.0) for k in _DISTORTION):
        warnings.append(f"camera {cid!r}: lens distortion ignored")
    return camera


def _vectors(shots: dict, names: list[str], field: str) -> np.ndarray:
    out = np.zeros((len(names), 3))
    for i, name in enumerate(names):
        value = shots[name].get(field) if isinstance(shots[name], dict) else None
        try:
            out[i] = np.asarray(value, float).reshape(3)
        except (TypeError, ValueError):
            raise PlanError(f"OpenSfM shot {name!r}: field {field!r} must be 3 numbers, got {value!r}") from None
    bad = np.flatnonzero(~np.isfinite(out).all(axis=1))
    if len(bad):
        raise PlanError(f"OpenSfM shot {names[bad[0]]!r}: field {field!r} is not finite")
    return out


def _capture_time(shot: Any) -> float:
    t = shot.get("capture_time") if isinstance(shot, dict) else None
    return float(t) if isinstance(t, (int, float)) and not isinstance(t, bool) and math.isfinite(t) else math.nan


def opensfm_from_data(data: Any, *, reconstruction: int = 0, source: str = "") -> Plan:
    """A plan from parsed ``reconstruction.json`` content: reconstruction number ``reconstruction``."""
    if not (isinstance(data, list) and data and all(isinstance(r, dict) for r in data)):
        raise PlanError(f"{source or 'data'} is not an OpenSfM reconstruction list")
    if not -len(data) <= reconstruction < len(data):
        raise PlanError(f"reconstruction {reconstruction} asked for, the file has {len(data)}")
    rec = data[reconstruction]
    shots, cams_raw = rec.get("shots"), rec.get("cameras")
    if not isinstance(shots, dict) or not shots or not isinstance(cams_raw, dict):
        raise PlanError(f"OpenSfM reconstruction {reconstruction} has no shots or no cameras")
    warnings: list[str] = []
    if len(data) > 1:
        others = sum(len(r.get("shots", {})) for k, r in enumerate(data) if k != reconstruction % len(data))
        warnings.append(f"{len(data) - 1} other reconstruction(s) with {others} shots not loaded (reconstruction=)")
    names = sorted(shots, key=lambda n: (math.isnan(t := _capture_time(shots[n])), 0.0 if math.isnan(t) else t, n))
    cam_ids = [shots[n].get("camera") if isinstance(shots[n], dict) else None for n in names]
    unknown = sorted({str(c) for c in cam_ids if c not in cams_raw})
    if unknown:
        raise PlanError(f"OpenSfM shots refer to camera(s) {unknown} the reconstruction lacks")
    cameras = {cid: _camera(cid, cams_raw[cid], warnings) for cid in sorted(set(cam_ids))}
    R_cw = R_from_rotvec(_vectors(shots, names, "rotation"))
    t = _vectors(shots, names, "translation")
    R_wc = np.transpose(R_cw, (0, 2, 1))
    C = -np.einsum("nij,nj->ni", R_wc, t)
    params: dict = {"source": {"format": "opensfm", "path": source, "reconstruction": reconstruction}, "warnings": warnings}
    lla = rec.get("reference_lla")
    if isinstance(lla, dict):
        params["georeference"] = {
            "reference_lla": {k: lla.get(k) for k in ("latitude", "longitude", "altitude")},
            "frame": "local topocentric ENU at reference_lla: +X east, +Y north, +Z up, metres",
        }
    times = np.array([_capture_time(shots[n]) for n in names])
    return Plan.build(cameras, R_wc, C, frame_camera=cam_ids, frame_names=names, capture_time=times, parameters=params)


def read_opensfm(path: str | Path, *, reconstruction: int = 0) -> Plan:
    """A plan from an OpenSfM ``reconstruction.json``; other reconstructions are listed in warnings."""
    return opensfm_from_data(read_json(path), reconstruction=reconstruction, source=str(path))


def sniff(source: Source) -> bool:
    """Whether the JSON is a list of reconstructions with shots."""
    data = source.json()
    return isinstance(data, list) and bool(data) and isinstance(data[0], dict) and "shots" in data[0]


def _read(source: Source, options: ReadOptions) -> Plan:
    return opensfm_from_data(source.json(), source=str(source.path))


FORMAT = FlightFormat(name="opensfm", label="OpenSfM", order=1, read=_read, suffixes=(".json",), sniff=sniff,
                      what="an OpenSfM reconstruction (a list of reconstructions with 'shots')")
