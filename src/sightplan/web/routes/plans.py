"""``/api/projects/{project_id}/plans``: from a template or an uploaded file; versions; edits; exports."""

from __future__ import annotations

import json
import logging
import re
import zipfile
from pathlib import Path
from typing import Annotated, Any, Literal

from fastapi import APIRouter, BackgroundTasks, Body, File, Form, HTTPException, Query, Response, UploadFile
from fastapi.responses import FileResponse
from sqlalchemy import select
from sqlalchemy.orm import Session
from starlette.concurrency import run_in_threadpool

from ...errors import PlanError, SightplanError
from ...formats.registry import FORMATS, WRITERS, ExportFormat, export_choices
from ...model.scene import Scene
from ...plan.domain import MAX_SPEED_M_S
from ...plan.templates.registry import TEMPLATES
from ...plan.types import Plan as PlanData
from ..deps import PROJECT_ACCESS, ServerState, SessionDep, StateDep, in_project, ready_model
from ..errors import MAX_ID, FlightChecksFailed
from ..models import Job, Model, Plan, PlanVersion
from ..schemas import ErrorOut, JobOut, OptimizeIn, PlanFileOut, PlanOut, PlanVersionOut, TemplatePlanIn
from ..services import (
    add_plan_version,
    checked_plan_json,
    flight_record,
    ground_stations,
    load_scene,
    read_uploaded_plan,
    template_plan,
)
from ..storage import PLAN_SUFFIXES, display_name
from ..uploads import receive_upload

log = logging.getLogger("sightplan.web")
FLIGHT_CHECKS_HEADER = "X-Sightplan-Flight-Violations"  # an export's flight-check violations: a 409's, a forced file's

router = APIRouter(prefix="/api/projects/{project_id}/plans", tags=["plans"], dependencies=PROJECT_ACCESS)
NOT_FOUND = {404: {"model": ErrorOut, "description": "No such project, plan, version or model"}}
BAD_PLAN = {422: {"model": ErrorOut, "description": "The plan or a parameter is invalid (the library's message)"}}
NOT_READY = {409: {"model": ErrorOut, "description": "The model is not loaded (yet)"}}
MEDIA = {**{f.suffix: f.media_type for f in WRITERS}, ".zip": "application/zip"}
EXPORTED = {200: {"description": "The exported file", "content": {m: {} for m in sorted(set(MEDIA.values()))}},
            409: {"model": ErrorOut, "description": "The model is not loaded (yet), or the plan fails its flight checks "
                                                   "(named in `violations`; force=true exports it anyway)"},
            422: {"model": ErrorOut, "description": "No georeference, or a frame a drone cannot take"}}


def plan_out(plan: Plan) -> PlanOut:
    return PlanOut(id=plan.id, project_id=plan.project_id, model_id=plan.model_id, name=plan.name, source=plan.source,
                   created_at=plan.created_at, latest_version=max((v.number for v in plan.versions), default=0),
                   versions=[PlanVersionOut.model_validate(v) for v in plan.versions])


def ready_scene(state: ServerState, session: Session, project_id: int, model_id: int) -> tuple[Model, Scene]:
    model = ready_model(session, project_id, model_id)
    return model, load_scene(state.storage, model.stored_name)[0]


def near_its_model(state: ServerState, session: Session, model_id: int | None, data: PlanData,
                   scene: Scene | None = None) -> None:
    """A plan whose model is loaded lies within reach of it (``SIGHTPLAN_MAX_REACH_M``): one frame kilometres away
    is a typo that every check, export and view of the plan would carry."""
    from ...plan.domain import check_plan_near_model

    if scene is None and model_id is not None:
        model = session.get(Model, model_id)
        if model is not None and model.status == "ready":
            scene = load_scene(state.storage, model.stored_name)[0]
    if scene is not None:
        check_plan_near_model(data, *scene.bounds())


def commit_version(state: ServerState, session: Session, plan_row: Plan, data: PlanData, note: str) -> PlanOut:
    """Write ``data`` as the plan's next version (file and row) and commit; on any failure neither is left."""
    path = None
    try:
        path = add_plan_version(state.storage, session, plan_row, data, note)
        session.commit()
    except BaseException:
        session.rollback()
        if path is not None:
            path.unlink(missing_ok=True)
        raise
    session.refresh(plan_row)
    return plan_out(plan_row)


