"""What the browser front end needs beyond the resource routes: the model as one compact binary geometry, its element
table, a plan version's frames with the flight checks, an evaluation's per-element and per-frame feedback, one element's
values with the frames that see it best, the simulated view of a frame as a PNG, and the page itself (``/``,
``/static/…``) with the JavaScript packages it imports (``/vendor/…``, from ``web/node_modules``)."""

from __future__ import annotations

import gzip
import io
import json
import mimetypes
import struct
import threading
from collections import OrderedDict
from collections.abc import Callable
from pathlib import Path
from typing import Annotated, Any, TypeVar

import numpy as np
from fastapi import APIRouter, HTTPException, Query, Request, Response
from fastapi.responses import FileResponse
from sqlalchemy.orm import Session

from ...assets import PACKAGES
from ...errors import ReportError
from ...plan.domain import MAX_DISTANCE_M
from ..deps import ProjectRead, ServerState, SessionDep, StateDep, in_project, ready_model
from ..models import Evaluation, Model, PlanVersion
from ..scenes import evaluation_scene
from ..schemas import (
    ElementDetailOut,
    ElementTableOut,
    ErrorOut,
    FeedbackOut,
    FlightChecksOut,
    MissionGeometryOut,
    PlanGeometryOut,
)
from ..services import FLIGHT_KEY, FOURD_KEY, REALITY_KEY, flight_settings, load_scene, rebuilt_evaluation
from . import evaluations, plans

router = APIRouter(tags=["viewer"])
NOT_FOUND = {404: {"model": ErrorOut, "description": "No such project, model, plan, version, evaluation, frame or element"}}
NOT_READY = {409: {"model": ErrorOut, "description": "The model is not loaded, or the evaluation is not done (yet)"}}
BAD_VALUE = {422: {"model": ErrorOut, "description": "An unknown metric or bad bounds (the library's message)"}}
PNG = {200: {"description": "A PNG image", "content": {"image/png": {}}}}

STATIC_DIR = Path(__file__).resolve().parents[1] / "static"
COLOURS_JS = Path(__file__).resolve().parents[2] / "report" / "colours.js"
# Only these packages of web/node_modules are served, read-only, under /vendor/<package>/ (3d-tiles-renderer streams
# reality point clouds; its build imports nothing but three.js and its own chunks; swagger-ui-dist draws /docs;
# maplibre-gl draws the map, with its worker beside it).
VENDOR_PACKAGES = PACKAGES
GEOMETRY_MAGIC = b"SPG1"
GEOMETRY_MEDIA = "application/vnd.sightplan.geometry"
NEUTRAL_TARGET = (0.78, 0.81, 0.86)  # elements of a view without an evaluation
VIEW_WIDTH_PX = 480

V = TypeVar("V")


class _Cache:
    """A small thread-safe LRU of values that never change for their key (stored files are never rewritten)."""

    def __init__(self, size: int) -> None:
        self.size = size
        self._items: OrderedDict[Any, Any] = OrderedDict()
        self._lock = threading.Lock()

    def get(self, key: Any, make: Callable[[], V]) -> V:
        with self._lock:
            if key in self._items:
                self._items.move_to_end(key)
                return self._items[key]
        value = make()
        with self._lock:
            self._items[key] = value
            self._items.move_to_end(key)
            while len(self._items) > self.size:
                self._items.popitem(last=False)
        return value


_geometry_cache = _Cache(3)
_checks_cache = _Cache(16)
_evaluation_cache = _Cache(4)
_feedback_cache = _Cache(4)
_engine_cache = _Cache(2)


# --------------------------------------------------------------------------- lookups
plan_version = plans.get_version
done_evaluation = evaluations.done_evaluation


def read_stored_plan(state: ServerState, version: PlanVersion):
    from ...plan.format import read_plan

    return read_plan(state.storage.plan_path(version.stored_name))


