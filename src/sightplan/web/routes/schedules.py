"""``/api/projects/{project_id}/schedules``: construction schedules linked to a model (in the worker), and the site
at a date for the viewer's date slider: every element built, in progress or not yet."""

from __future__ import annotations

from typing import Annotated, Literal

from fastapi import APIRouter, File, Form, HTTPException, Query, Response, UploadFile
from pydantic import BaseModel, Field
from sqlalchemy import select

from ..deps import PROJECT_ACCESS, ProjectEdit, SessionDep, StateDep, in_project
from ..errors import MAX_ID
from ..models import Job, Model, Schedule
from ..scenes import evaluations_using
from ..schemas import ErrorOut, JobOut, Time
from ..services import FOURD_KEY, element_states, load_element_dates
from ..storage import display_name
from ..uploads import queue_upload, receive_upload

router = APIRouter(prefix="/api/projects/{project_id}", tags=["schedules"], dependencies=PROJECT_ACCESS)
NOT_FOUND = {404: {"model": ErrorOut, "description": "No such project, model or schedule"}}
SCHEDULE_SUFFIXES = (".xml", ".xer", ".csv", ".ifc", ".ifczip")
RULES_SUFFIXES = (".toml",)


class ScheduleOut(BaseModel):
    id: int
    project_id: int
    model_id: int
    name: str = Field(description="The uploaded file's name, or 'model' for the model's own IfcWorkSchedule")
    status: Literal["queued", "linking", "ready", "failed"]
    error: str | None
    prefer_actual: bool
    first_date: str | None = Field(description="Earliest start of a linked element (YYYY-MM-DD)")
    last_date: str | None = Field(description="Latest finish of a linked element")
    report: dict | None = Field(description="The link report: lines as `sightplan evaluate --schedule` prints them, "
                                            "tasks, linked, unlinked, targets, dated, warnings")
    created_at: Time


class ScheduleUploadOut(BaseModel):
    schedule: ScheduleOut
    job: JobOut


class StatesOut(BaseModel):
    date: str
    schedule_id: int
    basis: Literal["finish", "start"]
    states: dict[int, Literal["built", "in_progress", "not_yet"]] = Field(
        description="Each element (by index) at the end of the date")
    counts: dict[str, int]


def schedule_out(row: Schedule) -> ScheduleOut:
    return ScheduleOut(id=row.id, project_id=row.project_id, model_id=row.model_id, name=row.original_name,
                       status=row.status, error=row.error, prefer_actual=row.prefer_actual,  # type: ignore[arg-type]
                       first_date=row.first_date, last_date=row.last_date, report=row.report, created_at=row.created_at)


@router.post("/schedules", response_model=ScheduleUploadOut, status_code=202,
             summary="Add a schedule to a model: a file, or the model's own IfcWorkSchedule",
             description="MS Project XML, Primavera P6 .xer, CSV, or an IFC with a work schedule; with `rules` (a TOML "
                         "file) linking tasks to elements by class, storey, name or property. Linked in the background: "
                         "follow the job. A schedule that links no element leaves it 'failed' with the reason.",
             responses={**NOT_FOUND, 409: {"model": ErrorOut, "description": "The model is not ready"},
                        413: {"model": ErrorOut, "description": "Over the upload limit"},
                        415: {"model": ErrorOut, "description": "Not a schedule or rules file"}})
async def add_schedule(project: ProjectEdit, state: StateDep, session: SessionDep,
                       model_id: Annotated[int, Form(ge=-MAX_ID - 1, le=MAX_ID,
                                                     description="The project's model the schedule builds")],
                       file: Annotated[UploadFile | None, File(description="The schedule; none: the model's own "
                                                                           "IfcWorkSchedule")] = None,
                       rules: Annotated[UploadFile | None, File(description="TOML link rules")] = None,
                       prefer_actual: Annotated[bool, Form(description="Actual dates win over planned ones")] = False,
                       ) -> ScheduleUploadOut:
    model = in_project(session, Model, model_id, project.id, "model")
    if model.status != "ready":
        raise HTTPException(409, f"model {model_id} is {model.status}, not ready")
    received: list[tuple] = []
    try:
        if file is not None:
            tmp = (await receive_upload(state, file, SCHEDULE_SUFFIXES, "schedule"))[0]
            received.append((tmp, state.storage.schedule_path(state.storage.new_name(tmp.suffix))))
        if rules is not None:
            tmp = (await receive_upload(state, rules, RULES_SUFFIXES, "link rules"))[0]
            received.append((tmp, state.storage.schedule_path(state.storage.new_name(".toml"))))
    except BaseException:
        state.storage.remove(*(t for t, _ in received))
        raise
    targets = iter(target.name for _, target in received)

    def rows() -> tuple[Schedule, Job]:
        row = Schedule(project_id=project.id, model_id=model_id,
                       stored_name=next(targets) if file is not None else None,
                       rules_name=next(targets) if rules is not None else None,
                       original_name=display_name(file.filename or "") if file is not None else "model",
                       prefer_actual=prefer_actual, dates_name=state.storage.new_name(".npz"))
        session.add(row)
        session.flush()
        job = Job(project_id=project.id, kind="link_schedule", model_id=model_id, schedule_id=row.id, message="queued")
        session.add(job)
        return row, job

    row, job = queue_upload(state, session, received, rows)
    return ScheduleUploadOut(schedule=schedule_out(row), job=JobOut.model_validate(job))


