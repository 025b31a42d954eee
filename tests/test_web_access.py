"""Team mode of ``sightplan serve``: accounts, roles, share links and tokens.

Every route under ``/api/projects/{project_id}`` is enumerated from the server's OpenAPI document, so a route added later is
checked too: a non-member gets 404 on all of them, a viewer 403 on every one that changes something.
"""

from __future__ import annotations

import re
from pathlib import Path

import pytest

pytest.importorskip("fastapi")
pytest.importorskip("argon2")

from fastapi.testclient import TestClient  # noqa: E402
from sqlalchemy import create_engine, text  # noqa: E402
from typer.testing import CliRunner  # noqa: E402

from sightplan.cli.main import app as cli  # noqa: E402
from sightplan.model.load import sample_model_path  # noqa: E402
from sightplan.web.app import create_app  # noqa: E402
from sightplan.web.config import ServerConfig  # noqa: E402
from web_support import wait_job  # noqa: E402

PASSWORDS = {"alice": "alice-secret-1", "bob": "bob-secret-22", "carol": "carol-secret-333"}


def add_user(data: Path, name: str) -> None:
    result = CliRunner().invoke(cli, ["users", "add", name, "--data", str(data), "--password-stdin"],
                                input=PASSWORDS[name] + "\n")
    assert result.exit_code == 0, result.output


PAGE = {"X-Sightplan-Request": "1"}  # the header sightplan's page sends with every request


def login(client: TestClient, name: str) -> TestClient:
    """Log ``client`` in as ``name``; its later changes carry the page's header, as the page's do."""
    client.cookies.clear()
    client.headers.update(PAGE)
    r = client.post("/api/auth/login", json={"username": name, "password": PASSWORDS[name]})
    assert r.status_code == 200, r.text
    return client




@pytest.fixture(scope="module")
def data(tmp_path_factory) -> Path:
    d = tmp_path_factory.mktemp("team") / "data"
    for name in PASSWORDS:
        add_user(d, name)
    return d


@pytest.fixture(scope="module")
def server(data):
    """A team server; the client logs in as whoever a test needs."""
    with TestClient(create_app(ServerConfig(data_dir=data, team=True)), headers=PAGE) as c:
        yield c


@pytest.fixture(scope="module")
def alices(server) -> dict[str, int]:
    """Alice's project with the Duplex, an orbit plan (26 m out: its legs keep 10 m at a GNSS drone's position
    error), its evaluation and a share link: real ids for every route."""
    c = login(server, "alice")
    pid = c.post("/api/projects", json={"name": "Alice's site"}).json()["id"]
    with open(sample_model_path(), "rb") as fh:
        r = c.post(f"/api/projects/{pid}/models", files={"file": ("duplex.ifc", fh)})
    assert r.status_code == 202, r.text
    assert wait_job(c, r.json()["job"]["id"])["status"] == "done"
    mid = r.json()["model"]["id"]
    r = c.post(f"/api/projects/{pid}/plans", json={"model_id": mid, "template": "orbit", "radius_m": [26],
                                                   "height_m": [8.0], "step_deg": 60})
    assert r.status_code == 201, r.text
    plan = r.json()["id"]
    r = c.post(f"/api/projects/{pid}/evaluations", json={"plan_id": plan, "settings": {"scale": 0.04}})
    assert r.status_code == 202, r.text
    job = r.json()["job"]["id"]
    assert wait_job(c, job)["status"] == "done"
    return {"project_id": pid, "model_id": mid, "plan_id": plan, "evaluation_id": r.json()["evaluation"]["id"],
            "job_id": job}


def project_routes(client: TestClient) -> list[tuple[str, str]]:
    """Every (method, path) under a project, from the server's own OpenAPI document."""
    paths = client.get("/openapi.json").json()["paths"]
    return [(method.upper(), path) for path, ops in sorted(paths.items()) if path.startswith("/api/projects/{project_id}")
            for method in sorted(ops)]


def fill(path: str, ids: dict[str, int]) -> str:
    values = {**ids, "number": 1, "user_id": 1, "link_id": 1, "frame": 0, "element": 0}
    return re.sub(r"\{(\w+)\}", lambda m: str(values.get(m.group(1), 1)), path)


def call(client: TestClient, method: str, url: str):
    kwargs = {"json": {}} if method in ("POST", "PUT", "PATCH") else {}
    return client.request(method, url, **kwargs)