def evaluation_result(state: ServerState, ev: Evaluation):
    """The finished evaluation rebuilt from its observations (cached: a result never changes)."""
    folder = state.storage.evaluation_dir(ev.result_dir)
    return _evaluation_cache.get(ev.result_dir, lambda: rebuilt_evaluation(folder, ev.settings, ev.metrics or {}))


def view_engine(state: ServerState, model: Model, d_max: float, session: Session | None = None,
                settings: dict[str, Any] | None = None):
    """A ray engine for simulated views (Embree where it is installed), kept for the next view: over the model, or
    over the scene an evaluation ran against (``settings``: at its capture date, with its reality capture)."""
    from ...engines.registry import make_engine, ray_engine_name

    site = {k: v for k, v in (settings or {}).items() if k in (FOURD_KEY, REALITY_KEY)}

    def make():
        if site and session is not None:
            scene = evaluation_scene(state.storage, session, model.stored_name, site, model.project_id)
        else:
            scene = load_scene(state.storage, model.stored_name)[0]
        return make_engine(ray_engine_name("auto"), scene, d_max=d_max, threads=1)

    return _engine_cache.get((model.project_id, model.stored_name, float(d_max), json.dumps(site, sort_keys=True)), make)


def check_frame(plan, frame: int) -> None:
    if not 0 <= frame < len(plan):
        raise HTTPException(404, f"frame {frame} not found: the plan version has frames 0 to {len(plan) - 1}")


# --------------------------------------------------------------------------- the model
def geometry_bytes(scene) -> bytes:
    """The scene as one merged triangle soup in the viewer frame (Y up, centred; see :class:`ViewerFrame`).

    Layout: ``SPG1``, a little-endian uint32 header length, the JSON header (padded with spaces to 4 bytes), then
    the arrays the header lists (byte offsets from the end of the header, each 4-byte aligned): ``position``
    float32 (V, 3), ``index`` uint32 (F, 3), ``vertex_element`` uint32 (V,) and ``triangle_element`` uint32 (F,).
    The vertices of each element are its own, so a colour per vertex is a colour per element."""
    from ...report.gltf import ViewerFrame, split_elements

    frame = ViewerFrame.of(scene)
    parts = split_elements(scene, frame)
    n_vertices = np.diff(parts.vertex_start)
    n_faces = np.diff(parts.face_start)
    index = parts.faces.astype(np.uint32) + np.repeat(parts.vertex_start[:-1], n_faces).astype(np.uint32)[:, None]
    arrays = {
        "position": np.ascontiguousarray(parts.vertices, np.float32),
        "index": np.ascontiguousarray(index, np.uint32),
        "vertex_element": np.repeat(parts.elements, n_vertices).astype(np.uint32),
        "triangle_element": np.repeat(parts.elements, n_faces).astype(np.uint32),
    }
    pos = arrays["position"]
    header: dict[str, Any] = {
        "format": "sightplan-geometry", "version": 1, "vertices": len(pos), "triangles": len(index),
        "elements": int(scene.n_elements), "elements_with_geometry": len(parts.elements),
        "origin_m": frame.origin.tolist(), "axes": "x east, y up (model z), z = -(model y); metres",
        "bounds": [pos.min(0).tolist(), pos.max(0).tolist()] if len(pos) else [[0, 0, 0], [0, 0, 0]],
        "arrays": {},
    }
    blobs = []
    offset = 0
    for name, arr in arrays.items():
        blobs.append(arr.tobytes())
        header["arrays"][name] = {"dtype": str(arr.dtype), "shape": list(arr.shape), "offset": offset,
                                  "bytes": arr.nbytes}
        offset += (arr.nbytes + 3) // 4 * 4
    text = json.dumps(header, separators=(",", ":")).encode()
    text += b" " * ((-len(text)) % 4)
    out = bytearray(GEOMETRY_MAGIC + struct.pack("<I", len(text)) + text)
    for blob in blobs:
        out += blob + b"\0" * ((-len(blob)) % 4)
    return bytes(out)


