"""``/api/projects/{project_id}/models``: upload (tessellated by the worker), list, get, delete."""

from __future__ import annotations

from typing import Annotated

from fastapi import APIRouter, File, HTTPException, Response, UploadFile
from sqlalchemy import select

from ..deps import PROJECT_ACCESS, SessionDep, StateDep, in_project
from ..models import Evaluation, Job, Model, Schedule
from ..schemas import ErrorOut, JobOut, ModelDetailOut, ModelOut, ModelUploadOut
from ..storage import MODEL_SUFFIXES, display_name
from ..uploads import queue_upload, receive_upload

router = APIRouter(prefix="/api/projects/{project_id}/models", tags=["models"], dependencies=PROJECT_ACCESS)
NOT_FOUND = {404: {"model": ErrorOut, "description": "No such project or model"}}


@router.post("", response_model=ModelUploadOut, status_code=202, summary="Upload an IFC or mesh model",
             description="The file is stored under a server-chosen name and tessellated in the background: follow the "
                         "returned job. A file that does not parse leaves the model 'failed' with the loader's message.",
             responses={**NOT_FOUND, 400: {"model": ErrorOut, "description": "Empty file"},
                        413: {"model": ErrorOut, "description": "Over the upload limit"},
                        415: {"model": ErrorOut, "description": "Not a model file extension"}})
async def upload_model(project_id: int, state: StateDep, session: SessionDep,
                       file: Annotated[UploadFile, File(description="IFC (.ifc, .ifczip) or mesh (.obj, .ply, .stl, "
                                                                    ".gltf, .glb) file")]) -> ModelUploadOut:
    tmp, size = await receive_upload(state, file, MODEL_SUFFIXES, "model")
    stored = state.storage.new_name(tmp.suffix)

    def rows() -> tuple[Model, Job]:
        model = Model(project_id=project_id, original_name=display_name(file.filename or ""), stored_name=stored,
                      size_bytes=size)
        session.add(model)
        session.flush()
        job = Job(project_id=project_id, kind="load_model", model_id=model.id, message="queued")
        session.add(job)
        return model, job

    model, job = queue_upload(state, session, [(tmp, state.storage.model_path(stored))], rows)
    return ModelUploadOut(model=ModelOut.model_validate(model), job=JobOut.model_validate(job))


@router.get("", response_model=list[ModelOut], summary="List the project's models", responses=NOT_FOUND)
def list_models(project_id: int, session: SessionDep) -> list[Model]:
    return list(session.scalars(select(Model).where(Model.project_id == project_id).order_by(Model.id)))


@router.get("/{model_id}", response_model=ModelDetailOut, summary="Get a model with its load report",
            responses=NOT_FOUND)
def read_model(project_id: int, model_id: int, session: SessionDep) -> Model:
    return in_project(session, Model, model_id, project_id, "model")


@router.delete("/{model_id}", status_code=204, response_class=Response,
               summary="Delete a model, its file and its evaluations",
               responses={**NOT_FOUND, 409: {"model": ErrorOut, "description": "A job is still running on it"}})
def delete_model(project_id: int, model_id: int, session: SessionDep, state: StateDep) -> Response:
    model = in_project(session, Model, model_id, project_id, "model")
    evaluations = list(session.scalars(select(Evaluation).where(Evaluation.model_id == model_id)))
    busy = session.scalars(select(Job).where(Job.status.in_(("queued", "running")),
                                             (Job.model_id == model_id)
                                             | Job.evaluation_id.in_([e.id for e in evaluations]))).first()
    if busy is not None:
        raise HTTPException(409, f"job {busy.id} is still running on model {model_id}; delete it when it is done")
    files = [state.storage.model_path(model.stored_name)] + [state.storage.evaluation_dir(e.result_dir)
                                                              for e in evaluations]
    for sched in session.scalars(select(Schedule).where(Schedule.model_id == model_id)):
        files += [state.storage.schedule_path(n) for n in (sched.stored_name, sched.rules_name, sched.dates_name) if n]
    session.delete(model)
    session.commit()
    state.storage.remove(*files)
    return Response(status_code=204)
