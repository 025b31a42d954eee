"""Every error answer is JSON ``{"detail": "one readable message"}``; never a traceback."""

from __future__ import annotations

import logging
import re

from fastapi import FastAPI, Request
from fastapi.exceptions import RequestValidationError
from fastapi.responses import JSONResponse
from sqlalchemy.exc import DataError
from starlette.exceptions import HTTPException as StarletteHTTPException

from ..errors import SightplanError
from .storage import UploadTooLarge

log = logging.getLogger("sightplan.web")


def _location(loc: tuple) -> str:
    parts = [str(p) for p in loc if p not in ("body", "query", "path", "form")]
    return ".".join(parts) or "request"


_BOUNDS = ("greater_than", "greater_than_equal", "less_than", "less_than_equal")


def _clause(e: dict) -> str:
    """One validation error as ``field: message``, a number's value as given (``NaN``, ``Infinity``, ``1e308``)."""
    from ..plan.domain import shown

    where, kind, value = _location(tuple(e.get("loc", ()))), e.get("type", ""), e.get("input")
    given = value[:40] if isinstance(value, str) else shown(value)  # a query's text as it came
    if kind == "finite_number":
        return f"{where}: {shown(value)} is not a finite number"
    if kind not in _BOUNDS:
        return f"{where}: {e.get('msg', 'invalid')}"
    if isinstance(value, int) and not isinstance(value, bool) and where.rsplit(".", 1)[-1].endswith("_id"):
        return f"{where}: {value} is out of range: no id is that large"
    return f"{where}: {e.get('msg', 'invalid')}, got {given}"


def validation_message(exc: RequestValidationError) -> str:
    """The first few validation errors, one clause each: ``scale: Input should be less than or equal to 1, got 2``."""
    errors = exc.errors()
    clauses = [_clause(e) for e in errors[:3]]
    more = f" (and {len(errors) - 3} more)" if len(errors) > 3 else ""
    return "; ".join(clauses) + more


#: FastAPI's words for a body it cannot parse, and what they mean
UNPARSED = {"There was an error parsing the body": "the request body cannot be parsed: JSON must be UTF-8 text, a "
                                                  "form multipart or URL-encoded"}


class FlightChecksFailed(StarletteHTTPException):
    """409: an export of a plan that fails its flight checks; the answer lists them (``violations``)."""

    def __init__(self, detail: str, violations: list[str], headers: dict[str, str] | None = None) -> None:
        super().__init__(409, detail, headers)
        self.violations = violations


def install_error_handlers(app: FastAPI) -> None:
    @app.exception_handler(StarletteHTTPException)
    async def http_error(_request: Request, exc: StarletteHTTPException) -> JSONResponse:
        body: dict = {"detail": UNPARSED.get(str(exc.detail), str(exc.detail))}
        if isinstance(exc, FlightChecksFailed):
            body["violations"] = list(exc.violations)
        return JSONResponse(body, status_code=exc.status_code, headers=exc.headers)

    @app.exception_handler(RequestValidationError)
    async def invalid_request(_request: Request, exc: RequestValidationError) -> JSONResponse:
        return JSONResponse({"detail": validation_message(exc)}, status_code=422)

    @app.exception_handler(SightplanError)
    async def bad_input(_request: Request, exc: SightplanError) -> JSONResponse:
        return JSONResponse({"detail": str(exc)}, status_code=422)

    @app.exception_handler(UploadTooLarge)
    async def too_large(_request: Request, exc: UploadTooLarge) -> JSONResponse:
        return JSONResponse({"detail": str(exc)}, status_code=413)

    @app.exception_handler(OverflowError)
    async def overflow(_request: Request, exc: OverflowError) -> JSONResponse:
        return JSONResponse({"detail": f"a number is out of range: {exc}"}, status_code=422)

    @app.exception_handler(DataError)
    async def out_of_range(_request: Request, exc: DataError) -> JSONResponse:
        return JSONResponse({"detail": f"a value the database cannot hold: {exc.orig}"}, status_code=422)

    @app.exception_handler(Exception)
    async def internal(request: Request, exc: Exception) -> JSONResponse:
        log.exception("internal error on %s %s", request.method, request.url.path)
        return JSONResponse({"detail": f"internal error: {type(exc).__name__}: {exc}"}, status_code=500)


MAX_ID = 2**63 - 1
_WHOLE = re.compile(r"-?[0-9]{1,4300}")


def ids_in_range(request: Request) -> None:
    """An id in the path or the query past what a database integer holds names nothing: 404, not a database error."""
    from fastapi import HTTPException

    for name, value in [*request.path_params.items(), *request.query_params.items()]:
        if not (name.endswith("_id") or name in ("number", "frame", "index")):
            continue
        text = str(value)
        if not _WHOLE.fullmatch(text):  # plain ASCII digits only: int() would read '²' or '١٢' too
            raise HTTPException(422, f"{name}: {text[:40]!r} is not a whole number")
        if abs(int(text)) > MAX_ID:
            raise HTTPException(404, f"{name} {text} not found")