def _compressed(request: Request, raw: bytes, gz: bytes, media: str, headers: dict[str, str]) -> Response:
    if "gzip" in request.headers.get("accept-encoding", "").lower():
        return Response(gz, media_type=media, headers={**headers, "Content-Encoding": "gzip", "Vary": "Accept-Encoding"})
    return Response(raw, media_type=media, headers={**headers, "Vary": "Accept-Encoding"})


@router.get("/api/projects/{project_id}/models/{model_id}/geometry", response_class=Response,
            summary="The model as one compact binary triangle soup for the 3D viewer",
            description="`SPG1`, a uint32 header length, a JSON header, then float32 positions (V, 3) in the viewer "
                        "frame (Y up, centred on the model's box, as the glTF export), uint32 triangle indices (F, 3), "
                        "the element index of each vertex (V,) and of each triangle (F,). Gzipped when the client "
                        "accepts it.",
            responses={200: {"description": "The binary geometry", "content": {GEOMETRY_MEDIA: {}}}, **NOT_FOUND,
                       **NOT_READY})
def model_geometry(project: ProjectRead, model_id: int, request: Request, session: SessionDep,
                   state: StateDep) -> Response:
    model = ready_model(session, project.id, model_id)

    def make() -> tuple[bytes, bytes]:
        raw = geometry_bytes(load_scene(state.storage, model.stored_name)[0])
        return raw, gzip.compress(raw, compresslevel=3)

    raw, gz = _geometry_cache.get(model.stored_name, make)
    return _compressed(request, raw, gz, GEOMETRY_MEDIA, {"Cache-Control": "private, max-age=3600"})


@router.get("/api/projects/{project_id}/models/{model_id}/elements", response_model=ElementTableOut,
            summary="The model's element table, column by column",
            description="One list per column, indexed by element: GlobalId, name, IFC class, discipline, storey, "
                        "whether it is a target (counts in the metrics) and its number of triangles.",
            responses={**NOT_FOUND, **NOT_READY})
def model_elements(project: ProjectRead, model_id: int, session: SessionDep, state: StateDep) -> ElementTableOut:
    model = ready_model(session, project.id, model_id)
    scene = load_scene(state.storage, model.stored_name)[0]
    el = scene.elements
    return ElementTableOut(model_id=model.id, count=int(scene.n_elements), global_id=el.global_id.tolist(),
                       name=el.name.tolist(), ifc_class=el.ifc_class.tolist(), discipline=el.discipline.tolist(),
                       storey=el.storey.tolist(), target=el.is_target.tolist(),
                       triangles=np.bincount(scene.face_element, minlength=scene.n_elements).tolist())


# --------------------------------------------------------------------------- a plan version
def _num(x: float | None, digits: int = 3) -> float | None:
    return None if x is None or not np.isfinite(x) else round(float(x), digits)


def plan_flight(plan) -> dict[str, Any]:
    """The flight settings the plan was made with (a template's), else a drone's defaults with the plan's safety
    distance (or 5 m) and a walker's for an indoor route."""
    from ...plan.checks.gate import walked as walked_plan
    from ...plan.templates.registry import default_flight

    recorded = plan.parameters.get(FLIGHT_KEY)
    keys = ("safety_distance_m", "vlos_radius_m", "altitude_limit_m", "aircraft")
    if isinstance(recorded, dict) and set(keys) <= set(recorded):
        return recorded
    walked = walked_plan(plan)
    flight = {k: v for k, v in default_flight(walked).items() if k in keys}  # no minimum height for a plan read in
    if not walked:
        flight["safety_distance_m"] = float(plan.parameters.get("safety_distance_m") or 5.0)
    return flight


