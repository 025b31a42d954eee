"""The FastAPI application: database brought up to date, interrupted jobs failed, worker started, routes mounted."""

from __future__ import annotations

from collections.abc import AsyncIterator
from contextlib import asynccontextmanager

from fastapi import Depends, FastAPI, HTTPException
from fastapi.responses import JSONResponse

from .. import __version__
from .config import ServerConfig
from .db import Database, upgrade_database
from .deps import ServerState
from .errors import ids_in_range, install_error_handlers
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

    app = FastAPI(title="sightplan", version=__version__, description=DESCRIPTION, lifespan=lifespan,
                  dependencies=[Depends(ids_in_range)])
    app.state.sightplan = state

    app.add_middleware(BodyLimit, limit=state.config.max_upload_bytes)
    if not state.config.team:
        app.add_middleware(LocalOnly, host=state.config.host)
    install_error_handlers(app)
    for router in ROUTERS:
        app.include_router(router)
    return app


LOOPBACK_NAMES = ("127.0.0.1", "localhost", "::1", "testserver")  # the last: the name Starlette's test client sends


class LocalOnly:
    """Single-user mode has no login, so it answers only requests made to its loopback address by pages of its own:
    another Host (a web site's name rebound to 127.0.0.1) is refused with 400, and a change sent by a page of
    another origin (a cross-site form or fetch) with 403."""

    def __init__(self, app, host: str) -> None:
        self.app = app
        self.names = {*LOOPBACK_NAMES, host.strip("[]").lower()}

    async def __call__(self, scope, receive, send) -> None:
        if scope["type"] not in ("http", "websocket"):
            await self.app(scope, receive, send)
            return
        headers = dict(scope.get("headers") or ())
        host = headers.get(b"host", b"").decode("latin-1").lower()
        name = host[1:host.index("]")] if host.startswith("[") and "]" in host else host.rsplit(":", 1)[0]
        if name not in self.names:
            await JSONResponse({"detail": f"this single-user server answers only on its loopback address, not as "
                                          f"{host!r}"}, status_code=400)(scope, receive, send)
            return
        origin = headers.get(b"origin")
        if origin is not None and scope.get("method") not in ("GET", "HEAD", "OPTIONS"):
            netloc = origin.decode("latin-1").lower().split("://", 1)[-1].rstrip("/")
            if netloc != host:
                await JSONResponse({"detail": f"a change sent by a page of another site ({origin.decode('latin-1')}) "
                                              "is refused"}, status_code=403)(scope, receive, send)
                return
        await self.app(scope, receive, send)


class BodyLimit:
    """Refuse a request body over the upload limit: at once when its declared length is over, and, for a body sent
    in chunks without a length, as soon as the bytes read pass it (before anything is spooled to disk)."""

    def __init__(self, app, limit: int) -> None:
        self.app, self.limit = app, limit
        self.message = (f"the upload is larger than the server's limit of {limit / 1024 / 1024:g} MB "
                        "(sightplan serve --max-upload-mb)")

    async def __call__(self, scope, receive, send) -> None:
        if scope["type"] != "http":
            await self.app(scope, receive, send)
            return
        limit = self.limit + MULTIPART_SLACK
        length = dict(scope.get("headers") or ()).get(b"content-length", b"")
        if length.isdigit() and int(length) > limit:
            await JSONResponse({"detail": self.message}, status_code=413)(scope, receive, send)
            return
        seen = 0

        async def counted():
            nonlocal seen
            message = await receive()
            if message["type"] == "http.request":
                seen += len(message.get("body", b""))
                if seen > limit:
                    raise HTTPException(413, self.message)
            return message

        await self.app(scope, counted, send)


def close_state(state: ServerState) -> None:
    """Stop the worker (running jobs finish first) and close the database."""
    state.worker.shutdown(wait=True)
    state.db.dispose()
