"""``/api/shared/{token}``: a plan shared read-only by a link: no login, nothing can be changed, and a revoked link
answers 404 like one that never existed."""

from __future__ import annotations

from typing import Annotated, Any

from fastapi import APIRouter, BackgroundTasks, HTTPException, Query
from fastapi.responses import FileResponse
from sqlalchemy import select
from sqlalchemy.orm import Session

from ...formats.registry import ExportFormat, export_choices
from ...plan.domain import MAX_SPEED_M_S
from ..auth import digest
from ..deps import SessionDep, StateDep
from ..models import Evaluation, Model, Plan, PlanVersion, ShareLink
from ..schemas import ErrorOut, EvaluationOut, PlanFileOut, SharedPlanOut
from . import evaluations, plans

router = APIRouter(prefix="/api/shared/{token}", tags=["members and sharing"])
NOT_FOUND = {404: {"model": ErrorOut, "description": "No such link (or revoked), version or evaluation"}}


def shared_plan(session: Session, token: str) -> Plan:
    link = session.scalars(select(ShareLink).where(ShareLink.digest == digest(token))).first()
    plan = session.get(Plan, link.plan_id) if link is not None and link.revoked_at is None else None
    if plan is None:
        raise HTTPException(404, "this share link does not exist or was revoked")
    return plan


def _evaluation(session: Session, plan: Plan, evaluation_id: int) -> Evaluation:
    ev = session.get(Evaluation, evaluation_id)
    if ev is None or ev.plan_version.plan_id != plan.id:
        raise HTTPException(404, f"evaluation {evaluation_id} is not one of the shared plan's")
    return ev


@router.get("", response_model=SharedPlanOut, summary="The shared plan, its versions and evaluations",
            responses=NOT_FOUND)
def read_shared(token: str, session: SessionDep) -> SharedPlanOut:
    plan = shared_plan(session, token)
    rows = session.scalars(select(Evaluation).join(PlanVersion, Evaluation.plan_version_id == PlanVersion.id)
                           .where(PlanVersion.plan_id == plan.id).order_by(Evaluation.id))
    model = session.get(Model, plan.model_id) if plan.model_id is not None else None
    return SharedPlanOut(plan=plans.plan_out(plan), evaluations=[evaluations.evaluation_out(e) for e in rows],
                         model=model)


@router.get("/versions/{number}", response_model=PlanFileOut, response_model_exclude_unset=True,
            summary="A version's plan JSON", responses=NOT_FOUND)
def read_shared_version(token: str, number: int, session: SessionDep, state: StateDep) -> dict[str, Any]:
    plan = shared_plan(session, token)
    return plans.read_version(plan.project_id, plan.id, number, session, state)


@router.get("/versions/{number}/export", response_class=FileResponse, summary="Export a version for a flight app",
            responses={**plans.EXPORTED, **NOT_FOUND})
def export_shared_version(token: str, number: int, session: SessionDep, state: StateDep, background: BackgroundTasks,
                          format: Annotated[ExportFormat, Query(description=export_choices())],
                          speed: Annotated[float, Query(gt=0, le=MAX_SPEED_M_S, allow_inf_nan=False,
                                                        description="Flight speed (m/s)")] = 5.0,
                          mission: Annotated[int | None, Query(ge=1, description="Only this mission (from 1)")] = None,
                          force: Annotated[bool, Query(description="Export a plan that fails its flight checks")] = False,
                          aircraft: Annotated[str | None, Query(max_length=40, description="wpml: the DJI aircraft "
                                                                "(m3e, m350-h20, m350-p1, m300-h20, m300-p1)")] = None,
                          ) -> FileResponse:
    plan = shared_plan(session, token)
    return plans.export_version(plan.project_id, plan.id, number, session, state, background, format=format,
                                model_id=None, speed=speed, mission=mission, autopilot=None, force=force,
                                aircraft=aircraft)


@router.get("/evaluations/{evaluation_id}", response_model=EvaluationOut, summary="An evaluation of the shared plan",
            responses=NOT_FOUND)
def read_shared_evaluation(token: str, evaluation_id: int, session: SessionDep) -> EvaluationOut:
    return evaluations.evaluation_out(_evaluation(session, shared_plan(session, token), evaluation_id))


@router.get("/evaluations/{evaluation_id}/report.html", response_class=FileResponse,
            summary="The HTML report of an evaluation of the shared plan",
            responses={200: {"description": "One HTML page", "content": {"text/html": {}}}, **NOT_FOUND,
                       **evaluations.NOT_DONE, 503: {"model": ErrorOut, "description": "The 3D viewer's files are "
                                                     "not installed on the server"}})
def read_shared_report(token: str, evaluation_id: int, session: SessionDep, state: StateDep) -> FileResponse:
    plan = shared_plan(session, token)
    ev = _evaluation(session, plan, evaluation_id)
    return evaluations.read_html_report(plan.project_id, ev.id, session, state)