def flight_checks(scene, plan, settings) -> dict[str, Any]:
    """The library's flight checks of the plan's missions as they are (``check_plan``), for drawing."""
    from ...plan.checks.feasibility import check_plan

    report = check_plan(scene, plan, settings)
    safety_distance_m, vlos_radius_m = settings.safety_distance_m, settings.vlos_radius_m
    safety = report.safety
    summary = report.to_dict()
    return {
        "ok": report.ok, "safety_distance_m": safety_distance_m, "vlos_radius_m": vlos_radius_m,
        "total_time_s": summary["total_time_s"],
        "clearance_m": [_num(v) for v in safety.waypoint_m],
        "segment_clearance_m": [_num(v) for v in safety.segment_m],
        "unsafe_frames": np.flatnonzero(safety.waypoint_m < safety_distance_m).tolist(),
        "unsafe_segments": np.flatnonzero(safety.segment_m < safety_distance_m).tolist(),
        "in_sight": report.in_sight.tolist(),
        "missions": summary["missions"],
        "violations": list(report.violations),
        "ground": summary["ground"],
        "position_error_m": summary["position_error_m"],
        "trajectory": [{**p.to_dict(), "out": np.round(out, 3).tolist(), "home": np.round(home, 3).tolist()}
                       for p in report.paths for out, home in [p.points()]],
    }


@router.get("/api/projects/{project_id}/plans/{plan_id}/versions/{number}/geometry", response_model=PlanGeometryOut,
            summary="A plan version's frames and missions for the 3D viewer",
            description="Frame names, cameras, positions (model frame, metres) and rotations (R_world_camera, "
                        "row-major), the cameras' intrinsics and fields of view, the missions with their ground "
                        "stations, and the waypoints.",
            responses=NOT_FOUND)
def plan_geometry(project: ProjectRead, plan_id: int, number: int, session: SessionDep, state: StateDep
                  ) -> PlanGeometryOut:
    version = plan_version(session, project.id, plan_id, number)
    plan = read_stored_plan(state, version)
    cameras = {}
    for cid, cam in plan.cameras.items():
        d = cam.to_dict()
        if d["model"] == "pinhole":
            d |= {"hfov_deg": cam.hfov_deg, "vfov_deg": cam.vfov_deg}
        cameras[cid] = d
    return PlanGeometryOut(
        plan_id=plan_id, version=number, frames=len(plan), model_id=version.plan.model_id,
        name=plan.frame_names.tolist(), camera=plan.frame_camera.tolist(),
        position=plan.C_world.tolist(), rotation=plan.R_world_camera.reshape(-1, 9).tolist(),
        cameras=cameras,
        missions=[MissionGeometryOut(name=m.name, start=m.start, stop=m.stop,
                                     ground_station=None if m.ground_station is None else list(m.ground_station))
                  for m in plan.missions],
        waypoints=np.asarray(plan.waypoints).reshape(-1, 3).tolist(),
        parameters={k: v for k, v in plan.parameters.items() if k != "georeference"},
        north_offset_deg=north_offset(plan),
    )


def north_offset(plan) -> float | None:
    """The true heading of model +Y at the plan's centre (the exports' headings less the model's), or None."""
    from ...geo import Georeference, GeoreferenceError

    geo = plan.parameters.get("georeference")
    if not isinstance(geo, dict) or not len(plan):
        return None
    try:
        centre = np.asarray(plan.C_world, float).mean(axis=0)
        return round(float(Georeference.from_dict(geo).north_offset_deg(centre)[0]), 4)
    except (GeoreferenceError, ValueError, KeyError, TypeError):
        return None


@router.get("/api/projects/{project_id}/plans/{plan_id}/versions/{number}/checks", response_model=FlightChecksOut,
            summary="Can a plan version be flown? Its flight checks against the model",
            description="The checks of `sightplan check` on the version's missions as they are: the clearance of "
                        "every waypoint and segment, the frames and segments closer than the safety distance, line of "
                        "sight from each mission's ground station within the VLOS radius, altitude and battery, and "
                        "every violation as one sentence.",
            responses={**NOT_FOUND, **NOT_READY,
                       422: {"model": ErrorOut, "description": "No model given, or bad check settings"}})