# --------------------------------------------------------------------------- logging in
def test_info_says_team_mode_and_nothing_answers_without_login(server, data):
    server.cookies.clear()
    info = server.get("/api/info").json()
    assert info["mode"] == "team" and info["login"] is True and info["data_dir"] == ""
    for url in ("/api/projects", "/api/jobs", "/api/auth/me", "/api/projects/1", "/api/projects/1/plans"):
        r = server.get(url)
        assert r.status_code == 401 and "log in" in r.json()["detail"], url
    assert server.post("/api/projects", json={"name": "x"}).status_code == 401


def test_passwords_are_stored_as_argon2_hashes(server, data):
    engine = create_engine(f"sqlite:///{data / 'sightplan.db'}")
    with engine.connect() as conn:
        rows = dict(conn.execute(text("SELECT username, password_hash FROM users")).all())
    engine.dispose()
    assert set(rows) == set(PASSWORDS)
    for name, hashed in rows.items():
        assert hashed.startswith("$argon2id$") and PASSWORDS[name] not in hashed


def test_wrong_password_and_unknown_user_are_refused_alike(server):
    server.cookies.clear()
    for body in ({"username": "alice", "password": "wrong-password"}, {"username": "nobody", "password": "x" * 12}):
        r = server.post("/api/auth/login", json=body)
        assert r.status_code == 401 and r.json()["detail"] == "wrong user name or password"
    assert server.get("/api/projects").status_code == 401


def test_login_cookie_me_and_logout(server, alices):
    c = login(server, "alice")
    cookie = c.cookies.get("sightplan_session")
    assert cookie and cookie.startswith("sps_")
    me = c.get("/api/auth/me").json()
    assert me["username"] == "alice" and me["projects"] == {str(alices["project_id"]): "owner"}
    out = c.post("/api/auth/logout")
    assert out.status_code == 204
    deletion = out.headers["set-cookie"].lower()  # deleted with the attributes it was set with
    assert "max-age=0" in deletion and "samesite=strict" in deletion and "httponly" in deletion
    c.cookies.set("sightplan_session", cookie)  # the old cookie, replayed after logout
    assert c.get("/api/projects").status_code == 401


# --------------------------------------------------------------------------- the API's description
JSON_TYPES = {"string": str, "array": list, "object": dict}


def conforms(value, schema: dict) -> bool:
    """The little of JSON Schema the error model uses: types, required keys, known properties, array items."""
    if not isinstance(value, JSON_TYPES[schema["type"]]):
        return False
    if schema["type"] == "object":
        props = schema.get("properties", {})
        return set(schema.get("required", ())) <= set(value) and all(k in props and conforms(v, props[k])
                                                                     for k, v in value.items())
    return schema["type"] != "array" or all(conforms(v, schema["items"]) for v in value)


def documented(doc: dict, path: str, method: str, status: int) -> dict:
    """The body schema the document gives for an answer, its reference resolved."""
    ref = doc["paths"][path][method]["responses"][str(status)]["content"]["application/json"]["schema"]["$ref"]
    return doc["components"]["schemas"][ref.rsplit("/", 1)[1]]


def test_the_team_api_document_has_its_login_and_the_errors_as_sent(server):
    doc = server.get("/openapi.json").json()
    assert "Team mode" in doc["info"]["description"] and "Single-user" not in doc["info"]["description"]
    session, token = doc["components"]["securitySchemes"]["session"], doc["components"]["securitySchemes"]["token"]
    assert (session["type"], session["in"], session["name"]) == ("apiKey", "cookie", "sightplan_session")
    assert "`X-Sightplan-Request`" in session["description"]  # changes with the cookie need the page's header
    assert (token["type"], token["scheme"]) == ("http", "bearer")
    assert doc["paths"]["/api/projects"]["get"]["security"] == [{"session": []}, {"token": []}]
    for path, method in (("/api/auth/login", "post"), ("/api/info", "get"), ("/api/shared/{token}", "get")):
        assert not doc["paths"][path][method].get("security"), path
    assert "HTTPValidationError" not in doc["components"]["schemas"]
    server.cookies.clear()
    r = server.get("/api/projects")
    assert r.status_code == 401 and conforms(r.json(), documented(doc, "/api/projects", "get", 401))
    c = login(server, "carol")
    r = c.post("/api/projects", json={})
    assert r.status_code == 422 and isinstance(r.json()["detail"], str)
    assert conforms(r.json(), documented(doc, "/api/projects", "post", 422))
    r = c.get("/api/projects/999999")
    assert r.status_code == 404 and conforms(r.json(), documented(doc, "/api/projects/{project_id}", "get", 404))


