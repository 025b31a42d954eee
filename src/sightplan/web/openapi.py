"""The OpenAPI document as the server behaves: the mode it runs in, how to log in (team mode), and one error model,
``{"detail": "one message"}``, on every error an operation can answer."""

from __future__ import annotations

import re
from typing import Any

from fastapi import FastAPI
from fastapi.routing import APIRoute

from .deps import SESSION_COOKIE, current_user, editable_project, owned_project, project_access

SUMMARY = """\
sightplan's REST API: upload building models, make capture plans from templates or files, edit them as versions,
evaluate them (VC, V̄C, VR, R, O, T) in the background, and download reports and flight-app exports.
"""
SINGLE_USER = """\
**Single-user mode**: the server answers on its loopback address only (a request to another `Host` gets 400) and
asks for no login; anyone on this machine can use it.
"""
TEAM = """\
**Team mode**: every request but logging in, `/api/info`, the catalogues and share links needs a login: the session
cookie that `POST /api/auth/login` sets, or an API token (`POST /api/auth/tokens`) sent as
`Authorization: Bearer <token>`. **Authorize** on this page takes a token. You see the projects you are a member of,
with a role in each: a *viewer* reads, an *editor* also changes its models, plans, evaluations and share links, an
*owner* also renames or deletes it and manages its members. A share link (`/api/shared/{token}`) reads one plan
without a login.
"""
ERRORS = """\
Every error is JSON `{"detail": "one message"}` (`ErrorOut`); an export refused for its flight checks (409) adds
`violations`, one sentence each.
"""
ERROR_REF = {"$ref": "#/components/schemas/ErrorOut"}
SECURITY_SCHEMES = {
    "session": {"type": "apiKey", "in": "cookie", "name": SESSION_COOKIE,
                "description": "The login session that `POST /api/auth/login` sets (14 days). A change made with it "
                               "(any method but GET, HEAD, OPTIONS) must come from a page of this server (its "
                               "`Origin`) or carry the header `X-Sightplan-Request` as sightplan's page does; "
                               "scripts use an API token instead. A browser sends the cookie by itself (a value typed "
                               "here is not sent): log in on this page with `POST /api/auth/login`."},
    "token": {"type": "http", "scheme": "bearer",
              "description": "An API token from `POST /api/auth/tokens`, sent as `Authorization: Bearer <token>` "
                             "until it is revoked."},
}
LOGIN = [{"session": []}, {"token": []}]
CHANGES = ("post", "put", "patch", "delete")
ID_NAMES = ("number", "frame", "index")  # besides *_id: looked up, and past a database integer answer 404
P = "/api/projects/{project_id}"
# what each operation that makes something answers, as the path parameters of the operations that read, change or
# delete it: the document's links (OpenAPI 3 ``links``), so a client, and a stateful fuzzer, can follow them
PRODUCES: dict[tuple[str, str], dict[str, str]] = {
    ("post", "/api/projects"): {"project_id": "/id"},
    ("post", f"{P}/models"): {"model_id": "/model/id", "job_id": "/job/id"},
    ("post", f"{P}/plans"): {"plan_id": "/id", "number": "/latest_version"},
    ("post", f"{P}/plans/upload"): {"plan_id": "/id", "number": "/latest_version"},
    ("put", f"{P}/plans/{{plan_id}}"): {"number": "/latest_version"},
    ("post", f"{P}/plans/optimize"): {"job_id": "/id"},
    ("post", f"{P}/evaluations"): {"evaluation_id": "/evaluation/id", "job_id": "/job/id"},
    ("post", f"{P}/members"): {"user_id": "/user_id"},
    ("post", f"{P}/plans/{{plan_id}}/links"): {"link_id": "/id", "token": "/token"},
    ("post", f"{P}/schedules"): {"schedule_id": "/schedule/id", "job_id": "/job/id"},
    ("post", f"{P}/reality"): {"reality_id": "/reality/id", "job_id": "/job/id"},
    ("post", "/api/auth/tokens"): {"token_id": "/id"},
}


def description(team: bool) -> str:
    """The document's description: what the API does, the mode the server runs in, the error model."""
    return "\n".join((SUMMARY, TEAM if team else SINGLE_USER, ERRORS))


def install_document(app: FastAPI, routes: list, team: bool) -> None:
    """Make ``app``'s ``/openapi.json`` the document of :func:`honest_document` for ``routes`` (those of its
    routers), built once."""

    def openapi() -> dict[str, Any]:
        if app.openapi_schema is None:
            app.openapi_schema = honest_document(FastAPI.openapi(app), routes, team)
        return app.openapi_schema

    app.openapi = openapi  # type: ignore[method-assign]


def _calls(dependant) -> set:
    """Every function the dependencies of a route call, at any depth."""
    out = set()
    for dep in dependant.dependencies:
        out.add(dep.call)
        out |= _calls(dep)
    return out


def honest_document(doc: dict[str, Any], routes: list, team: bool) -> dict[str, Any]:
    """FastAPI's document with the errors each operation can answer, all as ``ErrorOut`` (FastAPI's 422 schema
    describes an array the server never sends), and, in team mode, the login's security schemes on the operations
    that need one."""
    for route in routes:
        if not isinstance(route, APIRoute) or not route.include_in_schema:
            continue
        calls = _calls(route.dependant)
        if "current_user" in route.endpoint.__code__.co_names:  # called in the route itself (an event stream)
            calls.add(current_user)
        for method in route.methods:
            op = doc["paths"].get(route.path_format, {}).get(method.lower())
            if op is not None:
                _errors(op, method.lower(), calls, team, "require_user" in route.endpoint.__code__.co_names)
                if team and current_user in calls:
                    op["security"] = LOGIN
    schemas = doc.setdefault("components", {}).setdefault("schemas", {})
    add_links(doc)
    schemas.pop("HTTPValidationError", None)
    schemas.pop("ValidationError", None)
    if team:
        doc["components"]["securitySchemes"] = SECURITY_SCHEMES
    return doc


