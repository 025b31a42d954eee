"""A reconstruction registered to the model, as files: what ``sightplan reconstruct`` writes and what the
validation and the loop study read.

A reconstruction directory holds

- ``points.npz``: ``xyz`` (n, 3) float64 triangulated points in the model's frame and unit (the Scene's
  coordinates), ``track_length`` (n,) int32 images per point, ``error_px`` (n,) float64 mean reprojection error;
- ``registration.json``: the plan's frame names in plan order, which ones the SfM registered, each registered
  frame's position error (metres) and rotation error (degrees) after the similarity that maps the SfM frame
  onto the model (``scale``, ``R`` 3×3, ``t``), its RMS residual on the camera centres and the scene's size
  (bounding-box diagonal, metres);
- ``sparse/``: the registered COLMAP model itself (optional for reading).
"""

from __future__ import annotations

import json
import math
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np
from numpy.typing import NDArray

from ..errors import SightplanError

POINTS_FILE = "points.npz"
REGISTRATION_FILE = "registration.json"
RECONSTRUCTION_FILES = (POINTS_FILE, REGISTRATION_FILE)


@dataclass(frozen=True)
class Reconstruction:
    """Sparse points and per-frame registration of one SfM run, in the model's frame.

    points (n, 3) float64; track_length (n,) int32; error_px (n,) float64. frame_names, registered,
    position_error_m, rotation_error_deg: one entry per plan frame in plan order (errors NaN where not
    registered). scale, R, t: model = scale·R·x + t for an SfM point x. residual_m: RMS distance between the
    registered centres mapped onto the model and the planned centres. scene_size_m: the model's bounding-box
    diagonal. info: free-form run facts (matcher, timings, counts).
    """

    points: NDArray[np.float64]
    track_length: NDArray[np.int32]
    error_px: NDArray[np.float64]
    frame_names: tuple[str, ...]
    registered: NDArray[np.bool_]
    position_error_m: NDArray[np.float64]
    rotation_error_deg: NDArray[np.float64]
    scale: float
    R: NDArray[np.float64]
    t: NDArray[np.float64]
    residual_m: float
    scene_size_m: float
    info: dict = field(default_factory=dict)

    def __post_init__(self) -> None:
        n, m = len(self.points), len(self.frame_names)
        if self.points.shape != (n, 3) or len(self.track_length) != n or len(self.error_px) != n:
            raise SightplanError("a reconstruction's points, track lengths and errors must have one row per point")
        if not (len(self.registered) == len(self.position_error_m) == len(self.rotation_error_deg) == m):
            raise SightplanError("a reconstruction's registration must have one entry per frame")

    @property
    def n_registered(self) -> int:
        return int(np.count_nonzero(self.registered))

    @property
    def residual_share(self) -> float:
        """The registration residual as a share of the scene's size."""
        return self.residual_m / self.scene_size_m if self.scene_size_m > 0 else math.inf


def pose_error_summary(registered: NDArray, position_error_m: NDArray, rotation_error_deg: NDArray) -> dict:
    """Mean and max position error (m) and rotation error (°) over the registered frames (None when none has one)."""
    reg = np.asarray(registered, bool)
    out = {}
    for key, values in (("position_error_m", position_error_m), ("rotation_error_deg", rotation_error_deg)):
        v = np.asarray(values, np.float64)[reg]
        v = v[np.isfinite(v)]
        out[f"{key}_mean"] = float(v.mean()) if len(v) else None
        out[f"{key}_max"] = float(v.max()) if len(v) else None
    return out


def _num(x) -> float | None:
    """``x`` as a float, None where it is None or not finite (JSON has no NaN)."""
    if x is None:
        return None
    x = float(x)
    return x if math.isfinite(x) else None


def write_reconstruction(rec: Reconstruction, directory: str | Path) -> list[Path]:
    """Write ``points.npz`` and ``registration.json`` into ``directory`` (created); the paths written."""
    d = Path(directory)
    d.mkdir(parents=True, exist_ok=True)
    points = d / POINTS_FILE
    np.savez_compressed(points, xyz=np.asarray(rec.points, np.float64),
                        track_length=np.asarray(rec.track_length, np.int32),
                        error_px=np.asarray(rec.error_px, np.float64))
    reg = d / REGISTRATION_FILE
    reg.write_text(json.dumps({
        "frames": [{"name": name, "registered": bool(ok), "position_error_m": pe, "rotation_error_deg": re}
                   for name, ok, pe, re in zip(rec.frame_names, rec.registered, map(_num, rec.position_error_m),
                                               map(_num, rec.rotation_error_deg), strict=True)],
        "similarity": {"scale": float(rec.scale), "R": np.asarray(rec.R, float).tolist(),
                       "t": np.asarray(rec.t, float).tolist()},
        "residual_m": float(rec.residual_m), "scene_size_m": float(rec.scene_size_m), "info": rec.info,
    }, indent=1))
    return [points, reg]


def read_reconstruction(directory: str | Path) -> Reconstruction:
    """Read a directory written by :func:`write_reconstruction`; one :class:`SightplanError` naming what is wrong."""
    d = Path(directory)
    if not d.is_dir():
        raise SightplanError(f"{d} is not a reconstruction directory (run `sightplan reconstruct` first)")
    missing = [name for name in RECONSTRUCTION_FILES if not (d / name).is_file()]
    if missing:
        raise SightplanError(f"{d} has no {' or '.join(missing)}: it is not a sightplan reconstruction")
    try:
        with np.load(d / POINTS_FILE) as z:
            xyz = np.asarray(z["xyz"], np.float64).reshape(-1, 3)
            track = np.asarray(z["track_length"], np.int32)
            err = np.asarray(z["error_px"], np.float64)
        reg = json.loads((d / REGISTRATION_FILE).read_text())
        frames = reg["frames"]
        sim = reg["similarity"]
        rec = Reconstruction(
            points=xyz, track_length=track, error_px=err,
            frame_names=tuple(str(f["name"]) for f in frames),
            registered=np.array([bool(f["registered"]) for f in frames], bool),
            position_error_m=np.array([np.nan if f["position_error_m"] is None else f["position_error_m"]
                                       for f in frames], np.float64),
            rotation_error_deg=np.array([np.nan if f["rotation_error_deg"] is None else f["rotation_error_deg"]
                                         for f in frames], np.float64),
            scale=float(sim["scale"]), R=np.asarray(sim["R"], np.float64).reshape(3, 3),
            t=np.asarray(sim["t"], np.float64).reshape(3), residual_m=float(reg["residual_m"]),
            scene_size_m=float(reg["scene_size_m"]), info=dict(reg.get("info", {})))
    except SightplanError:
        raise
    except (OSError, ValueError, KeyError, TypeError, json.JSONDecodeError) as exc:
        raise SightplanError(f"{d} is not a readable reconstruction: {exc}") from None
    if not np.isfinite(rec.points).all():
        raise SightplanError(f"{d / POINTS_FILE} has points that are not finite numbers")
    return rec
