"""``/api/jobs``: background work and its progress, as JSON or as Server-Sent Events."""

from __future__ import annotations

import asyncio
import json
from collections.abc import AsyncIterator
from typing import Annotated

from fastapi import APIRouter, HTTPException, Query, Request
from fastapi.responses import StreamingResponse
from sqlalchemy import select
from starlette.concurrency import run_in_threadpool

from ..deps import ServerState, SessionDep, StateDep, UserDep, current_user, found, project_for
from ..models import FINAL_STATES, Job, Membership
from ..schemas import ErrorOut, JobOut

router = APIRouter(prefix="/api/jobs", tags=["jobs"])
NOT_FOUND = {404: {"model": ErrorOut, "description": "No such job"}}
POLL_S = 0.2
HEARTBEAT_S = 15.0


@router.get("", response_model=list[JobOut], summary="List jobs, newest first (in team mode: of your projects)")
def list_jobs(session: SessionDep, user: UserDep,
              project_id: Annotated[int | None, Query(description="Only this project's")] = None,
              limit: Annotated[int, Query(ge=1, le=1000)] = 100) -> list[Job]:
    query = select(Job).order_by(Job.id.desc()).limit(limit)
    if project_id is not None:
        query = query.where(Job.project_id == project_id)
    if user is not None:
        query = query.where(Job.project_id.in_(select(Membership.project_id).where(Membership.user_id == user.id)))
    return list(session.scalars(query))


def visible_job(session, job_id: int, user) -> Job:
    """The job, if it belongs to a project the caller may read; else 404."""
    job = found(session.get(Job, job_id), "job", job_id)
    if user is not None:
        try:
            project_for(session, job.project_id, user, "viewer")
        except HTTPException:
            raise HTTPException(404, f"job {job_id} not found") from None
    return job


@router.get("/{job_id}", response_model=JobOut, summary="Get a job's status and progress", responses=NOT_FOUND)
def read_job(job_id: int, session: SessionDep, user: UserDep) -> Job:
    return visible_job(session, job_id, user)


@router.post("/{job_id}/cancel", response_model=JobOut, summary="Cancel a queued or running job (editor or owner)",
             description="A queued job is failed at once; a running one stops at its next progress step (a frame of "
                         "an evaluation) and is failed as 'cancelled', leaving no partial result.",
             responses={**NOT_FOUND, 403: {"model": ErrorOut, "description": "A viewer cannot cancel"},
                        409: {"model": ErrorOut, "description": "The job is finished already"}})
def cancel_job(job_id: int, session: SessionDep, state: StateDep, user: UserDep) -> Job:
    from ..worker import CANCELLED

    job = visible_job(session, job_id, user)
    if user is not None:
        project_for(session, job.project_id, user, "editor")
    if job.status in FINAL_STATES:
        raise HTTPException(409, f"job {job_id} is {job.status} already")
    state.worker.cancel(job_id)
    session.commit()
    state.worker.fail_if_queued(job_id, CANCELLED)
    session.expire_all()
    return found(session.get(Job, job_id), "job", job_id)


def _snapshot(state: ServerState, job_id: int) -> JobOut | None:
    with state.db.session() as s:
        job = s.get(Job, job_id)
        return None if job is None else JobOut.model_validate(job)


async def job_events(request: Request, state: ServerState, job_id: int, created_at=None) -> AsyncIterator[str]:
    """``progress`` events whenever the job changes, then one ``done`` or ``failed`` event; a comment line every
    15 s keeps proxies from closing an idle stream. The stream follows the job it was opened for: should that job
    be deleted and its id taken by another, it ends."""
    last: tuple | None = None
    quiet = 0.0
    while True:
        job = await run_in_threadpool(_snapshot, state, job_id)
        if job is None or (created_at is not None and job.created_at != created_at):
            yield f"event: failed\ndata: {json.dumps({'detail': f'job {job_id} was deleted'})}\n\n"
            return
        key = (job.status, job.progress_done, job.progress_total, job.message)
        if job.status in FINAL_STATES:
            yield f"event: {job.status}\ndata: {job.model_dump_json()}\n\n"
            return
        if key != last:
            last, quiet = key, 0.0
            yield f"event: progress\ndata: {job.model_dump_json()}\n\n"
        elif quiet >= HEARTBEAT_S:
            quiet = 0.0
            yield ": waiting\n\n"
        if await request.is_disconnected():
            return
        await asyncio.sleep(POLL_S)
        quiet += POLL_S


@router.get("/{job_id}/events", response_class=StreamingResponse,
            summary="Stream a job's progress as Server-Sent Events until it is done or failed",
            responses={200: {"description": "`event: progress` with the job as JSON on each change, then "
                                            "`event: done` or `event: failed`", "content": {"text/event-stream": {}}},
                       **NOT_FOUND})
def stream_job(job_id: int, request: Request, state: StateDep) -> StreamingResponse:
    # its own short session, not the request's: the stream lasts as long as the job, and must not keep a database
    # connection (or a transaction) all that time
    with state.db.session() as session:
        created = JobOut.model_validate(visible_job(session, job_id, current_user(request, state, session))).created_at
    return StreamingResponse(job_events(request, state, job_id, created), media_type="text/event-stream",
                             headers={"Cache-Control": "no-cache", "X-Accel-Buffering": "no"})