def test_the_single_user_api_document_asks_for_no_login(tmp_path):
    with TestClient(create_app(ServerConfig(data_dir=tmp_path / "data"))) as c:
        doc = c.get("/openapi.json").json()
    assert "Single-user mode" in doc["info"]["description"] and "Team mode" not in doc["info"]["description"]
    assert "securitySchemes" not in doc["components"]
    assert not any("security" in op for ops in doc["paths"].values() for op in ops.values())


# --------------------------------------------------------------------------- projects are their members' only
def test_non_member_gets_404_on_every_project_route(server, alices):
    c = login(server, "carol")
    routes = project_routes(c)
    assert len(routes) >= 25  # every project route of the API, whatever is added later
    for method, path in routes:
        r = call(c, method, fill(path, alices))
        assert r.status_code == 404, (method, path, r.status_code, r.text)
    assert c.get("/api/projects").json() == []
    assert all(j["project_id"] != alices["project_id"] for j in c.get("/api/jobs").json())
    assert c.get(f"/api/jobs/{alices['job_id']}").status_code == 404
    assert c.get(f"/api/jobs/{alices['job_id']}/events").status_code == 404
    assert c.post(f"/api/jobs/{alices['job_id']}/cancel").status_code == 404


def test_viewer_reads_but_cannot_change_anything(server, alices):
    pid = alices["project_id"]
    owner = login(server, "alice")
    r = owner.post(f"/api/projects/{pid}/members", json={"username": "bob", "role": "viewer"})
    assert r.status_code == 201 and r.json()["role"] == "viewer"
    try:
        c = login(server, "bob")
        assert [p["id"] for p in c.get("/api/projects").json()] == [pid]
        assert c.get(f"/api/projects/{pid}").json()["role"] == "viewer"
        m = c.get(f"/api/projects/{pid}/evaluations/{alices['evaluation_id']}").json()["metrics"]
        assert m["frames"] == 6
        assert c.get(f"/api/jobs/{alices['job_id']}").status_code == 200
        assert c.post(f"/api/jobs/{alices['job_id']}/cancel").status_code == 403
        changing = [(m, p) for m, p in project_routes(c) if m in ("POST", "PUT", "PATCH", "DELETE")]
        assert len(changing) >= 10
        for method, path in changing:
            if method == "DELETE" and path.endswith("/members/{user_id}"):
                continue  # leaving the project is a viewer's own right (tested below)
            r = call(c, method, fill(path, alices))
            assert r.status_code == 403, (method, path, r.status_code, r.text)
            assert "viewer" in r.json()["detail"]
        # everything is still there
        login(server, "alice")
        assert len(server.get(f"/api/projects/{pid}/plans/{alices['plan_id']}").json()["versions"]) == 1
        assert server.get(f"/api/projects/{pid}/models/{alices['model_id']}").status_code == 200
    finally:
        login(server, "alice")
        bob_id = next(u["user_id"] for u in server.get(f"/api/projects/{pid}/members").json() if u["username"] == "bob")
        assert server.delete(f"/api/projects/{pid}/members/{bob_id}").status_code == 204


def test_editor_edits_but_only_an_owner_manages_the_project(server, alices):
    pid, plan = alices["project_id"], alices["plan_id"]
    owner = login(server, "alice")
    assert owner.post(f"/api/projects/{pid}/members", json={"username": "bob", "role": "editor"}).status_code == 201
    members = {u["username"]: u["user_id"] for u in owner.get(f"/api/projects/{pid}/members").json()}
    c = login(server, "bob")
    version = c.get(f"/api/projects/{pid}/plans/{plan}/versions/1").json()
    version["frames"] = version["frames"][:-1]
    version.pop("missions", None)
    r = c.put(f"/api/projects/{pid}/plans/{plan}?note=one+frame+less", json=version)
    assert r.status_code == 201 and len(r.json()["versions"]) == 2
    for method, url, body in (("PATCH", f"/api/projects/{pid}", {"name": "mine now"}),
                              ("DELETE", f"/api/projects/{pid}", None),
                              ("POST", f"/api/projects/{pid}/members", {"username": "carol", "role": "owner"}),
                              ("PATCH", f"/api/projects/{pid}/members/{members['bob']}", {"role": "owner"})):
        r = c.request(method, url, json=body)
        assert r.status_code == 403 and "owner" in r.json()["detail"], (method, url)
    # the last owner cannot step down
    owner = login(server, "alice")
    r = owner.patch(f"/api/projects/{pid}/members/{members['alice']}", json={"role": "editor"})
    assert r.status_code == 409 and "only owner" in r.json()["detail"]
    assert owner.delete(f"/api/projects/{pid}/members/{members['bob']}").status_code == 204
    assert login(server, "bob").get(f"/api/projects/{pid}").status_code == 404


