"""What the web server's tests share: waiting for a background job, uploading a model."""

from __future__ import annotations

import socket
import time
from pathlib import Path


def free_port() -> int:
    """A TCP port on the loopback address that nothing listens on now."""
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


def wait_job(client, job_id: int, timeout_s: float = 120.0) -> dict:
    """The job once it is done or failed (polled through the API)."""
    deadline = time.monotonic() + timeout_s
    while True:
        job = client.get(f"/api/jobs/{job_id}").json()
        if job["status"] in ("done", "failed"):
            return job
        assert time.monotonic() < deadline, f"job {job_id} still {job['status']} after {timeout_s} s"
        time.sleep(0.1)


def upload_model(client, project_id: int, path: str | Path, name: str | None = None, data: bytes | None = None) -> int:
    """Upload a model file (or ``data`` under ``name``), wait until it is tessellated, return its id."""
    body = data if data is not None else Path(path).read_bytes()
    r = client.post(f"/api/projects/{project_id}/models", files={"file": (name or Path(path).name, body)})
    assert r.status_code == 202, r.text
    assert wait_job(client, r.json()["job"]["id"])["status"] == "done"
    return r.json()["model"]["id"]


def wait_until_serving(base: str, tries: int = 300) -> None:
    """Wait (0.1 s a try) until a server started in another process answers ``GET /api/projects``."""
    import time

    import httpx

    for _ in range(tries):
        try:
            if httpx.get(f"{base}/api/projects", timeout=2).status_code == 200:
                return
        except httpx.HTTPError:
            time.sleep(0.1)

