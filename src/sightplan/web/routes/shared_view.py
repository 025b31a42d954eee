"""What the page's share view reads, under ``/api/shared/{token}``: the shared plan's model (its record, geometry,
element table and site), its versions (geometry, flight checks, exports, simulated views) and its evaluations (list,
feedback, element details, views), at the same paths below the token as below ``/api/projects/{id}``, so that the page
reads a shared plan as it reads a project's. Every id must be the shared plan's own (or its model's, or one of its
evaluations'); anything else answers 404 as a revoked link does."""

from __future__ import annotations

from typing import Annotated, Literal

from fastapi import APIRouter, BackgroundTasks, HTTPException, Query, Request, Response
from fastapi.responses import FileResponse
from sqlalchemy import select
from sqlalchemy.orm import Session

from ...formats.registry import ExportFormat, export_choices
from ...plan.domain import MAX_SPEED_M_S
from ..basemap import read_info
from ..deps import SessionDep, StateDep
from ..models import Evaluation, Model, Plan, PlanVersion, Project
from ..schemas import (
    ElementDetailOut,
    ElementTableOut,
    ErrorOut,
    EvaluationOut,
    FeedbackOut,
    FlightChecksOut,
    ModelDetailOut,
    PlanFileOut,
    PlanGeometryOut,
    ProjectBackgroundOut,
    SiteOut,
)
from . import evaluations, models, plans, site, viewer
from .shared import _evaluation, shared_plan

router = APIRouter(prefix="/api/shared/{token}", tags=["members and sharing"])
NOT_FOUND = {404: {"model": ErrorOut, "description": "No such link (or revoked), or an id that is not the shared plan's"}}
READ = {**NOT_FOUND, **viewer.NOT_READY, **viewer.BAD_VALUE}  # what the project's own reads answer besides
PNG = {200: {"description": "A PNG image", "content": {"image/png": {}}}}


def _shared(session: Session, token: str) -> tuple[Project, Plan]:
    plan = shared_plan(session, token)
    return session.get(Project, plan.project_id), plan


def _model(session: Session, token: str, model_id: int) -> Project:
    project, plan = _shared(session, token)
    if model_id != plan.model_id:
        raise HTTPException(404, f"model {model_id} is not the shared plan's")
    return project


def _plan(session: Session, token: str, plan_id: int) -> Project:
    project, plan = _shared(session, token)
    if plan_id != plan.id:
        raise HTTPException(404, f"plan {plan_id} is not the shared plan")
    return project


def _evaluation_of(session: Session, token: str, evaluation_id: int) -> Project:
    project, plan = _shared(session, token)
    _evaluation(session, plan, evaluation_id)
    return project


@router.get("/models/{model_id}", response_model=ModelDetailOut, summary="The shared plan's model, with its load report",
            responses=READ)
def shared_model(token: str, model_id: int, session: SessionDep) -> Model:
    return models.read_model(_model(session, token, model_id).id, model_id, session)


@router.get("/models/{model_id}/geometry", summary="The shared plan's model as the viewer's binary geometry",
            response_class=Response, responses=READ)
def shared_model_geometry(token: str, model_id: int, request: Request, session: SessionDep, state: StateDep) -> Response:
    return viewer.model_geometry(_model(session, token, model_id), model_id, request, session, state)


@router.get("/models/{model_id}/elements", response_model=ElementTableOut, summary="The shared plan's model's elements",
            responses=READ)
def shared_model_elements(token: str, model_id: int, session: SessionDep, state: StateDep) -> ElementTableOut:
    return viewer.model_elements(_model(session, token, model_id), model_id, session, state)


@router.get("/models/{model_id}/site", response_model=SiteOut, summary="Where the shared plan's model stands",
            responses=READ)
def shared_model_site(token: str, model_id: int, session: SessionDep, state: StateDep) -> SiteOut:
    return site.model_site(_model(session, token, model_id), model_id, session, state)


@router.get("/plans/{plan_id}/versions/{number}", response_model=PlanFileOut, response_model_exclude_unset=True,
            summary="A version of the shared plan (plan JSON)", responses=READ)
def shared_version(token: str, plan_id: int, number: int, session: SessionDep, state: StateDep) -> dict:
    return plans.read_version(_plan(session, token, plan_id).id, plan_id, number, session, state)


@router.get("/plans/{plan_id}/versions/{number}/geometry", response_model=PlanGeometryOut,
            summary="A version of the shared plan for the 3D view", responses=READ)
def shared_version_geometry(token: str, plan_id: int, number: int, session: SessionDep, state: StateDep
                            ) -> PlanGeometryOut:
    return viewer.plan_geometry(_plan(session, token, plan_id), plan_id, number, session, state)


@router.get("/plans/{plan_id}/versions/{number}/checks", response_model=FlightChecksOut,
            summary="The flight checks of a version of the shared plan, against its model", responses=READ)
def shared_version_checks(token: str, plan_id: int, number: int, session: SessionDep, state: StateDep,
                          model_id: Annotated[int | None, Query(description="The plan's model (the only one)")] = None,
                          ) -> FlightChecksOut:
    project = _plan(session, token, plan_id)
    if model_id is not None:
        _model(session, token, model_id)
    return viewer.plan_checks(project, plan_id, number, session, state, model_id, None, None)


@router.get("/plans/{plan_id}/versions/{number}/export", response_class=FileResponse,
            summary="Export a version of the shared plan for a flight app",
            responses={**plans.EXPORTED, **NOT_FOUND})