@router.get("/schedules", response_model=list[ScheduleOut], summary="The project's schedules", responses=NOT_FOUND)
def list_schedules(project_id: int, session: SessionDep,
                   model_id: Annotated[int | None, Query(description="Only this model's")] = None) -> list[ScheduleOut]:
    query = select(Schedule).where(Schedule.project_id == project_id).order_by(Schedule.id)
    if model_id is not None:
        query = query.where(Schedule.model_id == model_id)
    return [schedule_out(r) for r in session.scalars(query)]


@router.get("/schedules/{schedule_id}", response_model=ScheduleOut, summary="A schedule with its link report",
            responses=NOT_FOUND)
def read_schedule_row(project_id: int, schedule_id: int, session: SessionDep) -> ScheduleOut:
    return schedule_out(in_project(session, Schedule, schedule_id, project_id, "schedule"))


@router.delete("/schedules/{schedule_id}", status_code=204, response_class=Response, summary="Delete a schedule",
               responses=NOT_FOUND)
def delete_schedule(project_id: int, schedule_id: int, session: SessionDep, state: StateDep) -> Response:
    row = in_project(session, Schedule, schedule_id, project_id, "schedule")
    if row.status in ("queued", "linking"):
        raise HTTPException(409, f"schedule {schedule_id} is still being linked; delete it when it is done")
    users = evaluations_using(session, project_id, FOURD_KEY, schedule_id)
    if users:
        raise HTTPException(409, f"schedule {schedule_id} dates evaluation(s) {', '.join(map(str, users))}: delete "
                                 "those first")
    files = [state.storage.schedule_path(n) for n in (row.stored_name, row.rules_name, row.dates_name) if n]
    session.delete(row)
    session.commit()
    state.storage.remove(*files)
    return Response(status_code=204)


@router.get("/models/{model_id}/states", response_model=StatesOut,
            summary="The site at a date: each element built, in progress or not yet",
            description="For the viewer's date slider. `basis`: which schedule date builds an element (finish, as "
                        "evaluations count it, or start); elements the schedule does not date are built or not yet as "
                        "`unscheduled` says.",
            responses={**NOT_FOUND, 409: {"model": ErrorOut, "description": "The schedule is not linked (yet)"},
                       422: {"model": ErrorOut, "description": "Not a date"}})
def read_states(project_id: int, model_id: int, session: SessionDep, state: StateDep,
                date: Annotated[str, Query(description="YYYY-MM-DD")],
                schedule_id: Annotated[int | None, Query(description="Default: the model's latest ready schedule")]
                = None,
                basis: Annotated[Literal["finish", "start"], Query()] = "finish",
                unscheduled: Annotated[Literal["present", "absent"], Query()] = "present") -> StatesOut:
    in_project(session, Model, model_id, project_id, "model")
    if schedule_id is None:
        row = session.scalars(select(Schedule).where(Schedule.model_id == model_id, Schedule.status == "ready")
                              .order_by(Schedule.id.desc())).first()
        if row is None:
            raise HTTPException(404, f"model {model_id} has no linked schedule")
    else:
        row = in_project(session, Schedule, schedule_id, project_id, "schedule")
        if row.model_id != model_id:
            raise HTTPException(404, f"schedule {schedule_id} is not for model {model_id}")
    if row.status != "ready":
        raise HTTPException(409, f"schedule {row.id} is {row.status}" + (f": {row.error}" if row.error else ""))
    start, finish = load_element_dates(state.storage.schedule_path(row.dates_name))
    states = element_states(start, finish, date, basis, unscheduled)
    counts = {k: states.count(k) for k in ("built", "in_progress", "not_yet")}
    return StatesOut(date=date, schedule_id=row.id, basis=basis, states=dict(enumerate(states)),  # type: ignore[arg-type]
                     counts=counts)