# --------------------------------------------------------------------------- share links and API tokens
def test_share_link_reads_the_plan_until_revoked(server, alices):
    pid, plan = alices["project_id"], alices["plan_id"]
    c = login(server, "alice")
    r = c.post(f"/api/projects/{pid}/plans/{plan}/links")
    assert r.status_code == 201
    link = r.json()
    assert link["url"].endswith(f"/shared/{link['token']}") and "/api/" not in link["url"]
    assert link["api_url"].endswith(f"/api/shared/{link['token']}")
    c.cookies.clear()  # the link needs no account
    page = c.get(link["url"])  # the share view: the page, which reads the JSON below
    assert page.status_code == 200 and page.headers["content-type"].startswith("text/html")
    shared = c.get(f"/api/shared/{link['token']}")
    assert shared.status_code == 200 and shared.json()["plan"]["id"] == plan
    assert [e["id"] for e in shared.json()["evaluations"]] == [alices["evaluation_id"]]
    frames = c.get(f"/api/shared/{link['token']}/versions/1").json()["frames"]
    assert len(frames) == 6
    ev = c.get(f"/api/shared/{link['token']}/evaluations/{alices['evaluation_id']}")
    assert ev.status_code == 200 and ev.json()["metrics"]["frames"] == 6
    assert c.get(f"/api/shared/{link['token']}/versions/1/export?format=geojson").status_code == 200
    # what the share view reads: the plan's model, version geometry and checks, the evaluation's feedback
    base = f"/api/shared/{link['token']}"
    model = shared.json()["model"]["id"]
    assert c.get(f"{base}/models/{model}/geometry").content[:4] == b"SPG1"
    assert c.get(f"{base}/models/{model}/site").json()["georeferenced"]
    assert len(c.get(f"{base}/plans/{plan}/versions/1/geometry").json()["position"]) == 6
    assert c.get(f"{base}/plans/{plan}/versions/1/checks").json()["plan_id"] == plan
    assert len(c.get(f"{base}/evaluations/{alices['evaluation_id']}/feedback").json()["frames"]["stable"]) == 6
    assert [e["id"] for e in c.get(f"{base}/evaluations").json()] == [alices["evaluation_id"]]
    # the link opens nothing else: not another model, plan or evaluation id, not the project
    for url in (f"/models/{model + 1}/geometry", f"/plans/{plan + 1}/versions/1/geometry",
                f"/evaluations/{alices['evaluation_id'] + 1}/feedback"):
        assert c.get(base + url).status_code == 404, url
    assert c.get(f"/api/projects/{pid}").status_code == 401
    assert c.get(f"/api/shared/{link['token']}x").status_code == 404
    # revoked: it stops working at once
    c = login(server, "alice")
    assert c.delete(f"/api/projects/{pid}/links/{link['id']}").status_code == 204
    assert c.get(f"/api/projects/{pid}/links").json()[0]["revoked_at"] is not None
    c.cookies.clear()
    for url in ("", "/versions/1", f"/evaluations/{alices['evaluation_id']}", "/versions/1/export?format=qgc",
                f"/plans/{plan}/versions/1/geometry", f"/models/{model}/site"):
        r = c.get(f"/api/shared/{link['token']}{url}")
        assert r.status_code == 404 and "revoked" in r.json()["detail"], url


def test_password_change_ends_sessions_but_not_tokens(tmp_path):
    data = tmp_path / "d"
    add_user(data, "carol")
    with TestClient(create_app(ServerConfig(data_dir=data, team=True)), headers=PAGE) as c:
        login(c, "carol")
        token = c.post("/api/auth/tokens", json={"name": "script"}).json()["token"]
        cookie = c.cookies.get("sightplan_session")
        wrong = c.post("/api/auth/password", json={"old_password": "nope", "new_password": "carol-new-secret"})
        assert wrong.status_code == 403 and "current password is wrong" in wrong.json()["detail"]
        short = c.post("/api/auth/password", json={"old_password": PASSWORDS["carol"], "new_password": "short"})
        assert short.status_code == 422 and "8 characters" in short.json()["detail"]
        ok = c.post("/api/auth/password", json={"old_password": PASSWORDS["carol"], "new_password": "carol-new-secret"})
        assert ok.status_code == 204
        c.cookies.clear()
        c.cookies.set("sightplan_session", cookie)
        assert c.get("/api/auth/me").status_code == 401  # the session ended
        c.cookies.clear()
        assert c.get("/api/auth/me", headers={"Authorization": f"Bearer {token}"}).json()["username"] == "carol"
        assert c.post("/api/auth/login", json={"username": "carol", "password": PASSWORDS["carol"]}).status_code == 401
        assert c.post("/api/auth/login", json={"username": "carol", "password": "carol-new-secret"}).status_code == 200


