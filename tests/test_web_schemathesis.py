"""Schemathesis over the team server's OpenAPI document: generated requests to every operation, authenticated with
an API token, must never get a 5xx, and every answer must be one the document describes (its status code, content
type, headers and body schema). Positive requests (valid by the document) and negative ones (invalid: wrong types,
out-of-range numbers, bodies that are not JSON) alike.

Bounded: a few examples per operation and mode. Every other example has its path's ids pointed at real rows (a
project with the Duplex, an orbit plan, its evaluation and a share link), so the generated queries and bodies reach
the code behind the lookups; the rest keep the generated ids. Deletions run last, the project's own at the very end;
the token's own end is left out, so the run cannot revoke the token it runs with. Then the document's links are
followed by Schemathesis' state machine, under the same checks."""

from __future__ import annotations

import pytest

schemathesis = pytest.importorskip("schemathesis")

from fastapi.testclient import TestClient  # noqa: E402
from hypothesis import HealthCheck, Phase, given, settings  # noqa: E402
from hypothesis.errors import Unsatisfiable  # noqa: E402
from schemathesis import GenerationMode  # noqa: E402
from schemathesis.specs.openapi.checks import (  # noqa: E402
    content_type_conformance,
    response_headers_conformance,
    response_schema_conformance,
    status_code_conformance,
)

from sightplan.model.load import sample_model_path  # noqa: E402
from sightplan.plan.templates import spacing  # noqa: E402
from sightplan.web.app import create_app  # noqa: E402
from sightplan.web.config import ServerConfig  # noqa: E402
from test_web_access import PAGE, add_user, login  # noqa: E402
from web_support import wait_job  # noqa: E402

EXAMPLES = 8
NEGATIVE_EXAMPLES = 3  # each refused before any work: 422, or 400 for a body that cannot be parsed
# the token's own end (logout, password change, token revocation) is covered by test_web_access
SKIPPED = ("/api/auth/logout", "/api/auth/password", "/api/auth/tokens/{token_id}")
# every answer is one the document describes (a 5xx is reported on its own, with its message)
CHECKS = [status_code_conformance, content_type_conformance, response_schema_conformance, response_headers_conformance]


@pytest.fixture(scope="module")
def team(tmp_path_factory):
    """A team server with Alice's project, her token and real ids for every path parameter, and a template budget
    small enough that generated template parameters build their plans in moments (the refusal above it is what is
    exercised)."""
    data = tmp_path_factory.mktemp("fuzz") / "data"
    add_user(data, "alice")
    budget = spacing.MAX_TEMPLATE_FRAMES
    spacing.MAX_TEMPLATE_FRAMES = 500
    app = create_app(ServerConfig(data_dir=data, team=True, workers=1))
    try:
        with TestClient(app, headers=PAGE) as c:
            login(c, "alice")
            pid = c.post("/api/projects", json={"name": "site"}).json()["id"]
            with open(sample_model_path(), "rb") as fh:
                r = c.post(f"/api/projects/{pid}/models", files={"file": ("duplex.ifc", fh)})
            assert wait_job(c, r.json()["job"]["id"])["status"] == "done"
            mid = r.json()["model"]["id"]
            plan = c.post(f"/api/projects/{pid}/plans", json={"model_id": mid, "template": "orbit", "radius_m": [25],
                                                              "height_m": [8.0], "step_deg": 60}).json()["id"]
            r = c.post(f"/api/projects/{pid}/evaluations", json={"plan_id": plan, "settings": {"scale": 0.04}})
            job = r.json()["job"]["id"]
            assert wait_job(c, job)["status"] == "done"
            link = c.post(f"/api/projects/{pid}/plans/{plan}/links", json={}).json()
            me = c.get(f"/api/projects/{pid}/members").json()[0]["user_id"]
            token = c.post("/api/auth/tokens", json={"name": "fuzz"}).json()["token"]
            c.cookies.clear()
            ids = {"project_id": pid, "model_id": mid, "plan_id": plan, "number": 1, "evaluation_id":
                   r.json()["evaluation"]["id"], "job_id": job, "link_id": link["id"], "token": link["token"],
                   "user_id": me, "frame": 0, "index": 0}
            yield app, token, ids
    finally:
        spacing.MAX_TEMPLATE_FRAMES = budget


def _check(case, response, request: str, auth: dict, failures: dict[str, list[str]]) -> None:
    """Record a 5xx under "server errors", else every check :data:`CHECKS` fails under "violations"."""
    if response.status_code >= 500:
        failures["server errors"].append(f"{request}: {response.text[:200]}")
        return
    try:
        case.validate_response(response, checks=CHECKS, headers=auth)
    except BaseExceptionGroup as group:
        failures["violations"] += [f"{request}: {f.title}: {' '.join(str(f.message).split())[:300]}"
                                   for f in group.exceptions]


def _order(operation) -> tuple[int, int]:
    """Reads and changes first, deletions after them, the project's deletion last."""
    return (operation.method.upper() == "DELETE", operation.path == "/api/projects/{project_id}")


def _fuzz(operation, auth: dict, ids: dict, failures: dict[str, list[str]]) -> tuple[set[int], int]:
    """Send EXAMPLES valid and NEGATIVE_EXAMPLES invalid generated requests to one operation and check each answer;
    the status codes it answered and the number of requests."""
    seen: set[int] = set()
    count = [0]
    for mode, examples in ((GenerationMode.POSITIVE, EXAMPLES), (GenerationMode.NEGATIVE, NEGATIVE_EXAMPLES)):
        if not examples:
            continue
        try:
            _cases(operation, mode, examples, auth, ids, failures, seen, count)
        except Unsatisfiable:  # nothing of it can be invalid (no parameter, no body)
            assert mode is GenerationMode.NEGATIVE
    return seen, count[0]


