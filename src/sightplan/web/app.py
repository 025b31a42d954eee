"""The FastAPI application: database brought up to date, interrupted jobs failed, worker started, routes mounted."""

from __future__ import annotations

import base64
import hashlib
import os
import re
from collections.abc import AsyncIterator
from contextlib import asynccontextmanager

from fastapi import Depends, FastAPI, HTTPException
from fastapi.responses import JSONResponse

from ..version import __version__
from .config import ServerConfig
from .db import Database, upgrade_database
from .deps import ServerState
from .errors import ids_in_range, install_error_handlers
from .openapi import description, install_document
from .routes import ROUTERS
from .routes.viewer import STATIC_DIR
from .storage import Storage
from .worker import Worker, recover_interrupted

MULTIPART_SLACK = 64 * 1024  # multipart headers and boundaries around the file
UNPACKED_PER_UPLOAD = 10  # an archive's contents may be this many times the upload limit


def open_state(config: ServerConfig) -> ServerState:
    """Connect to the cluster (when there is one), create the data folder and the database schema (Alembic), fail
    the jobs a previous process left unfinished, and start the worker."""
    cluster = None
    if config.cluster is not None:
        from .cluster import ServerCluster

        cluster = ServerCluster(config.cluster)
    try:
        config.data_dir.mkdir(parents=True, exist_ok=True)
        storage = Storage(config.data_dir)
        storage.clear_tmp()
        db = Database(config.url)
        upgrade_database(db.engine)
        recover_interrupted(db)
    except BaseException:
        if cluster is not None:
            cluster.close()
        raise
    return ServerState(config=config, db=db, storage=storage, worker=Worker(db, storage, config.workers, cluster),
                       cluster=cluster)


def create_app(config: ServerConfig | None = None) -> FastAPI:
    """The application for ``config`` (default: ``./sightplan-data`` with its SQLite database)."""
    state = open_state(config or ServerConfig())
    # an uploaded .ifczip may unpack to ten times the upload limit at most (checked before and while unpacking)
    os.environ["SIGHTPLAN_MAX_UNPACKED_MB"] = f"{UNPACKED_PER_UPLOAD * state.config.max_upload_bytes / 2**20:g}"

    @asynccontextmanager
    async def lifespan(_app: FastAPI) -> AsyncIterator[None]:
        yield
        close_state(state)

    app = FastAPI(title="sightplan", version=__version__, description=description(state.config.team),
                  lifespan=lifespan, dependencies=[Depends(ids_in_range)], docs_url=None, redoc_url=None)
    install_document(app, [route for router in ROUTERS for route in router.routes], state.config.team)
    app.state.sightplan = state

    app.add_middleware(BodyLimit, limit=state.config.max_upload_bytes)
    app.add_middleware(SameOriginChanges, allowed=state.config.allowed_origins)
    if not state.config.team:
        app.add_middleware(LocalOnly, host=state.config.host)
    app.add_middleware(SecurityHeaders, basemap=state.config.basemap_origin)
    install_error_handlers(app)
    for router in ROUTERS:
        app.include_router(router)
    return app


LOOPBACK_NAMES = ("127.0.0.1", "localhost", "::1", "testserver")  # the last: the name Starlette's test client sends
SAFE_METHODS = ("GET", "HEAD", "OPTIONS")
#: The header the page sends with every change; a page of another origin cannot add it without the server's CORS consent,
#: which it never gives.
REQUEST_HEADER = "X-Sightplan-Request"


class LocalOnly:
    """Single-user mode has no login, so it answers only requests made to its loopback address: another Host (a web
    site's name rebound to 127.0.0.1) is refused with 400. Changes from pages of other origins are refused in every
    mode (:class:`SameOriginChanges`)."""

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
        await self.app(scope, receive, send)


def _origin_of(url: str) -> str:
    """``scheme://host[:port]`` of a URL, lower case ('' when it has none)."""
    scheme, _, rest = url.strip().partition("://")
    return f"{scheme.lower()}://{rest.split('/', 1)[0].lower()}" if rest else ""