@router.post("", response_model=PlanOut, status_code=201, summary="Create a plan from a template",
             description=f"{', '.join(TEMPLATES)} around one of the project's models, split into missions and "
                         "checked as `sightplan plan` does; the model's georeference is recorded for exports.",
             responses={**NOT_FOUND, **BAD_PLAN, **NOT_READY})
def create_from_template(project_id: int, body: TemplatePlanIn, session: SessionDep, state: StateDep) -> PlanOut:
    _, scene = ready_scene(state, session, project_id, body.model_id)
    data = template_plan(scene, body)
    near_its_model(state, session, body.model_id, data, scene)
    row = Plan(project_id=project_id, model_id=body.model_id, name=body.name or f"{body.template} plan",
               source=f"template {body.template} ({body.camera})")
    return commit_version(state, session, row, data, f"{body.template} template")


@router.post("/optimize", response_model=JobOut, status_code=202, summary="Optimise a plan (background job)",
             description="The fewest views that give every target element k serving views within the budget, routed "
                         "and checked, as `sightplan optimize` does; the job makes a new plan (its `plan_id` once "
                         "done). Candidates go through the per-frame cache, so a second run with other targets is "
                         "quick.", responses={**NOT_FOUND, **BAD_PLAN, **NOT_READY})
def create_optimised(project_id: int, body: OptimizeIn, session: SessionDep, state: StateDep) -> JobOut:
    from ...camera.catalogue import get_camera
    from ...camera.models import PinholeCamera

    model = ready_model(session, project_id, body.model_id)
    if not isinstance(get_camera(body.camera), PinholeCamera):
        raise PlanError("optimised plans need a perspective (pinhole) camera")
    flight = flight_record(body)  # an unknown aircraft is refused before the job
    params = body.model_dump() | {"flight": flight}
    if body.ground_station_geo:  # placed now: a point off the site is refused before the job
        scene = ready_scene(state, session, project_id, body.model_id)[1]
        params |= {"ground_station": ground_stations(scene, body.ground_station, body.ground_station_geo),
                   "ground_station_geo": []}
    job = Job(project_id=project_id, kind="optimize", model_id=model.id, params=params, message="queued",
              progress_total=1.0)
    session.add(job)
    session.commit()
    state.worker.submit(job.id)
    return JobOut.model_validate(job)


@router.post("/upload", response_model=PlanOut, status_code=201, summary="Upload a plan file",
             description="Any format the library reads: sightplan JSON, OpenSfM reconstruction.json, poses CSV, "
                         "QGroundControl .plan, QGC WPL 110 .waypoints, DJI WPML .kmz. Flight-app missions are placed "
                         "with the georeference of the model given.",
             responses={**NOT_FOUND, **BAD_PLAN, **NOT_READY, 400: {"model": ErrorOut, "description": "Empty file"},
                        413: {"model": ErrorOut, "description": "Over the upload limit"},
                        415: {"model": ErrorOut, "description": "Not a plan file extension"}})
async def upload_plan(project_id: int, session: SessionDep, state: StateDep,
                      file: Annotated[UploadFile, File(description="The plan file")],
                      name: Annotated[str, Form(max_length=200, description="Default: the file's name")] = "",
                      model_id: Annotated[int | None, Form(ge=-MAX_ID - 1, le=MAX_ID,
                                                            description="The project's model the plan is for")] = None,
                      camera: Annotated[str | None, Form(description="Camera of a poses CSV or a flight-app mission")]
                      = None) -> PlanOut:
    if model_id is not None:
        in_project(session, Model, model_id, project_id, "model")
    original = display_name(file.filename or "")
    tmp, _ = await receive_upload(state, file, PLAN_SUFFIXES, "plan")

    def store() -> PlanOut:  # parsing and writing, off the event loop
        try:
            scene = ready_scene(state, session, project_id, model_id)[1] if model_id is not None else None
            data = read_uploaded_plan(tmp, camera, scene)
            near_its_model(state, session, model_id, data, scene)
        except SightplanError as exc:
            raise PlanError(str(exc).replace(str(tmp), original).replace(tmp.name, original)) from None
        finally:
            tmp.unlink(missing_ok=True)
        row = Plan(project_id=project_id, model_id=model_id, name=name or original, source=f"upload {original}")
        return commit_version(state, session, row, data, f"uploaded {original}")

    return await run_in_threadpool(store)