def _cases(operation, mode, examples: int, auth: dict, ids: dict, failures: dict[str, list[str]], seen: set[int],
           count: list[int]) -> None:
    @given(case=operation.as_strategy(generation_mode=mode))
    @settings(max_examples=examples, deadline=None, derandomize=True, database=None,
              suppress_health_check=list(HealthCheck), phases=[Phase.explicit, Phase.generate])
    def call(case):
        count[0] += 1
        if count[0] % 2 and case.path_parameters:  # real rows behind the path
            case.path_parameters = {k: ids.get(k, v) for k, v in case.path_parameters.items()}
        response = case.call(headers=auth)
        seen.add(response.status_code)
        request = f"{mode.value} {case.method} {case.formatted_path} {case.query or ''} → {response.status_code}"
        _check(case, response, request, auth, failures)

    call()


def test_the_documents_links_name_real_fields_and_lead_somewhere(team):
    """Every link of the document names an operation it has and takes its values from fields the answer has (the
    document is built to refuse otherwise); following one by hand reads what was made."""
    app, token, ids = team
    doc = app.openapi()
    ops = {op["operationId"]: (path, method) for path, item in doc["paths"].items() for method, op in item.items()}
    links = {(path, method, name): link for path, item in doc["paths"].items() for method, op in item.items()
             for answer in op["responses"].values() for name, link in answer.get("links", {}).items()}
    assert len(links) > 60 and all(link["operationId"] in ops for link in links.values())
    made = links[("/api/projects", "post", ops_id(doc, "get", "/api/projects/{project_id}"))]
    assert made["parameters"] == {"project_id": "$response.body#/id"}
    plan = links[("/api/projects/{project_id}/plans", "post",
                  ops_id(doc, "get", "/api/projects/{project_id}/plans/{plan_id}/versions/{number}"))]
    assert plan["parameters"] == {"project_id": "$request.path.project_id", "plan_id": "$response.body#/id",
                                  "number": "$response.body#/latest_version"}


def ops_id(doc: dict, method: str, path: str) -> str:
    return doc["paths"][path][method]["operationId"]


def test_no_generated_request_gets_a_server_error_or_an_undocumented_answer(team):
    app, token, ids = team
    schema = schemathesis.openapi.from_asgi("/openapi.json", app)
    schema.config.generation.update(with_security_parameters=False)  # every request carries the token below
    auth = {"Authorization": f"Bearer {token}"}
    failures: dict[str, list[str]] = {"server errors": [], "violations": []}
    operations = sorted((r.ok() for r in schema.get_all_operations()), key=_order)
    runs = {f"{op.method.upper()} {op.path}": _fuzz(op, auth, ids, failures)
            for op in operations if op.path not in SKIPPED}
    statuses = {op: codes for op, (codes, _) in runs.items()}
    cases = sum(n for _, n in runs.values())
    assert len(statuses) > 60  # every operation was called
    answered = {op for op, codes in statuses.items() if codes & {200, 201, 202, 204, 409, 413, 415, 422}}
    assert len(answered) > 40, sorted(statuses.items())  # most got past the lookups, not only a 404
    assert schema["/api/auth/me"]["GET"].Case().call(headers=auth).status_code == 200  # the token still works
    print(f"{cases} requests: {len(failures['server errors'])} server errors, {len(failures['violations'])} "
          "answers the document does not describe")
    assert failures == {"server errors": [], "violations": []}, \
        "\n".join(f"{kind}: {line}" for kind, lines in failures.items() for line in lines[:20])


def test_following_the_links_gets_no_server_error_or_an_undocumented_answer(team):
    """Schemathesis' state machine over the document's links: scenarios that make a project, then its plans,
    evaluations, members and links, and read, change and delete them with the ids the answers gave (and now and
    then an unknown id). Bounded: a few scenarios of a few steps. It runs after the test above, whose rows it may
    delete."""
    app, token, ids = team
    schema = schemathesis.openapi.from_asgi("/openapi.json", app).exclude(path=list(SKIPPED))
    schema.config.generation.update(with_security_parameters=False)
    auth = {"Authorization": f"Bearer {token}"}
    failures: dict[str, list[str]] = {"server errors": [], "violations": []}
    calls: list[str] = []

    class Links(schema.as_state_machine()):
        def get_call_kwargs(self, case):
            return {"headers": auth}

        def validate_response(self, response, case, additional_checks=None, **kwargs):
            request = f"{case.method} {case.formatted_path} → {response.status_code}"
            calls.append(request)
            _check(case, response, request, auth, failures)

    assert schema.statistic.transitions.total > 60
    Links.run(settings=settings(max_examples=25, stateful_step_count=6, deadline=None, derandomize=True,
                                database=None, suppress_health_check=list(HealthCheck), phases=[Phase.generate]))
    followed = [c for c in calls if "/{" not in c]
    print(f"{len(calls)} linked requests: {len(failures['server errors'])} server errors, "
          f"{len(failures['violations'])} answers the document does not describe")
    assert len(calls) > 20 and any(c.startswith("POST /api/projects →") for c in followed)
    assert failures == {"server errors": [], "violations": []}, \
        "\n".join(f"{kind}: {line}" for kind, lines in failures.items() for line in lines[:20])
    assert schema["/api/auth/me"]["GET"].Case().call(headers=auth).status_code == 200  # the token still works