def shared_version_export(token: str, plan_id: int, number: int, session: SessionDep, state: StateDep,
                          background: BackgroundTasks,
                          format: Annotated[ExportFormat, Query(description=export_choices())],
                          speed: Annotated[float, Query(gt=0, le=MAX_SPEED_M_S, allow_inf_nan=False,
                                                        description="Flight speed (m/s)")] = 5.0,
                          mission: Annotated[int | None, Query(ge=1, description="Only this mission (from 1)")] = None,
                          autopilot: Annotated[Literal["px4", "ardupilot"] | None, Query(
                              description="qgc and wpl: the flight controller the file is for")] = None,
                          aircraft: Annotated[str | None, Query(max_length=40, description="wpml: the DJI aircraft")]
                          = None,
                          force: Annotated[bool, Query(description="Export a plan that fails its flight checks")]
                          = False) -> FileResponse:
    project = _plan(session, token, plan_id)
    return plans.export_version(project.id, plan_id, number, session, state, background, format=format, model_id=None,
                                speed=speed, mission=mission, autopilot=autopilot, force=force, aircraft=aircraft)


@router.get("/plans/{plan_id}/versions/{number}/frames/{frame}/view.png", response_class=Response,
            summary="A frame's simulated view (shared plan)", responses={**PNG, **READ})
def shared_plan_view(token: str, plan_id: int, number: int, frame: int, session: SessionDep, state: StateDep,
                     width: Annotated[int, Query(ge=16, le=2000, description="Image width (px)")] = viewer.VIEW_WIDTH_PX,
                     ) -> Response:
    return viewer.plan_view(_plan(session, token, plan_id), plan_id, number, frame, session, state, None, width)


@router.get("/evaluations", response_model=list[EvaluationOut], summary="The shared plan's evaluations",
            responses=NOT_FOUND)
def shared_evaluations(token: str, session: SessionDep) -> list[EvaluationOut]:
    _, plan = _shared(session, token)
    rows = session.scalars(select(Evaluation).join(PlanVersion, Evaluation.plan_version_id == PlanVersion.id)
                           .where(PlanVersion.plan_id == plan.id).order_by(Evaluation.id))
    return [evaluations.evaluation_out(e) for e in rows]


@router.get("/evaluations/{evaluation_id}/feedback", response_model=FeedbackOut,
            summary="Per-element and per-frame feedback of an evaluation of the shared plan", responses=READ)
def shared_feedback(token: str, evaluation_id: int, session: SessionDep, state: StateDep) -> Response:
    return viewer.evaluation_feedback(_evaluation_of(session, token, evaluation_id), evaluation_id, session, state)


@router.get("/evaluations/{evaluation_id}/elements/{index}", response_model=ElementDetailOut,
            summary="One element's values in an evaluation of the shared plan", responses=READ)
def shared_element(token: str, evaluation_id: int, index: int, session: SessionDep, state: StateDep,
                   limit: Annotated[int, Query(ge=1, le=100, description="How many frames")] = 5) -> ElementDetailOut:
    return viewer.evaluation_element(_evaluation_of(session, token, evaluation_id), evaluation_id, index, session,
                                     state, limit)


@router.get("/evaluations/{evaluation_id}/frames/{frame}/view.png", response_class=Response,
            summary="A frame's view coloured by a metric (shared plan)", responses={**PNG, **READ})
def shared_evaluation_view(token: str, evaluation_id: int, frame: int, session: SessionDep, state: StateDep,
                           metric: Annotated[str, Query(description="visibility, vr, ssd or orientation")]
                           = "visibility",
                           lo: Annotated[float | None, Query(
                               allow_inf_nan=False, description="Bound of the gradient (with hi)")] = None,
                           hi: Annotated[float | None, Query(
                               allow_inf_nan=False, description="Bound of the gradient (with lo)")] = None,
                           width: Annotated[int, Query(ge=16, le=2000, description="Image width (px)")]
                           = viewer.VIEW_WIDTH_PX,
                           shading: Annotated[bool, Query(description="Darken surfaces seen at a grazing angle")]
                           = True) -> Response:
    return viewer.evaluation_view(_evaluation_of(session, token, evaluation_id), evaluation_id, frame, session, state,
                                  metric, lo, hi, width, shading)


@router.get("/basemap", response_model=ProjectBackgroundOut,
            summary="The shared plan's project's map background; null when it has none", responses=NOT_FOUND)
def shared_basemap(token: str, session: SessionDep, state: StateDep) -> ProjectBackgroundOut:
    project, _ = _shared(session, token)
    info = read_info(site.basemap_folder(state, project.id))
    return ProjectBackgroundOut(basemap=None if info is None else site.basemap_out(info, f"/api/shared/{token}"))


@router.get("/basemap/image.png", response_class=FileResponse, summary="The project's orthomosaic (shared plan)",
            responses={**PNG, **READ})
def shared_basemap_image(token: str, session: SessionDep, state: StateDep) -> FileResponse:
    return site.basemap_image(state, _shared(session, token)[0].id)


@router.get("/basemap/tiles/{z}/{x}/{y}", response_class=Response, summary="One tile of the project's MBTiles "
            "(shared plan)", responses={**site.TILE, **READ})
def shared_basemap_tile(token: str, z: int, x: int, y: int, session: SessionDep, state: StateDep) -> Response:
    return site.basemap_tile(state, _shared(session, token)[0].id, z, x, y)
