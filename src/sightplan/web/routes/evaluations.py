"""``/api/projects/{project_id}/evaluations``: start (run by the worker), get, per-element metrics, HTML report."""

from __future__ import annotations

import json
import os
from pathlib import Path

from fastapi import APIRouter, HTTPException, Response
from fastapi.responses import FileResponse
from sqlalchemy import select
from sqlalchemy.orm import Session

from ...errors import ReportError
from ..deps import PROJECT_ACCESS, ServerState, SessionDep, StateDep, in_project, ready_model
from ..models import Evaluation, Job, Model, Plan, PlanVersion, Reality, Schedule
from ..scenes import evaluation_scene
from ..schemas import ElementsOut, ErrorOut, EvaluationIn, EvaluationOut, EvaluationStartOut, JobOut
from ..services import AS_FLOWN_KEY, FOURD_KEY, REALITY_KEY, ROBUSTNESS_KEY, evaluation_settings, rebuilt_evaluation

DEFAULT_DRAWS = 32  # draws under a position error when the request names none

router = APIRouter(prefix="/api/projects/{project_id}/evaluations", tags=["evaluations"], dependencies=PROJECT_ACCESS)
NOT_FOUND = {404: {"model": ErrorOut, "description": "No such project, evaluation, plan, version or model"}}
NOT_DONE = {409: {"model": ErrorOut, "description": "The evaluation is not done (yet)"}}


def queue_evaluation(state: ServerState, session: Session, version: PlanVersion, model_id: int,
                     settings: dict) -> tuple[Evaluation, Job]:
    """Record an evaluation of ``version`` against model ``model_id`` and submit its job to the worker."""
    project_id = version.plan.project_id
    ev = Evaluation(project_id=project_id, plan_version_id=version.id, model_id=model_id, settings=settings,
                    result_dir=state.storage.new_name(), progress_total=version.frames)
    session.add(ev)
    session.flush()
    job = Job(project_id=project_id, kind="evaluate", evaluation_id=ev.id, model_id=model_id, message="queued",
              progress_total=float(version.frames))
    session.add(job)
    session.commit()
    state.worker.submit(job.id)
    return ev, job


def capture_date(session: Session, project_id: int, model_id: int, body: EvaluationIn) -> dict:
    """The 4D settings of an evaluation at ``body.date``, checked now rather than in the worker."""
    from ...model.dates import parse_day

    day = str(parse_day(body.date))
    if body.schedule_id is None:
        row = session.scalars(select(Schedule).where(Schedule.model_id == model_id, Schedule.status == "ready")
                              .order_by(Schedule.id.desc())).first()
        if row is None:
            raise HTTPException(422, f"a capture date needs a schedule: model {model_id} has none linked (POST "
                                     f"/api/projects/{project_id}/schedules)")
    else:
        row = in_project(session, Schedule, body.schedule_id, project_id, "schedule")
        if row.model_id != model_id:
            raise HTTPException(422, f"schedule {row.id} is for model {row.model_id}, not model {model_id}")
        if row.status != "ready":
            raise HTTPException(409, f"schedule {row.id} is {row.status}, not ready")
    return {"date": day, "schedule_id": row.id, "basis": body.date_basis, "unscheduled": body.unscheduled}


def evaluation_out(ev: Evaluation) -> EvaluationOut:
    return EvaluationOut(id=ev.id, project_id=ev.project_id, plan_id=ev.plan_version.plan_id,
                         plan_version=ev.plan_version.number, model_id=ev.model_id, status=ev.status,  # type: ignore[arg-type]
                         progress_done=ev.progress_done, progress_total=ev.progress_total, settings=ev.settings,
                         metrics=ev.metrics, error=ev.error, created_at=ev.created_at, started_at=ev.started_at,
                         finished_at=ev.finished_at)


@router.post("", response_model=EvaluationStartOut, status_code=202,
             summary="Evaluate a plan version against a model (in the background)",
             description="Returns at once with the evaluation and its job; follow the job (or its events) for progress.",
             responses={**NOT_FOUND, 409: {"model": ErrorOut, "description": "The model is not ready"},
                        422: {"model": ErrorOut, "description": "Invalid settings, or no model given"}})