def plan_checks(project: ProjectRead, plan_id: int, number: int, session: SessionDep, state: StateDep,
                model_id: Annotated[int | None, Query(description="Model to check against (default: the plan's)")]
                = None,
                safety_distance_m: Annotated[float | None, Query(
                    gt=0, le=MAX_DISTANCE_M, allow_inf_nan=False,
                    description="Least distance to the model (m); default: the plan's")] = None,
                vlos_radius_m: Annotated[float | None, Query(
                    ge=0, le=MAX_DISTANCE_M, allow_inf_nan=False,
                    description="Visual line-of-sight radius (m); 0: none; default: the plan's")] = None,
                ) -> FlightChecksOut:
    version = plan_version(session, project.id, plan_id, number)
    model_id = model_id if model_id is not None else version.plan.model_id
    if model_id is None:
        raise HTTPException(422, f"plan {plan_id} is for no model: give model_id")
    model = ready_model(session, project.id, model_id)
    plan = read_stored_plan(state, version)
    settings = flight_settings(plan_flight(plan), safety_distance_m=safety_distance_m, vlos_radius_m=vlos_radius_m)
    key = (settings.safety_distance_m, settings.vlos_radius_m, settings.altitude_limit_m,
           getattr(settings.aircraft, "name", None))

    def make() -> dict[str, Any]:
        scene = load_scene(state.storage, model.stored_name)[0]
        return flight_checks(scene, plan, settings)

    return FlightChecksOut(plan_id=plan_id, version=number, model_id=model_id,
                           **_checks_cache.get((version.stored_name, model.stored_name, *key), make))


# --------------------------------------------------------------------------- an evaluation
def feedback_dict(state: ServerState, session: Session, ev_row: Evaluation, model: Model) -> dict[str, Any]:
    from ...metrics.glossary import glossary
    from ...report.colours import GRADIENT, OCCLUDER, UNSEEN
    from ...report.html import viewer_data
    from ...report.overview import OBSERVED_ONLY, VISIBLE

    ev = evaluation_result(state, ev_row)
    scene = evaluation_scene(state.storage, session, model.stored_name, ev_row.settings, ev_row.project_id)
    plan = read_stored_plan(state, ev_row.plan_version)
    data = viewer_data(ev, scene, plan, "visibility", None)
    em, fm, mp = ev.metrics.elements, ev.metrics.frames, ev.metrics.params
    data["metrics"] |= {"frames_observed": em.frames_observed.tolist(),
                        "pixels_total": [_num(v, 1) for v in em.pixels_total]}
    data["frames"] = {"name": plan.frame_names.tolist(), "nu": fm.nu.tolist(), "stable": fm.stable.tolist(),
                      "features_observed": fm.features_observed.tolist(),
                      "elements_visible": fm.elements_visible.tolist(),
                      "pixels_on_targets": [_num(v, 1) for v in fm.pixels_on_targets]}
    # the same colours as sRGB floats (the hex codes are rounded to 8 bits)
    data["colours"] |= {"gradient_rgb": [list(c) for c in GRADIENT], "unseen_rgb": list(UNSEEN),
                        "occluder_rgb": list(OCCLUDER),
                        "classes_rgb": [list(c) for c in (VISIBLE, OBSERVED_ONLY, UNSEEN, OCCLUDER)]}
    data["params"] = {"omega": mp.omega, "k": mp.k, "min_track": mp.min_track, "min_features": mp.min_features}
    data["metric_help"] = glossary(mp)  # the definitions with this evaluation's thresholds
    data["plan_metrics"] = ev_row.metrics
    data["missions"] = [{"name": m.name, "start": m.start, "stop": m.stop} for m in plan.missions]
    data |= {"evaluation_id": ev_row.id, "plan_id": ev_row.plan_version.plan_id,
             "plan_version": ev_row.plan_version.number, "model_id": ev_row.model_id}
    return data


