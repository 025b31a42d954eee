"""The web server on PostgreSQL (``sightplan serve --database postgresql://…``) instead of the embedded SQLite: the
same API flow, restart, cascades, and team mode, against a throw-away cluster of Debian's PostgreSQL server.

``make setup`` installs the server where it is missing; in CI this test cannot be skipped.
"""

from __future__ import annotations

import json
import os

import pytest

pytest.importorskip("fastapi")
pytest.importorskip("psycopg")

from fastapi.testclient import TestClient  # noqa: E402

from pgcluster import temporary_cluster  # noqa: E402
from sightplan.evaluate import EvaluationSettings, evaluate  # noqa: E402
from sightplan.model.load import load_model, sample_model_path  # noqa: E402
from sightplan.plan.format import plan_from_dict  # noqa: E402
from sightplan.web.app import create_app  # noqa: E402
from sightplan.web.config import ServerConfig  # noqa: E402
from web_support import wait_job  # noqa: E402

SCALE = 0.05


@pytest.fixture(scope="module")
def pg_url():
    try:
        with temporary_cluster() as url:
            yield url
    except (FileNotFoundError, OSError) as exc:
        if os.environ.get("CI"):
            pytest.fail(f"PostgreSQL is needed in CI (make setup installs it): {exc}")
        pytest.skip(f"no PostgreSQL server here: {exc}")


def new_database(url: str, name: str) -> str:
    import psycopg

    base, query = url.split("?")
    with psycopg.connect(f"dbname=postgres user=sightplan {query.replace('&', ' ')}", autocommit=True) as conn:
        conn.execute(f'CREATE DATABASE "{name}"')
    return f"{base.rsplit('/', 1)[0]}/{name}?{query}"




def test_the_api_flow_on_postgresql_survives_a_restart(pg_url, tmp_path):
    url = new_database(pg_url, "flow")
    config = ServerConfig(data_dir=tmp_path / "d", database_url=url)
    with TestClient(create_app(config)) as c:
        info = c.get("/api/info").json()
        assert info["database"] == "postgresql" and not (tmp_path / "d" / "sightplan.db").exists()
        pid = c.post("/api/projects", json={"name": "on postgres"}).json()["id"]
        with open(sample_model_path(), "rb") as fh:
            up = c.post(f"/api/projects/{pid}/models", files={"file": ("duplex.ifc", fh)}).json()
        assert wait_job(c, up["job"]["id"])["status"] == "done"
        mid = up["model"]["id"]
        model = c.get(f"/api/projects/{pid}/models/{mid}").json()
        assert model["targets"] == 154 and model["load_report"]["schema"] == "IFC2X3"  # a JSON column, read back
        plans = []
        for step, height in ((30, 6.0), (45, 12.0)):
            r = c.post(f"/api/projects/{pid}/plans", json={"model_id": mid, "template": "orbit", "radius_m": [25],
                                                           "height_m": [height], "step_deg": step})
            assert r.status_code == 201, r.text
            plans.append(r.json()["id"])
        v1 = c.get(f"/api/projects/{pid}/plans/{plans[0]}/versions/1").json()
        edited = json.loads(json.dumps(v1))
        edited["frames"][0]["position"][2] += 2.0
        assert c.put(f"/api/projects/{pid}/plans/{plans[0]}", json=edited).json()["latest_version"] == 2
        started = [c.post(f"/api/projects/{pid}/evaluations", json={
            "plan_id": p, "version": 1, "settings": {"scale": SCALE, "engine": "embree"}}).json() for p in plans]
        for s in started:  # two worker threads writing progress to PostgreSQL at once
            assert wait_job(c, s["job"]["id"])["status"] == "done"
        metrics, data = {}, {}
        for p, s in zip(plans, started):
            metrics[p] = c.get(f"/api/projects/{pid}/evaluations/{s['evaluation']['id']}").json()["metrics"]
            data[p] = c.get(f"/api/projects/{pid}/plans/{p}/versions/1").json()
    scene, _ = load_model("sample")
    for p in plans:
        plan = plan_from_dict(data[p])
        ref = evaluate(scene, plan, EvaluationSettings(scale=SCALE, engine="embree"), cache_dir=False).metrics.plan
        assert metrics[p]["VR"] == pytest.approx(ref.VR) and metrics[p]["VC_pct"] == pytest.approx(100 * ref.VC)
    with TestClient(create_app(config)) as c:  # restarted: everything is still there
        assert [p["name"] for p in c.get("/api/projects").json()] == ["on postgres"]
        assert [v["number"] for v in c.get(f"/api/projects/{pid}/plans/{plans[0]}").json()["versions"]] == [1, 2]
        assert c.get(f"/api/projects/{pid}/plans/{plans[0]}/versions/1").json() == v1
        evs = c.get(f"/api/projects/{pid}/evaluations").json()
        assert {e["plan_id"]: e["metrics"]["VR"] for e in evs} == {p: metrics[p]["VR"] for p in plans}
        assert c.delete(f"/api/projects/{pid}").status_code == 204  # the foreign keys cascade on PostgreSQL too
        assert c.get("/api/projects").json() == [] and c.get("/api/jobs").json() == []


def test_team_mode_on_postgresql(pg_url, tmp_path):
    from sightplan.web.auth import create_user

    url = new_database(pg_url, "team")
    config = ServerConfig(data_dir=tmp_path / "d", database_url=url, team=True)
    with TestClient(create_app(config), headers={"X-Sightplan-Request": "1"}) as c:  # as the page sends
        with c.app.state.sightplan.db.session() as s:
            create_user(s, "alice", "alice-secret-1")
            create_user(s, "bob", "bob-secret-22")
        assert c.get("/api/projects").status_code == 401
        assert c.post("/api/auth/login", json={"username": "alice", "password": "alice-secret-1"}).status_code == 200
        pid = c.post("/api/projects", json={"name": "alice's"}).json()["id"]
        assert c.post(f"/api/projects/{pid}/members", json={"username": "bob", "role": "viewer"}).status_code == 201
        c.cookies.clear()
        assert c.post("/api/auth/login", json={"username": "bob", "password": "bob-secret-22"}).status_code == 200
        assert c.get(f"/api/projects/{pid}").json()["role"] == "viewer"
        assert c.patch(f"/api/projects/{pid}", json={"name": "bob's"}).status_code == 403
        assert c.post("/api/auth/login", json={"username": "bob", "password": "wrong-password"}).status_code == 401