@router.get("", response_model=list[PlanOut], summary="List the project's plans", responses=NOT_FOUND)
def list_plans(project_id: int, session: SessionDep) -> list[PlanOut]:
    return [plan_out(p) for p in session.scalars(select(Plan).where(Plan.project_id == project_id).order_by(Plan.id))]


@router.get("/{plan_id}", response_model=PlanOut, summary="Get a plan with its versions", responses=NOT_FOUND)
def read_plan_row(project_id: int, plan_id: int, session: SessionDep) -> PlanOut:
    return plan_out(in_project(session, Plan, plan_id, project_id, "plan"))


def get_version(session: Session, project_id: int, plan_id: int, number: int) -> PlanVersion:
    plan = in_project(session, Plan, plan_id, project_id, "plan")
    for v in plan.versions:
        if v.number == number:
            return v
    raise HTTPException(404, f"plan {plan_id} has no version {number} (it has 1 to {len(plan.versions)})")


@router.get("/{plan_id}/versions/{number}", response_model=PlanFileOut, response_model_exclude_unset=True,
            summary="Get a version's plan JSON (sightplan plan format, version 1)", responses=NOT_FOUND)
def read_version(project_id: int, plan_id: int, number: int, session: SessionDep, state: StateDep) -> dict[str, Any]:
    version = get_version(session, project_id, plan_id, number)
    return json.loads(state.storage.plan_path(version.stored_name).read_text(encoding="utf-8"))


@router.put("/{plan_id}", response_model=PlanOut, status_code=201, summary="Save an edited plan as a new version",
            description="The body is a whole sightplan plan JSON (frames moved, deleted or inserted), validated as a "
                        "plan file is read. Earlier versions stay as they were.",
            responses={**NOT_FOUND, **BAD_PLAN})
def put_version(project_id: int, plan_id: int, session: SessionDep, state: StateDep,
                body: Annotated[dict[str, Any], Body(description="The edited plan JSON")],
                note: Annotated[str, Query(max_length=500, description="What changed")] = "edited") -> PlanOut:
    plan = in_project(session, Plan, plan_id, project_id, "plan")
    data = checked_plan_json(body)
    near_its_model(state, session, plan.model_id, data)
    return commit_version(state, session, plan, data, note)


@router.delete("/{plan_id}", status_code=204, response_class=Response,
               summary="Delete a plan, its versions and their evaluations",
               responses={**NOT_FOUND, 409: {"model": ErrorOut, "description": "An evaluation of it is running"}})
def delete_plan(project_id: int, plan_id: int, session: SessionDep, state: StateDep) -> Response:
    from ..models import Evaluation

    plan = in_project(session, Plan, plan_id, project_id, "plan")
    version_ids = [v.id for v in plan.versions]
    evaluations = list(session.scalars(select(Evaluation).where(Evaluation.plan_version_id.in_(version_ids))))
    busy = session.scalars(select(Job).where(Job.status.in_(("queued", "running")),
                                             Job.evaluation_id.in_([e.id for e in evaluations]))).first()
    if busy is not None:
        raise HTTPException(409, f"job {busy.id} is still evaluating plan {plan_id}; delete it when it is done")
    files = [state.storage.plan_path(v.stored_name) for v in plan.versions]
    files += [state.storage.evaluation_dir(e.result_dir) for e in evaluations]
    session.delete(plan)
    session.commit()
    state.storage.remove(*files)
    return Response(status_code=204)


def _slug(text: str) -> str:
    """A file name from a plan name: letters of any script kept (the download names them with RFC 5987's
    ``filename*``), every run of anything else one underscore."""
    return re.sub(r"[^\w.-]+", "_", text).strip("._")[:100] or "plan"


@router.get("/{plan_id}/versions/{number}/export", response_class=FileResponse,
            summary="Export a plan version for a flight app or a map (a download)",
            description="Placed with the plan's georeference, else the model's (IfcMapConversion or IfcSite), as "
                        "`sightplan export` does; several files (a QGC plan per mission, Litchi parts) come as a zip.",
            responses={**EXPORTED, **NOT_FOUND})
