"""One entry point for every plan or pose file: :func:`load_plan`.

Formats (the :data:`PlanFormat` names, shared with the CLI and the web API):

- ``sightplan``: sightplan's JSON plan (:mod:`.format`);
- ``opensfm``: OpenSfM ``reconstruction.json`` (:mod:`.io_opensfm`);
- ``csv``: a pose table (:mod:`.io_csv`);
- ``colmap``: a COLMAP sparse model, folder or file (:mod:`.io_colmap`);
- ``qgc``: a QGroundControl ``.plan`` mission (:mod:`.io_qgc`);
- ``wpl``: a ``QGC WPL 110`` waypoint file, ``.waypoints`` or ``.txt`` (:mod:`.io_qgc`);
- ``wpml``: a DJI WPML ``.kmz`` mission (:mod:`.io_wpml`).

A ``.txt`` file whose first line is ``QGC WPL 110`` is a waypoint file; any other ``.txt`` is
taken as a COLMAP text model.
"""

from __future__ import annotations

import json
from dataclasses import replace
from pathlib import Path
from typing import Literal, get_args

import numpy as np
from numpy.typing import ArrayLike

from ..camera.files import parse_camera_spec
from ..camera.models import Camera
from ..errors import PlanError
from ..geo import Georeference
from .format import FORMAT_NAME, plan_from_dict, read_json
from .io_colmap import find_colmap_model, read_colmap
from .io_csv import read_csv_plan
from .io_opensfm import opensfm_from_data
from .io_qgc import read_qgc_plan, read_wpl, sniff_wpl
from .io_wpml import read_wpml
from .types import Plan

PlanFormat = Literal["sightplan", "opensfm", "csv", "colmap", "qgc", "wpl", "wpml"]
FLIGHT_FORMATS = ("qgc", "wpl", "wpml")
PLAN_FORMATS: tuple[str, ...] = get_args(PlanFormat)


def apply_similarity(plan: Plan, T_model_source: ArrayLike) -> Plan:
    """The plan moved by the (4, 4) similarity ``[[s·R_s, t], [0, 1]]`` (source → model frame).

    Centres and waypoints: ``x' = s R_s x + t``; rotations: ``R' = R_s R``. The 3×3 block
    must be a positive multiple of a rotation (to 1e-3; it is then projected exactly).
    """
    T = np.asarray(T_model_source, float)
    if T.shape != (4, 4) or not np.isfinite(T).all():
        raise PlanError(f"transform must be a finite (4, 4) matrix, got shape {T.shape}")
    if not np.allclose(T[3], [0, 0, 0, 1], atol=1e-9):
        raise PlanError(f"transform's last row must be [0, 0, 0, 1], got {T[3].tolist()}")
    M, t = T[:3, :3], T[:3, 3]
    det = np.linalg.det(M)
    if det <= 0:
        raise PlanError(f"transform's 3×3 block has determinant {det:.6g}: a reflection or degenerate, not s·R")
    s = np.cbrt(det)
    U, _, Vt = np.linalg.svd(M / s)
    R_s = U @ Vt
    if np.abs(M / s - R_s).max() > 1e-3:
        raise PlanError("transform's 3×3 block is not a uniform scale times a rotation (shear or unequal scales)")
    params = dict(plan.parameters)
    warnings = list(params.get("warnings", []))
    if "georeference" in params:
        params["source_georeference"] = params.pop("georeference")
        warnings.append("transform applied: the source georeference no longer describes the plan's frame "
                        "(kept as parameters['source_georeference'])")
    params["transform"] = {"matrix": T.tolist(), "scale": float(s)}
    params["warnings"] = warnings
    return replace(
        plan,
        C_world=s * plan.C_world @ R_s.T + t,
        R_world_camera=np.einsum("ij,njk->nik", R_s, plan.R_world_camera),
        waypoints=s * np.asarray(plan.waypoints, float).reshape(-1, 3) @ R_s.T + t,
        parameters=params,
    )


def in_capture_order(plan: Plan) -> Plan:
    """A flown capture with a time on every frame, sorted by it (tracks follow capture time, METRICS.md §5.3)."""
    t = plan.capture_time
    if len(t) < 2 or not np.isfinite(t).all() or np.all(np.diff(t) >= 0):
        return plan
    order = np.argsort(t, kind="stable")
    params = dict(plan.parameters)
    params["warnings"] = [*params.get("warnings", []), "frames were not in capture-time order: sorted by time"]
    return replace(plan.subset(order), parameters=params)