class SameOriginChanges:
    """Cross-site request forgery: a change (any method but GET, HEAD, OPTIONS) is refused with 403 when

    - its ``Origin`` (or, without one, its ``Referer``) is not the server's own origin (the request's scheme and
      ``Host``) nor one of ``allowed`` (a reverse proxy's). Browsers send ``Origin`` with every such request, also
      from a form or a ``no-cors`` fetch, and a page on another port of the same machine is another origin;
    - it is authenticated by the session cookie yet carries neither header nor :data:`REQUEST_HEADER`.

    Requests with a bearer token (scripts) need nothing more: a browser never adds that header for another site.
    """

    def __init__(self, app, allowed: tuple[str, ...] = ()) -> None:
        self.app, self.allowed = app, set(allowed)

    async def __call__(self, scope, receive, send) -> None:
        if scope["type"] != "http" or scope.get("method") in SAFE_METHODS:
            await self.app(scope, receive, send)
            return
        headers = dict(scope.get("headers") or ())
        own = f"{scope.get('scheme', 'http')}://{headers.get(b'host', b'').decode('latin-1').lower()}"
        origin = headers.get(b"origin", b"").decode("latin-1")
        referer = headers.get(b"referer", b"").decode("latin-1")
        sender = origin or _origin_of(referer)
        problem = None
        if sender and sender.lower().rstrip("/") != own and sender.lower().rstrip("/") not in self.allowed:
            problem = f"a change sent by a page of another site ({sender}) is refused"
        elif not sender and b"sightplan_session=" in headers.get(b"cookie", b"") \
                and not headers.get(b"authorization", b"").lower().startswith(b"bearer ") \
                and REQUEST_HEADER.lower().encode() not in headers:
            problem = (f"a change made with the session cookie must come from sightplan's page (header "
                       f"{REQUEST_HEADER}); scripts use an API token")
        if problem:
            await JSONResponse({"detail": problem}, status_code=403)(scope, receive, send)
            return
        await self.app(scope, receive, send)


def _csp(basemap: str | None = None) -> str:
    """The page's Content-Security-Policy: its own scripts only, the import map by its hash; the map's tiles from
    ``basemap`` (an origin) too, when one is configured."""
    page = (STATIC_DIR / "index.html").read_text(encoding="utf-8")
    hashes = []
    for body in re.findall(r"<script(?![^>]*\bsrc=)[^>]*>(.*?)</script>", page, flags=re.S):
        digest = base64.b64encode(hashlib.sha256(body.encode("utf-8")).digest()).decode()
        hashes.append(f"'sha256-{digest}'")
    tiles = f" {basemap}" if basemap else ""
    return ("default-src 'self'; script-src 'self' " + " ".join(hashes) + "; style-src 'self'; "
            f"img-src 'self' data: blob:{tiles}; connect-src 'self'{tiles}; worker-src 'self' blob:; object-src 'none'; "
            "base-uri 'none'; form-action 'self'; frame-ancestors 'none'")


class SecurityHeaders:
    """Headers on every response: a strict Content-Security-Policy, no sniffing, no framing, same-origin referrers."""

    def __init__(self, app, basemap: str | None = None) -> None:
        self.app = app
        self.headers = [(b"content-security-policy", _csp(basemap).encode()), (b"x-content-type-options", b"nosniff"),
                        (b"x-frame-options", b"DENY"), (b"referrer-policy", b"same-origin")]

    async def __call__(self, scope, receive, send) -> None:
        if scope["type"] != "http":
            await self.app(scope, receive, send)
            return

        async def with_headers(message) -> None:
            if message["type"] == "http.response.start":
                present = {k.lower() for k, _ in message.get("headers", ())}
                message["headers"] = [*message.get("headers", ()), *(h for h in self.headers if h[0] not in present)]
            await send(message)

        await self.app(scope, receive, with_headers)


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
    """Stop the worker (running jobs stop at their next progress step, or are failed after a grace period), close
    the cluster's client (and a ``local:N`` cluster) and the database."""
    state.worker.shutdown()
    if state.cluster is not None:
        state.cluster.close()
    state.db.dispose()