def test_api_token_works_as_bearer_until_revoked(server, alices):
    c = login(server, "alice")
    r = c.post("/api/auth/tokens", json={"name": "nightly script"})
    assert r.status_code == 201
    token = r.json()
    assert token["token"].startswith("spt_") and "token" not in c.get("/api/auth/tokens").json()[0]
    c.cookies.clear()
    bearer = {"Authorization": f"Bearer {token['token']}"}
    assert [p["id"] for p in c.get("/api/projects", headers=bearer).json()] == [alices["project_id"]]
    assert login(server, "bob").delete(f"/api/auth/tokens/{token['id']}").status_code == 404  # not bob's
    c = login(server, "alice")
    assert c.delete(f"/api/auth/tokens/{token['id']}").status_code == 204
    c.cookies.clear()
    assert c.get("/api/projects", headers=bearer).status_code == 401


def test_upload_name_with_a_path_changes_nothing_outside_the_data_folder(server, alices, data):
    outside = data.parent
    before = {p for p in outside.rglob("*") if data not in p.parents and p != data}
    c = login(server, "alice")
    r = c.post(f"/api/projects/{alices['project_id']}/models", files={"file": ("../../x.ifc", b"ISO-10303-21;\n")})
    assert r.status_code == 202
    wait_job(c, r.json()["job"]["id"])
    after = {p for p in outside.rglob("*") if data not in p.parents and p != data}
    assert after == before and not (outside / "x.ifc").exists() and not (outside.parent / "x.ifc").exists()
    model = c.get(f"/api/projects/{alices['project_id']}/models/{r.json()['model']['id']}").json()
    assert model["original_name"] == "x.ifc" and model["status"] == "failed"


def test_a_request_under_way_holds_no_write_lock(server, data):
    """A logged-in request records its token's use at once, not when it ends: a job's event stream stays open while
    the job runs, and must not keep the worker (or any other request) from writing to the database meanwhile."""
    import sqlite3

    from starlette.requests import Request

    from sightplan.web.deps import SESSION_COOKIE, current_user

    secret = login(server, "alice").cookies.get(SESSION_COOKIE)
    state = server.app.state.sightplan
    request = Request({"type": "http", "method": "GET", "path": "/api/jobs/1/events", "query_string": b"",
                       "headers": [(b"cookie", f"{SESSION_COOKIE}={secret}".encode())]})
    with state.db.session() as session:
        assert current_user(request, state, session).username == "alice"
        other = sqlite3.connect(data / "sightplan.db", timeout=0.5)
        try:
            other.execute("BEGIN IMMEDIATE")  # a writer: "database is locked" while the request's session holds it
            other.rollback()
        finally:
            other.close()


# --------------------------------------------------------------------------- the command line
def test_users_command_line(tmp_path):
    data = tmp_path / "d"
    runner = CliRunner()
    add = ["users", "add", "dana", "--data", str(data), "--password-stdin"]
    assert runner.invoke(cli, add, input="short\n").exit_code == 2  # under 8 characters
    assert runner.invoke(cli, add, input="long-enough-pw\n").exit_code == 0
    again = runner.invoke(cli, add, input="long-enough-pw\n")
    assert again.exit_code == 2 and "exists already" in again.output and "Traceback" not in again.output
    bad = runner.invoke(cli, ["users", "add", "../x", "--data", str(data), "--password-stdin"], input="x" * 10 + "\n")
    assert bad.exit_code == 2 and "user name" in bad.output
    with TestClient(create_app(ServerConfig(data_dir=data, team=True)), headers=PAGE) as c:
        assert c.post("/api/auth/login", json={"username": "dana", "password": "long-enough-pw"}).status_code == 200
        pid = c.post("/api/projects", json={"name": "p"}).json()["id"]
    listed = runner.invoke(cli, ["users", "list", "--data", str(data)])
    assert f"dana: project {pid} owner" in listed.output
    sole = runner.invoke(cli, ["users", "remove", "dana", "--data", str(data)])
    assert sole.exit_code == 2 and "only owner" in sole.output
    assert runner.invoke(cli, ["users", "passwd", "dana", "--data", str(data), "--password-stdin"],
                         input="another-password\n").exit_code == 0
    with TestClient(create_app(ServerConfig(data_dir=data, team=True)), headers=PAGE) as c:
        assert c.post("/api/auth/login", json={"username": "dana", "password": "long-enough-pw"}).status_code == 401
        assert c.post("/api/auth/login", json={"username": "dana", "password": "another-password"}).status_code == 200
