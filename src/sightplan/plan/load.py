"""One entry point for every plan or pose file: :func:`load_plan`.

Formats (the :data:`PlanFormat` names, shared with the CLI and the web API) are the readers of
:mod:`sightplan.formats`, one module each, found by :mod:`sightplan.formats.registry`: sightplan's JSON
plan, OpenSfM and COLMAP reconstructions, pose tables and flight-app missions (QGroundControl, QGC WPL,
DJI WPML, Litchi).

The format of a file is told by its suffix (:func:`detect_format`); where several formats claim one,
by its content: a ``.json`` file is a sightplan plan or an OpenSfM reconstruction, a ``.txt`` file whose
first line is ``QGC WPL 110`` is a waypoint file and any other ``.txt`` a COLMAP text model, a ``.csv`` with
Litchi's header a Litchi mission and any other a pose table.
"""

from __future__ import annotations

import json
from dataclasses import replace
from pathlib import Path
from typing import Literal

import numpy as np
from numpy.typing import ArrayLike

from ..camera.files import parse_camera_spec
from ..camera.models import Camera
from ..errors import PlanError
from ..formats.base import FlightFormat, ReadOptions, Source
from ..formats.registry import FILE_SUFFIXES, PLAN_FORMATS, READERS, PlanFormat, reader
from ..geo import Georeference
from .types import Plan

__all__ = ["PLAN_FORMATS", "PlanFormat", "apply_similarity", "detect_format", "load_plan", "read_transform",
           "scene_placement"]


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


def sniffed(source: Source) -> FlightFormat:
    """The reader of ``source``: the one format claiming its suffix (or reading folders); where several do, the first
    whose ``sniff`` recognises the content, else the one without a sniff."""
    path = source.path
    if path.is_dir():
        claims = [f for f in READERS if f.folder]
    else:
        claims = [f for f in READERS if source.suffix in f.suffixes]
    if not claims:
        kinds = [*FILE_SUFFIXES, *(f"a {f.label} model folder" for f in READERS if f.folder)]
        raise PlanError(f"cannot tell the format of {path}: expected {', '.join(kinds[:-1])} or {kinds[-1]}; pass fmt=")
    if len(claims) == 1:
        return claims[0]
    for f in claims:
        if f.sniff is not None and f.sniff(source):
            return f
    fallback = [f for f in claims if f.sniff is None]
    if fallback:
        return fallback[0]
    raise PlanError(f"{path} is neither {' nor '.join(f.what for f in claims)}")


def detect_format(path: str | Path) -> PlanFormat:
    """The format of ``path``: see :func:`sniffed`."""
    return sniffed(Source(path)).name


def scene_placement(scene) -> dict:
    """The ``georef``, ``ground_z`` and ``takeoff_z`` of :func:`load_plan` for a flight-app mission checked against
    ``scene``: the model's georeference and the site's ground (:func:`~sightplan.plan.ground.ground_of`), which is the
    take-off height too when the user gave it (``--ground-z``, the web form's ground z)."""
    from .ground import ground_of

    ground = ground_of(scene)
    return {"georef": Georeference.from_scene_metadata(scene.metadata), "ground_z": ground.level_m,
            "takeoff_z": ground.level_m if ground.source == "user" else None}


def load_plan(
    path: str | Path,
    *,
    fmt: PlanFormat | Literal["auto"] = "auto",
    camera: Camera | str | dict | None = None,
    transform: ArrayLike | str | Path | None = None,
    georef: Georeference | None = None,
    ground_z: float | None = None,
    takeoff_z: float | None = None,
) -> Plan:
    """A Plan from any supported file or folder.

    camera: the camera of CSV rows without one, and of flight-app missions (qgc, wpl, wpml, litchi)
    that name no camera the catalogue knows (the formats whose reader ``uses_camera``); for the
    other formats it replaces every camera of the file (recorded in ``plan.parameters["warnings"]``). Catalogue name, spec dict
    (:func:`parse_camera_spec`) or camera model.
    georef: for flight-app missions (latitude/longitude), the georeference that places them in
    the model frame; without one they get a topocentric frame at their take-off point.
    Flight-app missions take off from the file's own reference (QGroundControl's ``plannedHomePosition``, a WPL
    file's line 0, DJI's ``takeOffRefPoint``): its heights above take-off start there, at the height the file gives
    in the georeference's datum (:func:`~sightplan.formats.reading.place_takeoff`). It becomes
    ``plan.parameters["takeoff_m"]``; ``plan.parameters["home"]["from"]`` says where its height came from.
    ground_z: the model-frame height of the site's ground: the take-off height of a mission whose file has no usable
    reference (none, as in Litchi; no height; a frame of its own; more than 100 m from this ground; more than 5 km
    from the model's origin: each said in ``plan.parameters["warnings"]``).
    takeoff_z: a model-frame take-off height the user gives: it replaces the file's reference height.
    transform: optional (4, 4) similarity (or a JSON file of one, :func:`read_transform`) from the file's frame to the model frame
    (:func:`apply_similarity`).
    """
    spec = reader(fmt) if fmt != "auto" else None
    path = Path(path)
    if not path.exists():
        raise PlanError(f"no such file or folder: {path}")
    source = Source(path)
    spec = spec or sniffed(source)
    plan = spec.read(source, ReadOptions(camera=camera, georef=georef, ground_z=ground_z, takeoff_z=takeoff_z))
    if camera is not None and not spec.uses_camera:
        cam = parse_camera_spec(camera)
        cid = cam.name or "camera"
        warnings = [*plan.parameters.get("warnings", []),
                    f"camera {cid!r} given: replaces the file's camera(s) {', '.join(map(repr, plan.cameras))}"]
        plan = replace(plan, cameras={cid: cam}, frame_camera=np.full(len(plan), cid, dtype=object),
                       parameters={**plan.parameters, "warnings": warnings})
    if spec.name in FLIGHT_APPS and plan.parameters.get("takeoff_m") is not None:
        plan = _pilot_at_takeoff(plan)
    if transform is not None:
        if isinstance(transform, str | Path):
            transform = read_transform(transform)
        plan = apply_similarity(plan, transform)
    return plan


FLIGHT_APPS = ("qgc", "wpl", "wpml", "litchi")  # missions read from a flight app take off where the file says


def _pilot_at_takeoff(plan: Plan) -> Plan:
    """A flight-app mission's pilot stands at its take-off point (1.5 m up, as a pilot station): the line-of-sight
    and battery checks measure from there, not from a corner of the region."""
    from .ground import GROUND_STATION_HEIGHT_M

    station = tuple(float(v) for v in np.asarray(plan.parameters["takeoff_m"], float) + [0, 0, GROUND_STATION_HEIGHT_M])
    missions = tuple(m if m.ground_station is not None else replace(m, ground_station=station) for m in plan.missions)
    return replace(plan, missions=missions)
