"""Receiving an uploaded file: a known suffix, not empty, not over the limit, into ``tmp/`` under a server-chosen
name."""

from __future__ import annotations

from collections.abc import AsyncIterator
from pathlib import Path

from fastapi import HTTPException, UploadFile

from .deps import ServerState
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
