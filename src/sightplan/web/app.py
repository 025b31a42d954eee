"""The FastAPI application: database brought up to date, interrupted jobs failed, worker started, routes mounted."""

from __future__ import annotations

from collections.abc import AsyncIterator
from contextlib import asynccontextmanager

from fastapi import FastAPI, Request
from fastapi.responses import JSONResponse

from .. import __version__
from .config import ServerConfig
from .db import Database, upgrade_database
from .deps import ServerState
from .errors import install_error_handlers
from .routes import ROUTERS
from .storage import Storage
from .worker import Worker, recover_interrupted

DESCRIPTION = """\
sightplan's REST API: upload building models, make capture plans from templates or files, edit them as versions,
evaluate them (VC, V̄C, VR, R, O, T) in the background, and download reports and flight-app exports.

Single-user mode: the server listens on the loopback address only and asks for no login.
Errors are JSON `{"detail": "one message"}`.
"""
MULTIPART_SLACK = 64 * 1024  # multipart headers and boundaries around the file


def open_state(config: ServerConfig) -> ServerState:
    """Create the data folder and the database schema (Alembic), fail the jobs a previous process left unfinished,
    and start the worker."""
    config.data_dir.mkdir(parents=True, exist_ok=True)
    storage = Storage(config.data_dir)
    storage.clear_tmp()
    db = Database(config.url)
    upgrade_database(db.engine)
    recover_interrupted(db)
    return ServerState(config=config, db=db, storage=storage, worker=Worker(db, storage, config.workers))


def create_app(config: ServerConfig | None = None) -> FastAPI:
    """The application for ``config`` (default: ``./sightplan-data`` with its SQLite database)."""
    state = open_state(config or ServerConfig())

    @asynccontextmanager
    async def lifespan(_app: FastAPI) -> AsyncIterator[None]:
        yield
        close_state(state)

    app = FastAPI(title="sightplan", version=__version__, description=DESCRIPTION, lifespan=lifespan)
    app.state.sightplan = state

    @app.middleware("http")
    async def limit_body(request: Request, call_next):
        """Refuse a request whose declared size is over the upload limit before reading it."""
        length = request.headers.get("content-length")
        limit = state.config.max_upload_bytes
        if length is not None and length.isdigit() and int(length) > limit + MULTIPART_SLACK:
            return JSONResponse({"detail": f"the upload is larger than the server's limit of {limit / 1024 / 1024:g} MB "
                                           "(sightplan serve --max-upload-mb)"}, status_code=413)
        return await call_next(request)

    install_error_handlers(app)
    for router in ROUTERS:
        app.include_router(router)
    return app


def close_state(state: ServerState) -> None:
    """Stop the worker (running jobs finish first) and close the database."""
    state.worker.shutdown(wait=True)
    state.db.dispose()