def start_evaluation(project_id: int, body: EvaluationIn, session: SessionDep, state: StateDep) -> EvaluationStartOut:
    plan = in_project(session, Plan, body.plan_id, project_id, "plan")
    number = body.version if body.version is not None else max((v.number for v in plan.versions), default=0)
    version = next((v for v in plan.versions if v.number == number), None)
    if version is None:
        raise HTTPException(404, f"plan {plan.id} has no version {number}")
    model_id = body.model_id if body.model_id is not None else plan.model_id
    if model_id is None:
        raise HTTPException(422, f"plan {plan.id} is for no model: give model_id")
    ready_model(session, project_id, model_id)
    settings = body.settings.model_dump()
    evaluation_settings(settings)  # the library's own checks, before anything is queued
    if body.reality_id is not None:
        reality = in_project(session, Reality, body.reality_id, project_id, "reality capture")
        if reality.status != "ready":
            raise HTTPException(409, f"reality capture {reality.id} is {reality.status}, not ready")
        settings[REALITY_KEY] = reality.id
    if body.as_flown is not None:
        settings[AS_FLOWN_KEY] = body.as_flown
    if body.position_error is not None:
        from ...plan.perturb import PoseError
        from ...robustness import check_draws

        draws = body.draws if body.draws is not None else DEFAULT_DRAWS
        error = PoseError.parse(body.position_error)
        settings[ROBUSTNESS_KEY] = {"error": [error.horizontal_m, error.vertical_m, error.yaw_deg], "draws": draws,
                                    "pool": check_draws(draws, None), "label": error.label()}
    elif body.draws is not None:
        raise HTTPException(422, "draws needs a position_error: the error the draws are made under")
    if body.date is not None:
        settings[FOURD_KEY] = capture_date(session, project_id, model_id, body)
    elif body.schedule_id is not None:
        raise HTTPException(422, "schedule_id needs a date: the capture date to evaluate the site at")
    ev, job = queue_evaluation(state, session, version, model_id, settings)
    return EvaluationStartOut(evaluation=evaluation_out(ev), job=JobOut.model_validate(job))


@router.get("", response_model=list[EvaluationOut], summary="List the project's evaluations", responses=NOT_FOUND)
def list_evaluations(project_id: int, session: SessionDep) -> list[EvaluationOut]:
    rows = session.scalars(select(Evaluation).where(Evaluation.project_id == project_id).order_by(Evaluation.id))
    return [evaluation_out(e) for e in rows]


@router.get("/{evaluation_id}", response_model=EvaluationOut, summary="Get an evaluation with its plan metrics",
            responses=NOT_FOUND)
def read_evaluation(project_id: int, evaluation_id: int, session: SessionDep) -> EvaluationOut:
    return evaluation_out(in_project(session, Evaluation, evaluation_id, project_id, "evaluation"))


def done_evaluation(session: Session, project_id: int, evaluation_id: int) -> Evaluation:
    ev = in_project(session, Evaluation, evaluation_id, project_id, "evaluation")
    if ev.status != "done":
        raise HTTPException(409, f"evaluation {evaluation_id} is {ev.status}, not done"
                                 + (f": {ev.error}" if ev.error else ""))
    return ev


@router.get("/{evaluation_id}/elements", response_model=ElementsOut, summary="Per-element metrics",
            description="One row per target element: the columns of `sightplan evaluate`'s elements.csv.",
            responses={**NOT_FOUND, **NOT_DONE})
def read_elements(project_id: int, evaluation_id: int, session: SessionDep, state: StateDep) -> ElementsOut:
    ev = done_evaluation(session, project_id, evaluation_id)
    rows = json.loads((state.storage.evaluation_dir(ev.result_dir) / "elements.json").read_text(encoding="utf-8"))
    return ElementsOut(evaluation_id=ev.id, elements=rows)


@router.get("/{evaluation_id}/report.html", response_class=FileResponse,
            summary="The self-contained HTML report (a download)",
            responses={200: {"description": "One HTML page", "content": {"text/html": {}}}, **NOT_FOUND, **NOT_DONE,
                       503: {"model": ErrorOut, "description": "The 3D viewer's files are not installed on the server"}})
def read_html_report(project_id: int, evaluation_id: int, session: SessionDep, state: StateDep) -> FileResponse:
    from ...plan.format import read_plan
    from ...report.html import write_html

    ev = done_evaluation(session, project_id, evaluation_id)
    folder = state.storage.evaluation_dir(ev.result_dir)
    path = folder / "report.html"
    name = f"evaluation-{ev.id}.html"
    if not path.is_file():
        model = session.get(Model, ev.model_id)
        version = ev.plan_version
        assert model is not None
        try:
            result = rebuilt_evaluation(folder, ev.settings, ev.metrics or {})
            scene = evaluation_scene(state.storage, session, model.stored_name, ev.settings, ev.project_id)
            plan = read_plan(state.storage.plan_path(version.stored_name))
            tmp = state.storage.temp_path(".html")
            write_html(result, scene, plan, tmp, model_label=model.original_name,
                       plan_label=f"{version.plan.name} v{version.number}")
            os.replace(tmp, path)
        except ReportError as exc:
            raise HTTPException(503, str(exc)) from None
    return FileResponse(Path(path), media_type="text/html", filename=name)


@router.delete("/{evaluation_id}", status_code=204, response_class=Response, summary="Delete an evaluation",
               responses={**NOT_FOUND, 409: {"model": ErrorOut, "description": "It is still running"}})
def delete_evaluation(project_id: int, evaluation_id: int, session: SessionDep, state: StateDep) -> Response:
    ev = in_project(session, Evaluation, evaluation_id, project_id, "evaluation")
    if ev.status in ("queued", "running"):
        raise HTTPException(409, f"evaluation {evaluation_id} is {ev.status}; delete it when it is done")
    folder = state.storage.evaluation_dir(ev.result_dir)
    session.delete(ev)
    session.commit()
    state.storage.remove(folder)
    return Response(status_code=204)