def read_transform(path: str | Path) -> np.ndarray:
    """A (4, 4) similarity from a JSON file: a 4×4 list, ``{"matrix": 4×4}``, or
    ``{"scale": s, "rotation": 3×3, "translation": [x, y, z]}`` (source → model frame)."""
    path = Path(path)
    try:
        d = json.loads(path.read_text(encoding="utf-8"))
    except OSError as exc:
        raise PlanError(f"cannot read the transform {path}: {exc.strerror}") from None
    except (ValueError, UnicodeDecodeError) as exc:
        raise PlanError(f"{path.name} is not a JSON transform: {exc}") from None
    try:
        if isinstance(d, dict) and "matrix" in d:
            d = d["matrix"]
        if isinstance(d, dict):
            T = np.eye(4)
            T[:3, :3] = float(d.get("scale", 1.0)) * np.asarray(d["rotation"], float).reshape(3, 3)
            T[:3, 3] = np.asarray(d["translation"], float).reshape(3)
            return T
        return np.asarray(d, float)
    except (KeyError, TypeError, ValueError) as exc:
        raise PlanError(f"{path.name}: a transform is a 4×4 matrix or scale/rotation/translation ({exc})") from None


def detect_format(path: str | Path) -> PlanFormat:
    """The format of ``path`` from its name, and for .txt/.waypoints from its first line (.json: see :func:`load_plan`)."""
    path = Path(path)
    suffix = path.suffix.lower()
    if path.is_dir():
        return "colmap"
    if suffix == ".plan":
        return "qgc"
    if suffix == ".kmz":
        return "wpml"
    if suffix == ".waypoints" or (suffix == ".txt" and sniff_wpl(path)):
        return "wpl"
    if suffix in (".bin", ".txt"):
        return "colmap"
    if suffix == ".csv":
        return "csv"
    if suffix == ".json":
        return "sightplan"
    raise PlanError(f"cannot tell the format of {path}: expected .json, .csv, .plan, .kmz, .waypoints or a COLMAP model "
                    "folder; pass fmt=")


def _from_json(path: Path, fmt: PlanFormat | Literal["auto"]) -> Plan:
    data = read_json(path)
    if fmt == "auto":
        if isinstance(data, dict) and data.get("format") == FORMAT_NAME:
            fmt = "sightplan"
        elif isinstance(data, list) and data and isinstance(data[0], dict) and "shots" in data[0]:
            fmt = "opensfm"
        else:
            raise PlanError(f"{path} is neither a sightplan plan ('format': {FORMAT_NAME!r}) "
                            "nor an OpenSfM reconstruction (a list of reconstructions with 'shots')")
    if fmt == "opensfm":
        return opensfm_from_data(data, source=str(path))
    return plan_from_dict(data)


def load_plan(
    path: str | Path,
    *,
    fmt: PlanFormat | Literal["auto"] = "auto",
    camera: Camera | str | dict | None = None,
    transform: ArrayLike | str | Path | None = None,
    georef: Georeference | None = None,
    ground_z: float | None = None,
) -> Plan:
    """A Plan from any supported file or folder.

    camera: the camera of CSV rows without one, and of flight-app missions (qgc, wpl, wpml)
    that name no camera the catalogue knows; for the other formats it replaces every camera
    of the file (recorded in ``plan.parameters["warnings"]``). Catalogue name, spec dict
    (:func:`parse_camera_spec`) or camera model.
    georef: for flight-app missions (latitude/longitude), the georeference that places them in
    the model frame; without one they get a topocentric frame at their home point.
    ground_z: for flight-app missions, the model-frame height of the ground the aircraft takes
    off from (e.g. the model's base). Heights above the take-off point are then measured from
    it, not from the file's home altitude: an app's home altitude is a rough terrain value in
    some datum, and a model's elevation is often only nominal.
    transform: optional (4, 4) similarity (or a JSON file of one, :func:`read_transform`) from the file's frame to the model frame
    (:func:`apply_similarity`).
    """
    if fmt != "auto" and fmt not in PLAN_FORMATS:
        raise PlanError(f"unknown plan format {fmt!r}; expected 'auto' or one of {', '.join(PLAN_FORMATS)}")
    path = Path(path)
    if not path.exists():
        raise PlanError(f"no such file or folder: {path}")
    kind = detect_format(path) if fmt == "auto" else fmt
    if kind == "colmap":
        find_colmap_model(path)  # clear error before anything else
        plan = read_colmap(path)
    elif kind == "csv":
        plan = in_capture_order(read_csv_plan(path, camera=camera))
    elif kind == "qgc":
        plan = read_qgc_plan(path, georef=georef, camera=camera, ground_z=ground_z)
    elif kind == "wpl":
        plan = read_wpl(path, georef=georef, camera=camera, ground_z=ground_z)
    elif kind == "wpml":
        plan = read_wpml(path, georef=georef, camera=camera, ground_z=ground_z)
    else:
        plan = _from_json(path, fmt)
    if camera is not None and kind != "csv" and kind not in FLIGHT_FORMATS:
        cam = parse_camera_spec(camera)
        cid = cam.name or "camera"
        warnings = [*plan.parameters.get("warnings", []),
                    f"camera {cid!r} given: replaces the file's camera(s) {', '.join(map(repr, plan.cameras))}"]
        plan = replace(plan, cameras={cid: cam}, frame_camera=np.full(len(plan), cid, dtype=object),
                       parameters={**plan.parameters, "warnings": warnings})
    if transform is not None:
        if isinstance(transform, str | Path):
            transform = read_transform(transform)
        plan = apply_similarity(plan, transform)
    return plan
