"""Receiving an uploaded file: a known suffix, not empty, not over the limit, into ``tmp/`` under a server-chosen
name."""

from __future__ import annotations

from collections.abc import AsyncIterator, Callable, Sequence
from pathlib import Path

from fastapi import HTTPException, UploadFile
from sqlalchemy.orm import Session

from .deps import ServerState
from .models import Base, Job
from .storage import safe_suffix

CHUNK = 1 << 20


async def _chunks(file: UploadFile) -> AsyncIterator[bytes]:
    while chunk := await file.read(CHUNK):
        yield chunk


async def receive_upload(state: ServerState, file: UploadFile, allowed: tuple[str, ...], what: str) -> tuple[Path, int]:
    """The upload in a new temporary file and its size; 415 for an unknown suffix, 413 over the limit, 400 when
    empty (nothing is left behind)."""
    original = file.filename or ""
    suffix = safe_suffix(original, allowed)
    if suffix is None:
        raise HTTPException(415, f"{original or 'the upload'!s}: not a {what} file this server reads; expected one of "
                                 f"{', '.join(allowed)}")
    path, size = await state.storage.receive(_chunks(file), suffix, state.config.max_upload_bytes)
    if size == 0:
        path.unlink(missing_ok=True)
        raise HTTPException(400, f"{original}: the file is empty (0 bytes)")
    return path, size


def queue_upload(state: ServerState, session: Session, files: Sequence[tuple[Path, Path]],
                 rows: Callable[[], tuple[Base, Job]]) -> tuple[Base, Job]:
    """Record an upload and queue the job that prepares it: ``rows()`` adds the rows (flushed, so ids exist) and
    returns the resource and its job; each received temporary file moves to its place; one commit. On any failure
    nothing stays behind, neither rows nor files. Returns the rows, the job submitted to the worker."""
    try:
        row, job = rows()
        session.flush()
        for tmp, target in files:
            state.storage.adopt(tmp, target)
        session.commit()
    except BaseException:
        session.rollback()
        state.storage.remove(*(p for pair in files for p in pair))
        raise
    state.worker.submit(job.id)
    return row, job
