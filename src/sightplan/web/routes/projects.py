"""``/api/projects``: list, create, get, rename, delete."""

from __future__ import annotations

from fastapi import APIRouter, HTTPException, Response
from sqlalchemy import select

from ..deps import SessionDep, StateDep, get_project
from ..models import Evaluation, Job, Project
from ..schemas import ErrorOut, ProjectIn, ProjectOut

router = APIRouter(prefix="/api/projects", tags=["projects"])
NOT_FOUND = {404: {"model": ErrorOut, "description": "No such project"}}


@router.get("", response_model=list[ProjectOut], summary="List the projects")
def list_projects(session: SessionDep) -> list[Project]:
    return list(session.scalars(select(Project).order_by(Project.id)))


@router.post("", response_model=ProjectOut, status_code=201, summary="Create a project")
def create_project(body: ProjectIn, session: SessionDep) -> Project:
    project = Project(name=body.name.strip() or body.name)
    session.add(project)
    session.commit()
    return project


@router.get("/{project_id}", response_model=ProjectOut, summary="Get a project", responses=NOT_FOUND)
def read_project(project_id: int, session: SessionDep) -> Project:
    return get_project(session, project_id)


@router.patch("/{project_id}", response_model=ProjectOut, summary="Rename a project", responses=NOT_FOUND)
def rename_project(project_id: int, body: ProjectIn, session: SessionDep) -> Project:
    project = get_project(session, project_id)
    project.name = body.name.strip() or body.name
    session.commit()
    return project


@router.delete("/{project_id}", status_code=204, response_class=Response,
               summary="Delete a project with its models, plans, evaluations and files",
               responses={**NOT_FOUND, 409: {"model": ErrorOut, "description": "A job is still running"}})
def delete_project(project_id: int, session: SessionDep, state: StateDep) -> Response:
    project = get_project(session, project_id)
    busy = session.scalars(select(Job).where(Job.project_id == project_id, Job.status.in_(("queued", "running")))).first()
    if busy is not None:
        raise HTTPException(409, f"job {busy.id} is still running in project {project_id}; delete it when it is done")
    storage = state.storage
    files = [storage.model_path(m.stored_name) for m in project.models]
    files += [storage.plan_path(v.stored_name) for p in project.plans for v in p.versions]
    files += [storage.evaluation_dir(e.result_dir)
              for e in session.scalars(select(Evaluation).where(Evaluation.project_id == project_id))]
    session.delete(project)
    session.commit()
    storage.remove(*files)
    return Response(status_code=204)
