"""The sample project of ``sightplan serve --sample`` (the quick start's main job): the bundled Duplex, the README's
facade grid (160 frames at g = 8 m plus the GNSS position error, 80 % overlap) and its evaluation, made once per data
folder."""

from __future__ import annotations

import json
import os
import subprocess
import sys
import time
import urllib.request

import pytest

pytest.importorskip("fastapi")

from fastapi.testclient import TestClient  # noqa: E402

from sightplan.evaluate import EvaluationSettings, evaluate  # noqa: E402
from sightplan.model.load import load_model  # noqa: E402
from sightplan.plan.format import plan_from_dict  # noqa: E402
from sightplan.web.app import create_app  # noqa: E402
from sightplan.web.config import ServerConfig  # noqa: E402
from sightplan.web.sample import SAMPLE_PROJECT, ensure_sample_project  # noqa: E402
from web_support import free_port, wait_job  # noqa: E402

SCALE = 0.05


@pytest.mark.bench  # make bench; the wheel test serves --sample and draws it in make test
def test_sample_project_is_made_once_and_evaluated(tmp_path):
    with TestClient(create_app(ServerConfig(data_dir=tmp_path / "d"))) as c:
        state = c.app.state.sightplan
        job_id = ensure_sample_project(state, scale=SCALE)
        assert job_id is not None and ensure_sample_project(state, scale=SCALE) is None
        job = wait_job(c, job_id)
        assert job["status"] == "done", job
        projects = c.get("/api/projects").json()
        assert [p["name"] for p in projects] == [SAMPLE_PROJECT]
        pid = projects[0]["id"]
        model = c.get(f"/api/projects/{pid}/models").json()[0]
        assert model["status"] == "ready" and model["targets"] == 154
        plan = c.get(f"/api/projects/{pid}/plans").json()[0]
        assert plan["versions"][0]["frames"] == 160 and plan["versions"][0]["missions"] == 4
        ev = c.get(f"/api/projects/{pid}/evaluations").json()[0]
        data = c.get(f"/api/projects/{pid}/plans/{plan['id']}/versions/1").json()
    scene, _ = load_model("sample")
    ref = evaluate(scene, plan_from_dict(data), EvaluationSettings(scale=SCALE), cache_dir=False).metrics.plan
    assert ev["metrics"]["VC_pct"] == pytest.approx(100 * ref.VC) and ev["metrics"]["VR"] == pytest.approx(ref.VR)


@pytest.mark.bench  # a server process (11 s); test_sample_project_is_made_once_and_evaluated stays in make test
def test_serve_sample_starts_with_the_project_ready(tmp_path):
    port = free_port()
    proc = subprocess.Popen([sys.executable, "-m", "sightplan", "serve", "--sample", "--port", str(port), "--data",
                             str(tmp_path / "d")], stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True,
                            env={**os.environ, "PYTHONUNBUFFERED": "1"})
    try:
        deadline = time.monotonic() + 90
        projects = None
        while time.monotonic() < deadline and proc.poll() is None:
            try:
                with urllib.request.urlopen(f"http://127.0.0.1:{port}/api/projects", timeout=2) as r:
                    projects = json.loads(r.read())
                    break
            except OSError:
                time.sleep(0.3)
        assert projects is not None and [p["name"] for p in projects] == [SAMPLE_PROJECT]
        with urllib.request.urlopen(f"http://127.0.0.1:{port}/api/projects/{projects[0]['id']}/evaluations") as r:
            evaluations = json.loads(r.read())
        assert len(evaluations) == 1 and evaluations[0]["settings"]["scale"] == 0.25
    finally:
        proc.terminate()
        output = proc.communicate(timeout=30)[0]
    assert f"sample project '{SAMPLE_PROJECT}'" in output and f"http://127.0.0.1:{port}/" in output


def test_cancelling_a_running_evaluation_stops_it_and_leaves_no_result(tmp_path):
    with TestClient(create_app(ServerConfig(data_dir=tmp_path / "d"))) as c:
        job_id = ensure_sample_project(c.app.state.sightplan, scale=0.5)  # 216 frames of about 0.15 s each
        deadline = time.monotonic() + 60
        while (job := c.get(f"/api/jobs/{job_id}").json())["progress_done"] < 1:
            assert job["status"] in ("queued", "running") and time.monotonic() < deadline
            time.sleep(0.05)
        r = c.post(f"/api/jobs/{job_id}/cancel")
        assert r.status_code == 200
        t0 = time.monotonic()
        while (job := c.get(f"/api/jobs/{job_id}").json())["status"] not in ("done", "failed"):
            assert time.monotonic() - t0 < 60, "the evaluation did not stop"  # a hang guard, not a speed claim
            time.sleep(0.05)
        assert job["status"] == "failed" and job["error"] == "cancelled" and job["progress_done"] < 216
        pid = c.get("/api/projects").json()[0]["id"]
        ev = c.get(f"/api/projects/{pid}/evaluations").json()[0]
        assert ev["status"] == "failed" and ev["metrics"] is None
        assert not any((tmp_path / "d" / "evaluations").iterdir())
        again = c.post(f"/api/jobs/{job_id}/cancel")
        assert again.status_code == 409 and "failed already" in again.json()["detail"]


def test_a_cancelled_queued_job_leaves_no_mark_for_a_later_job_of_the_same_id(tmp_path):
    from sightplan.web.models import Job

    with TestClient(create_app(ServerConfig(data_dir=tmp_path / "d", workers=1))) as c:
        state = c.app.state.sightplan
        pid = c.post("/api/projects", json={"name": "p"}).json()["id"]
        with state.db.session() as s:  # a job waiting in the queue (not handed to the worker yet)
            job = Job(project_id=pid, kind="load_model", message="queued")
            s.add(job)
            s.flush()
            job_id = job.id
        r = c.post(f"/api/jobs/{job_id}/cancel")
        assert r.status_code == 200 and r.json()["status"] == "failed" and r.json()["error"] == "cancelled"
        state.worker.run(job_id)  # the worker reaches it: not queued any more, nothing to do
        with state.db.session() as s:  # the id taken again by a new job (SQLite reuses the largest id)
            s.delete(s.get(Job, job_id))
        with state.db.session() as s:
            again = Job(project_id=pid, kind="load_model", message="queued")
            s.add(again)
            s.flush()
            assert again.id == job_id
        state.worker.run(job_id)  # no model: it runs and fails, but for its own reason, not as "cancelled"
        job = c.get(f"/api/jobs/{job_id}").json()
        assert job["status"] == "failed" and job["started_at"] is not None and "cancelled" not in job["error"]