def export_version(project_id: int, plan_id: int, number: int, session: SessionDep, state: StateDep,
                   background: BackgroundTasks,
                   format: Annotated[ExportFormat, Query(description=export_choices())],
                   model_id: Annotated[int | None, Query(description="Model whose georeference places the plan "
                                                                     "(default: the plan's model)")] = None,
                   speed: Annotated[float, Query(gt=0, le=MAX_SPEED_M_S, allow_inf_nan=False,
                                                 description="Flight speed (m/s)")] = 5.0,
                   mission: Annotated[int | None, Query(ge=1, description="Only this mission (from 1)")] = None,
                   autopilot: Annotated[Literal["px4", "ardupilot"] | None, Query(
                       description="qgc and wpl: the flight controller the file is for (default px4 for qgc, "
                                   "ardupilot for wpl)")] = None,
                   aircraft: Annotated[str | None, Query(
                       max_length=40, description="wpml: the DJI aircraft the file is for (m3e, m350-h20, m350-p1, "
                                                  "m300-h20, m300-p1; default: the one carrying the plan's camera)")] = None,
                   force: Annotated[bool, Query(description="Export a plan that fails its flight checks")] = False,
                   ) -> FileResponse:
    from ...export.files import export_files, takeoff_point
    from ...geo import Georeference, GeoreferenceError, resolve_georeference
    from ...plan.format import read_plan

    version = get_version(session, project_id, plan_id, number)
    plan_row = version.plan
    data = read_plan(state.storage.plan_path(version.stored_name))
    model_id = model_id if model_id is not None else plan_row.model_id
    scene = ready_scene(state, session, project_id, model_id)[1] if model_id is not None else None
    model_geo = Georeference.from_scene_metadata(scene.metadata) if scene is not None else None
    if data.parameters.get("georeference") is None and model_geo is None:
        where = (f"model {model_id} has no IfcMapConversion and its IfcSite no RefLatitude/RefLongitude"
                 if scene is not None else "no model is given (model_id)")
        raise GeoreferenceError(f"a {format} export needs a georeference and none was found: plan {plan_id} records "
                                f"none and {where}. Georeference the IFC, or upload a plan that records one")
    geo = resolve_georeference(data.parameters.get("georeference"), model_geo, what=f"a {format} export")
    takeoff = takeoff_point(data, scene, hint="give model_id to take the south-west corner of its region")
    from ...plan.checks.gate import export_violations

    failed = export_violations(data, takeoff, scene)
    if failed and not force:
        raise FlightChecksFailed(f"the plan fails its flight checks ({len(failed)} violation(s)): "
                                 f"{'; '.join(failed[:20])}{' …' if len(failed) > 20 else ''}. "
                                 "Fix the plan, or export it anyway with force=true", list(failed),
                                 headers={FLIGHT_CHECKS_HEADER: str(len(failed))})
    for v in failed:  # as the CLI's warnings: who exported what despite which violation
        log.warning("plan %s version %s exported as %s despite its flight checks: %s", plan_id, number, format, v)
    folder = state.storage.temp_path()
    folder.mkdir()
    background.add_task(state.storage.remove, folder)
    stem = f"{_slug(plan_row.name)}_v{number}"
    from ...export import ReplayRefusal

    try:
        spec = FORMATS[format]
        paths = export_files(data, format, folder / (stem + spec.suffix), geo, takeoff, speed_m_s=speed,
                             mission=mission, autopilot=autopilot, aircraft=aircraft if spec.aircraft_choice else None,
                             faithful=not force)
    except ReplayRefusal as exc:  # the replay's verdict, which the page can override like the checks'
        state.storage.remove(folder)
        raise FlightChecksFailed(str(exc), [str(exc)],
                                 headers={FLIGHT_CHECKS_HEADER: "1"}) from None
    except BaseException:
        state.storage.remove(folder)
        raise
    if len(paths) == 1:
        path = Path(paths[0])
    else:
        path = folder / f"{stem}_{format}.zip"
        with zipfile.ZipFile(path, "w", zipfile.ZIP_DEFLATED) as zf:
            for p in paths:
                zf.write(p, Path(p).name)
    return FileResponse(path, media_type=MEDIA.get(path.suffix, "application/octet-stream"), filename=path.name,
                        headers={FLIGHT_CHECKS_HEADER: str(len(failed))} if failed else None)