OTHER_HOST = "a request addressed to another `Host` than the loopback address"
UNPARSED = "a body that cannot be parsed (a form, or JSON that is not UTF-8 text)"
NOT_LOGGED_IN = "not logged in, or an unknown, revoked or expired session or token"
CROSS_SITE = "a change sent by a page of another site"
CROSS_SITE_TEAM = f"{CROSS_SITE}, or with the session cookie but without the header `X-Sightplan-Request`"
ROLE = "your role in the project does not allow it"
NO_SUCH = "no such resource (or not in a project of yours), or an id past the range of ids"
NO_ACCOUNTS = "single-user mode has no accounts"
TOO_LARGE = "the body is over the server's upload limit (`sightplan serve --max-upload-mb`)"
INVALID = "invalid parameters or body: the first few problems, in one message"
ROLE_WORDS = re.compile(r"role|owner|viewer", re.I)
# the causes added to a route's own description of a code
ADDED = (OTHER_HOST, UNPARSED, CROSS_SITE, CROSS_SITE_TEAM, ROLE, NO_ACCOUNTS, INVALID)


def _errors(op: dict[str, Any], method: str, calls: set, team: bool, accounts_only: bool) -> None:
    """Document on ``op`` each error it can answer. A code the route declares keeps its description, with the causes
    that apply to every operation of its kind added."""
    params = op.get("parameters", [])
    body = op.get("requestBody", {}).get("content", {})
    looked_up = any(p["in"] == "path" or p["name"].endswith("_id") or p["name"] in ID_NAMES for p in params)
    login = team and current_user in calls
    causes = {
        400: [OTHER_HOST] * (not team) + [UNPARSED] * bool(body),
        401: [NOT_LOGGED_IN] * login,
        403: [CROSS_SITE_TEAM if team else CROSS_SITE] * (method in CHANGES)
             + [ROLE] * bool(team and (calls & {editable_project, owned_project}
                                        or method in CHANGES and project_access in calls)),
        404: [NO_SUCH] * looked_up + [NO_ACCOUNTS] * (not team and accounts_only),
        413: [TOO_LARGE] * bool(body),
        422: [INVALID] * bool(params or body),
    }
    responses = op.setdefault("responses", {})
    for code, found in causes.items():
        key = str(code)
        declared = responses.get(key, {}).get("description", "")
        if declared == "Validation Error":  # FastAPI's own
            declared = ""
        if declared:  # the route's own words; causes of its kind that they do not cover yet are added
            found = [c for c in found if c in ADDED and not (c == ROLE and ROLE_WORDS.search(declared))]
        text = "; or ".join([declared] * bool(declared) + found)
        if text:
            responses.setdefault(key, {})["description"] = text[0].upper() + text[1:]
    op["responses"] = responses = dict(sorted(responses.items()))
    for key, response in responses.items():
        if key[0] in "45":
            response.setdefault("content", {}).setdefault("application/json", {})["schema"] = ERROR_REF
    if login:
        responses["401"]["headers"] = {"WWW-Authenticate": {"description": "`Bearer`", "schema": {"type": "string"}}}


def _path_names(path: str) -> set[str]:
    return set(re.findall(r"{(\w+)}", path))


def _field(doc: dict[str, Any], schema: dict[str, Any], pointer: str) -> bool:
    """Whether the JSON pointer ``pointer`` names a property of ``schema`` (its ``$ref`` followed)."""
    for key in pointer.strip("/").split("/"):
        while "$ref" in schema:
            schema = doc["components"]["schemas"][schema["$ref"].rsplit("/", 1)[-1]]
        schema = schema.get("properties", {}).get(key)
        if schema is None:
            return False
    return True


def add_links(doc: dict[str, Any]) -> None:
    """On each success answer of :data:`PRODUCES`, a link to every operation whose path parameters it supplies (at
    least one of them made by it, the others taken from its own path), named by that operation's id."""
    for (method, path), made in PRODUCES.items():
        op = doc["paths"].get(path, {}).get(method)
        if op is None:
            raise KeyError(f"the document has no {method.upper()} {path} to link from")
        code, answer = next((k, r) for k, r in op["responses"].items() if k.startswith("2"))
        schema = answer.get("content", {}).get("application/json", {}).get("schema", {})
        missing = [pointer for pointer in made.values() if not _field(doc, schema, pointer)]
        if missing:
            raise KeyError(f"{method.upper()} {path} answers no {', '.join(missing)} to link with")
        own = _path_names(path)
        links = {}
        for target_path, target_ops in doc["paths"].items():
            names = _path_names(target_path)
            if not names & made.keys() or not names <= own | made.keys():
                continue
            for target_method, target in target_ops.items():
                if (target_method, target_path) == (method, path):
                    continue
                links[target["operationId"]] = {
                    "operationId": target["operationId"],
                    "parameters": {name: (f"$response.body#{made[name]}" if name in made else f"$request.path.{name}")
                                   for name in sorted(names)},
                }
        if links:
            answer["links"] = dict(sorted(links.items()))