@router.get("/api/projects/{project_id}/evaluations/{evaluation_id}/feedback", response_model=FeedbackOut,
            summary="Everything the viewer colours from: per-element and per-frame values of an evaluation",
            description="Per element (all of the model's, by index): visibility class (0 visible, 1 observed only, "
                        "2 unseen, 3 occluder), VR_i, R_i (SSD, m/px), O_i (°), frames observed, pixels; the metrics' "
                        "labels, default colour bounds and the traffic-light colours of the HTML report. Per frame: "
                        "ν_f and whether it is stable (ν_f ≥ Λ).",
            responses={**NOT_FOUND, **NOT_READY})
def evaluation_feedback(project: ProjectRead, evaluation_id: int, session: SessionDep, state: StateDep
                        ) -> Response:
    ev_row = done_evaluation(session, project.id, evaluation_id)
    model = in_project(session, Model, ev_row.model_id, project.id, "model")
    body = _feedback_cache.get(ev_row.result_dir, lambda: json.dumps(
        feedback_dict(state, session, ev_row, model), allow_nan=False, separators=(",", ":")).encode())
    return Response(body, media_type="application/json")


@router.get("/api/projects/{project_id}/evaluations/{evaluation_id}/elements/{index}", response_model=ElementDetailOut,
            summary="One element's values and the frames that see it best",
            description="The element's row of the per-element metrics (null values for an occluder), then up to "
                        "`limit` frames: first those that see it by ≥ Ω px, finest surface sampling distance first "
                        "(R_i is the mean of the k finest), then those that see fewer pixels, most pixels first.",
            responses={**NOT_FOUND, **NOT_READY})
def evaluation_element(project: ProjectRead, evaluation_id: int, index: int, session: SessionDep, state: StateDep,
                       limit: Annotated[int, Query(ge=1, le=100, description="How many frames")] = 5
                       ) -> ElementDetailOut:
    ev_row = done_evaluation(session, project.id, evaluation_id)
    model = in_project(session, Model, ev_row.model_id, project.id, "model")
    scene = evaluation_scene(state.storage, session, model.stored_name, ev_row.settings, ev_row.project_id)
    if not 0 <= index < scene.n_elements:
        raise HTTPException(404, f"element {index} not found: the model has elements 0 to {scene.n_elements - 1}")
    rows = json.loads((state.storage.evaluation_dir(ev_row.result_dir) / "elements.json").read_text(encoding="utf-8"))
    row = next((r for r in rows if r["index"] == index), None)
    el = scene.elements
    if row is None:
        row = {"index": index, "global_id": el.global_id[index], "name": el.name[index],
               "ifc_class": el.ifc_class[index], "discipline": el.discipline[index], "storey": el.storey[index],
               "visibility": "occluder", "VR_i": None, "R_i_m_per_px": None, "O_i_deg": None,
               "frames_observed": None, "pixels_total": None}
    ev = evaluation_result(state, ev_row)
    obs = ev.observations
    plan = read_stored_plan(state, ev_row.plan_version)
    sel = np.flatnonzero(obs.element == index)
    pixels, ssd = obs.pixels[sel], obs.ssd[sel]
    counted = pixels >= ev.metrics.params.omega
    order = np.lexsort((-pixels, np.where(counted, ssd, np.inf), ~counted))[:limit]
    frames = [{"frame": int(obs.frame[sel[j]]), "name": str(plan.frame_names[obs.frame[sel[j]]]),
               "pixels": round(float(pixels[j]), 1), "ssd_m_per_px": float(ssd[j]),
               "angle_deg": float(obs.angle_mean[sel[j]]), "depth_m": float(obs.depth_mean[sel[j]]),
               "counts": bool(counted[j])} for j in order]
    return ElementDetailOut(evaluation_id=ev_row.id, element=row, target=bool(el.is_target[index]),
                            omega_px=ev.metrics.params.omega, best_frames=frames)


