"""A stopping server: SIGTERM ends `sightplan serve` promptly even with a job stuck inside one long step, and the
job is recorded as failed (interrupted), not left running."""

from __future__ import annotations

import signal
import socket
import subprocess
import sys
import textwrap
import threading
import time

import httpx
from fastapi.testclient import TestClient

from sightplan.web.app import create_app
from sightplan.web.config import ServerConfig
from sightplan.web.db import Database
from sightplan.web.models import Job
from sightplan.web.worker import INTERRUPTED
from web_support import wait_until_serving

# a server whose model loads never reach a progress step (a stand-in for one enormous product in the kernel)
SERVER = textwrap.dedent("""
    import sys, threading
    from sightplan.web import worker
    worker.Worker._load_model = lambda self, job_id: threading.Event().wait(600)
    from sightplan.cli.main import app
    sys.argv = ["sightplan", "serve", "--data", sys.argv[1], "--port", sys.argv[2], "--workers", "1"]
    app()
""")


def _free_port() -> int:
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


def _job(state, pid: int) -> int:
    with state.db.session() as s:
        job = Job(project_id=pid, kind="load_model", message="queued")
        s.add(job)
        s.flush()
        return job.id


def test_sigterm_stops_the_server_and_fails_the_stuck_job(tmp_path):
    data, port = tmp_path / "data", _free_port()
    with TestClient(create_app(ServerConfig(data_dir=data, workers=1))) as c:  # the project and a queued job
        pid = c.post("/api/projects", json={"name": "p"}).json()["id"]
        job_id = _job(c.app.state.sightplan, pid)
    proc = subprocess.Popen([sys.executable, "-c", SERVER, str(data), str(port)], stdout=subprocess.PIPE,
                            stderr=subprocess.STDOUT, text=True)
    try:
        base = f"http://127.0.0.1:{port}"
        wait_until_serving(base, 300)
        headers = {"Origin": base, "X-Sightplan-Request": "1"}
        assert httpx.get(f"{base}/api/jobs/{job_id}").json()["error"] == INTERRUPTED  # left queued by the last one
        r = httpx.post(f"{base}/api/projects/{pid}/models", headers=headers,
                       files={"file": ("a.ifc", b"ISO-10303-21;\nEND-ISO-10303-21;\n")})
        assert r.status_code in (200, 201, 202), r.text
        stuck = r.json()["job"]["id"]
        for _ in range(300):
            if httpx.get(f"{base}/api/jobs/{stuck}").json()["status"] == "running":
                break
            time.sleep(0.1)
        stream = threading.Thread(target=lambda: _hold_stream(base, stuck), daemon=True)  # an open progress stream
        stream.start()
        time.sleep(0.5)
        proc.send_signal(signal.SIGTERM)
        proc.wait(timeout=30)  # without the grace periods it never returns (pytest's own timeout would fail it)
    finally:
        if proc.poll() is None:
            proc.kill()
            proc.wait()
    db = Database(f"sqlite:///{data / 'sightplan.db'}")
    with db.session() as s:
        job = s.get(Job, stuck)
        assert job.status == "failed" and job.error == INTERRUPTED  # marked by the stopping process itself
    db.dispose()


def _hold_stream(base: str, job_id: int) -> None:
    try:
        with httpx.stream("GET", f"{base}/api/jobs/{job_id}/events", timeout=60) as r:
            for _ in r.iter_bytes():
                pass
    except httpx.HTTPError:
        pass


def test_shutdown_marks_a_job_stuck_in_one_step_failed_and_returns(tmp_path, monkeypatch):
    from sightplan.web import worker as worker_mod

    release = threading.Event()
    monkeypatch.setattr(worker_mod.Worker, "_load_model", lambda self, job_id: release.wait(600))
    with TestClient(create_app(ServerConfig(data_dir=tmp_path / "d", workers=1))) as c:
        state = c.app.state.sightplan
        pid = c.post("/api/projects", json={"name": "p"}).json()["id"]
        job_id, queued = _job(state, pid), _job(state, pid)
        state.worker.submit(job_id)
        state.worker.submit(queued)
        for _ in range(300):
            if c.get(f"/api/jobs/{job_id}").json()["status"] == "running":
                break
            time.sleep(0.05)
        state.worker.shutdown(grace_s=0.5)
        job = c.get(f"/api/jobs/{job_id}").json()
        assert job["status"] == "failed" and job["error"] == INTERRUPTED
        assert c.get(f"/api/jobs/{queued}").json()["status"] == "queued"  # never started; the next start fails it
        release.set()  # the step ends late: the job stays failed, not "done"
        time.sleep(0.2)
        assert c.get(f"/api/jobs/{job_id}").json()["status"] == "failed"
