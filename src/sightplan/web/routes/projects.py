"""``/api/projects``: list, create, get, rename, delete."""

from __future__ import annotations

from fastapi import APIRouter, HTTPException, Response
from sqlalchemy import select

from ..auth import role_of
from ..deps import ProjectOwn, ProjectRead, SessionDep, StateDep, UserDep
from ..models import Evaluation, Job, Membership, Project, Reality, Schedule
from ..schemas import ErrorOut, ProjectIn, ProjectOut

router = APIRouter(prefix="/api/projects", tags=["projects"])
NOT_FOUND = {404: {"model": ErrorOut, "description": "No such project"}}


FORBIDDEN = {403: {"model": ErrorOut, "description": "Only an owner may (team mode)"}}


def project_out(session, project: Project, user) -> ProjectOut:
    role = role_of(session, project.id, user.id) if user is not None else None
    return ProjectOut(id=project.id, name=project.name, created_at=project.created_at, role=role)


@router.get("", response_model=list[ProjectOut], summary="List the projects (in team mode: yours)")
def list_projects(session: SessionDep, user: UserDep) -> list[ProjectOut]:
    query = select(Project).order_by(Project.id)
    if user is not None:
        query = query.join(Membership).where(Membership.user_id == user.id)
    return [project_out(session, p, user) for p in session.scalars(query)]


@router.post("", response_model=ProjectOut, status_code=201, summary="Create a project (you are its owner)")
def create_project(body: ProjectIn, session: SessionDep, user: UserDep) -> ProjectOut:
    project = Project(name=body.name.strip() or body.name)
    session.add(project)
    session.flush()
    if user is not None:
        session.add(Membership(project_id=project.id, user_id=user.id, role="owner"))
    session.commit()
    return project_out(session, project, user)


@router.get("/{project_id}", response_model=ProjectOut, summary="Get a project", responses=NOT_FOUND)
def read_project(project: ProjectRead, session: SessionDep, user: UserDep) -> ProjectOut:
    return project_out(session, project, user)


@router.patch("/{project_id}", response_model=ProjectOut, summary="Rename a project (owner only)",
              responses={**NOT_FOUND, **FORBIDDEN})
def rename_project(project: ProjectOwn, body: ProjectIn, session: SessionDep, user: UserDep) -> ProjectOut:
    project.name = body.name.strip() or body.name
    session.commit()
    return project_out(session, project, user)


@router.delete("/{project_id}", status_code=204, response_class=Response,
               summary="Delete a project with its models, plans, evaluations and files (owner only)",
               responses={**NOT_FOUND, **FORBIDDEN, 409: {"model": ErrorOut, "description": "A job is still running"}})
def delete_project(project: ProjectOwn, session: SessionDep, state: StateDep) -> Response:
    project_id = project.id
    busy = session.scalars(select(Job).where(Job.project_id == project_id, Job.status.in_(("queued", "running")))).first()
    if busy is not None:
        raise HTTPException(409, f"job {busy.id} is still running in project {project_id}; delete it when it is done")
    storage = state.storage
    files = [storage.model_path(m.stored_name) for m in project.models]
    files += [storage.plan_path(v.stored_name) for p in project.plans for v in p.versions]
    files += [storage.evaluation_dir(e.result_dir)
              for e in session.scalars(select(Evaluation).where(Evaluation.project_id == project_id))]
    for sched in session.scalars(select(Schedule).where(Schedule.project_id == project_id)):
        files += [storage.schedule_path(n) for n in (sched.stored_name, sched.rules_name, sched.dates_name) if n]
    for real in session.scalars(select(Reality).where(Reality.project_id == project_id)):
        files += [storage.reality_path(n) for n in (real.stored_name, real.view_name, real.view_name + ".glb")]
    files.append(storage.root / "basemaps" / str(project_id))  # its map background
    session.delete(project)
    session.commit()
    storage.remove(*files)
    return Response(status_code=204)