# --------------------------------------------------------------------------- simulated views
def view_png(engine, plan, frame: int, rgb: np.ndarray, width: int, shading: bool) -> tuple[bytes, np.ndarray]:
    """The frame's simulated view at ``width`` px: each pixel in its element's colour (white where nothing is hit),
    darkened at grazing angles when ``shading``. Returns the PNG and the (H, W) element ids."""
    from PIL import Image

    cam = plan.camera_of(frame)
    scale = min(1.0, width / cam.width)
    ids, _, cos = engine.shaded_view(cam, plan.R_world_camera[frame], plan.C_world[frame], scale)
    hit = ids >= 0
    img = np.ones((*ids.shape, 3))
    img[hit] = rgb[ids[hit]] * ((0.4 + 0.6 * cos[hit])[:, None] if shading else 1.0)
    buf = io.BytesIO()
    Image.fromarray(np.round(img * 255).astype(np.uint8)).save(buf, format="PNG", compress_level=1)
    return buf.getvalue(), ids


def _png(data: bytes, ids: np.ndarray) -> Response:
    return Response(data, media_type="image/png",
                    headers={"Cache-Control": "private, max-age=3600",
                             "X-Sightplan-Elements-Seen": str(len(np.unique(ids[ids >= 0])))})


@router.get("/api/projects/{project_id}/evaluations/{evaluation_id}/frames/{frame}/view.png",
            response_class=Response, summary="The simulated view from a frame, coloured by a metric",
            description="The frame's element-id image cast by the engine at a small size, each element in its colour "
                        "for the metric (as the glTF and the HTML report colour it: traffic light between the bounds, "
                        "unseen red, occluders grey), white where nothing is hit.",
            responses={**PNG, **NOT_FOUND, **NOT_READY, **BAD_VALUE})
def evaluation_view(project: ProjectRead, evaluation_id: int, frame: int, session: SessionDep, state: StateDep,
                    metric: Annotated[str, Query(description="visibility, vr, ssd or orientation")] = "visibility",
                    lo: Annotated[float | None, Query(
                               allow_inf_nan=False, description="Bound of the gradient (with hi)")] = None,
                    hi: Annotated[float | None, Query(
                               allow_inf_nan=False, description="Bound of the gradient (with lo)")] = None,
                    width: Annotated[int, Query(ge=16, le=2000, description="Image width (px)")] = VIEW_WIDTH_PX,
                    shading: Annotated[bool, Query(description="Darken surfaces seen at a grazing angle")] = True,
                    ) -> Response:
    from ...report.colours import check_colour_by, metric_colours

    ev_row = done_evaluation(session, project.id, evaluation_id)
    model = in_project(session, Model, ev_row.model_id, project.id, "model")
    colour_by = check_colour_by(metric)
    if (lo is None) != (hi is None):
        raise ReportError("give both bounds lo and hi, or neither")
    ev = evaluation_result(state, ev_row)
    rgb = metric_colours(ev.metrics.elements, colour_by, None if lo is None else (lo, hi))[:, :3]  # type: ignore[arg-type]
    plan = read_stored_plan(state, ev_row.plan_version)
    check_frame(plan, frame)
    data, ids = view_png(view_engine(state, model, ev.settings.d_max, session, ev_row.settings), plan, frame, rgb,
                         width, shading)
    return _png(data, ids)


@router.get("/api/projects/{project_id}/plans/{plan_id}/versions/{number}/frames/{frame}/view.png",
            response_class=Response, summary="The simulated view from a frame of a plan version (not evaluated)",
            description="The frame's element-id image cast against the model: target elements light grey-blue, "
                        "occluders grey, white where nothing is hit; for frames being edited before an evaluation.",
            responses={**PNG, **NOT_FOUND, **NOT_READY, 422: {"model": ErrorOut, "description": "No model given"}})
def plan_view(project: ProjectRead, plan_id: int, number: int, frame: int, session: SessionDep, state: StateDep,
              model_id: Annotated[int | None, Query(description="Default: the plan's model")] = None,
              width: Annotated[int, Query(ge=16, le=2000, description="Image width (px)")] = VIEW_WIDTH_PX,
              ) -> Response:
    from ...engines.base import D_MAX_M
    from ...report.overview import OCCLUDER

    version = plan_version(session, project.id, plan_id, number)
    model_id = model_id if model_id is not None else version.plan.model_id
    if model_id is None:
        raise HTTPException(422, f"plan {plan_id} is for no model: give model_id")
    model = ready_model(session, project.id, model_id)
    plan = read_stored_plan(state, version)
    check_frame(plan, frame)
    engine = view_engine(state, model, D_MAX_M)
    targets = engine.scene.elements.is_target
    rgb = np.where(targets[:, None], np.array(NEUTRAL_TARGET), np.array(OCCLUDER))
    data, ids = view_png(engine, plan, frame, rgb, width, True)
    return _png(data, ids)


# --------------------------------------------------------------------------- the page and its packages
MEDIA_TYPES = {".js": "text/javascript", ".mjs": "text/javascript", ".css": "text/css", ".html": "text/html",
               ".json": "application/json", ".map": "application/json", ".svg": "image/svg+xml", ".png": "image/png",
               ".wasm": "application/wasm"}


def node_modules() -> Path:
    """The npm packages served under /vendor/: a wheel's own copy, else the checkout's web/node_modules."""
    from ...assets import vendor_root

    return vendor_root()


def safe_file(root: Path, relative: str) -> Path:
    """``root/relative`` if it is a file inside ``root`` (after resolving links and ``..``), else 404."""
    root = root.resolve()
    if not relative or "\\" in relative or "\0" in relative:
        raise HTTPException(404, "file not found")
    target = (root / relative).resolve()
    if not target.is_relative_to(root) or not target.is_file():
        raise HTTPException(404, "file not found")
    return target


def _file(path: Path, cache: str) -> FileResponse:
    media = MEDIA_TYPES.get(path.suffix.lower()) or mimetypes.guess_type(path.name)[0] or "application/octet-stream"
    return FileResponse(path, media_type=media, headers={"Cache-Control": cache})


@router.get("/", response_class=FileResponse, include_in_schema=False)
def index_page() -> FileResponse:
    return _file(STATIC_DIR / "index.html", "no-cache")


@router.get("/shared/{token}", response_class=FileResponse, include_in_schema=False)
def shared_page(token: str) -> FileResponse:
    """A share link opened in a browser: the page, which reads the plan from /api/shared/{token} (read-only)."""
    return _file(STATIC_DIR / "index.html", "no-cache")


@router.get("/favicon.ico", response_class=FileResponse, include_in_schema=False)
def favicon() -> FileResponse:
    """The page's icon, for browsers that ask for it at the root whatever the page says."""
    return _file(STATIC_DIR / "favicon.svg", "public, max-age=86400")


@router.get("/docs", response_class=FileResponse, include_in_schema=False)
def api_docs() -> FileResponse:
    """The OpenAPI documentation (Swagger UI from web/node_modules: no network needed)."""
    return _file(STATIC_DIR / "docs.html", "no-cache")


@router.get("/static/{path:path}", response_class=FileResponse, include_in_schema=False)
def static_file(path: str) -> FileResponse:
    if path == COLOURS_JS.name:  # the colouring the HTML report's viewer uses too
        return _file(COLOURS_JS, "no-cache")
    return _file(safe_file(STATIC_DIR, path), "no-cache")


@router.get("/vendor/{package}/{path:path}", response_class=FileResponse, include_in_schema=False)
def vendor_file(package: str, path: str) -> FileResponse:
    if package not in VENDOR_PACKAGES:
        raise HTTPException(404, f"package {package!r} is not served; the page uses {', '.join(VENDOR_PACKAGES)}")
    root = node_modules() / package
    if not root.is_dir():
        raise HTTPException(503, f"{package} is not installed ({root} is missing); run `make setup`, which runs "
                                 "`npm ci --prefix web`")
    return _file(safe_file(root, path), "public, max-age=86400")
