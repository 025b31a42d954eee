"""The web server on a dask cluster (``sightplan serve --cluster``): models are prepared in tasks on its workers,
evaluations and optimisations cast there with the results of a local run, a cancelled job cancels its task, and an
unreachable scheduler is one line at start."""

from __future__ import annotations

import io
import os
import shutil
import signal
import subprocess
import sys
import textwrap
import threading
import time
from pathlib import Path

import numpy as np
import pytest
import trimesh

distributed = pytest.importorskip("distributed")
pytest.importorskip("fastapi")

from fastapi.testclient import TestClient  # noqa: E402

from sightplan import distributed as sp_distributed  # noqa: E402
from sightplan.errors import SightplanError  # noqa: E402
from sightplan.model.load import sample_model_path  # noqa: E402
from sightplan.web.app import create_app  # noqa: E402
from sightplan.web.config import ServerConfig, ServerConfigError  # noqa: E402
from web_support import free_port, upload_model, wait_job, wait_until_serving  # noqa: E402

SCALE = 0.05
RELEASE = threading.Event()  # ends a stuck preparation that was not cancelled (a failing test)
STOPPED = threading.Event()  # set by a stuck preparation that saw its task cancelled


@pytest.fixture(scope="module")
def cluster():
    """One in-process worker of one thread: the server reaches it by its scheduler's address."""
    with distributed.LocalCluster(n_workers=1, threads_per_worker=1, processes=False, dashboard_address=None) as lc, \
            distributed.Client(lc, set_as_default=False) as c:
        yield lc, c


@pytest.fixture(scope="module")
def server(cluster, duplex, tmp_path_factory):
    """A server on the cluster whose scene cache already holds the Duplex (its preparation reads it, as a worker that
    tessellated it before would, instead of tessellating it for 10 s)."""
    data = tmp_path_factory.mktemp("cluster") / "data"
    (data / "cache" / "scenes").mkdir(parents=True)
    cached = list((Path(os.environ["SIGHTPLAN_CACHE"]) / "scenes").glob(f"{duplex.content_hash}.*"))
    assert cached, "the Duplex fixture's scene cache moved"
    for path in cached:
        shutil.copy(path, data / "cache" / "scenes")
    with TestClient(create_app(ServerConfig(data_dir=data, cluster=cluster[0].scheduler_address))) as c:
        yield c


def _keys(stream, prefix: str) -> list[str]:
    return [str(t["key"]) for t in stream.data if str(t["key"]).startswith(prefix)]


def _box_obj() -> bytes:
    mesh = trimesh.creation.box((8, 8, 8))
    mesh.apply_translation((4, 4, 4))
    buf = io.BytesIO()
    mesh.export(buf, file_type="obj")
    return buf.getvalue()


def test_a_model_is_prepared_and_a_plan_evaluated_on_the_cluster_as_here(server, cluster, duplex):
    from sightplan.evaluate import EvaluationSettings, evaluate
    from sightplan.plan.format import plan_from_dict
    from sightplan.report.tables import report_dict

    client = cluster[1]
    pid = server.post("/api/projects", json={"name": "Duplex"}).json()["id"]
    with distributed.get_task_stream(client) as stream:
        model = upload_model(server, pid, sample_model_path(), name="Duplex A.ifc")
    assert len(_keys(stream, "prepare_model-")) == 1  # prepared in a task on the worker
    row = server.get(f"/api/projects/{pid}/models/{model}").json()
    assert row["status"] == "ready" and row["elements"] == duplex.n_elements
    assert row["triangles"] == len(duplex.faces)
    r = server.post(f"/api/projects/{pid}/plans", json={"name": "orbit", "model_id": model, "template": "orbit",
                                                         "radius_m": [25], "height_m": [12.0], "step_deg": 45})
    assert r.status_code == 201, r.text
    plan_id = r.json()["id"]
    with distributed.get_task_stream(client) as stream:
        r = server.post(f"/api/projects/{pid}/evaluations",
                        json={"plan_id": plan_id, "settings": {"scale": SCALE, "engine": "embree"}})
        assert r.status_code == 202, r.text
        job = wait_job(server, r.json()["job"]["id"])
    assert job["status"] == "done", job
    assert len(_keys(stream, "observe_frames")) == 1  # 8 frames, one batch, cast on the worker
    eid = r.json()["evaluation"]["id"]
    ev = server.get(f"/api/projects/{pid}/evaluations/{eid}").json()
    assert ev["progress_done"] == ev["progress_total"] == 8
    plan = plan_from_dict(server.get(f"/api/projects/{pid}/plans/{plan_id}/versions/1").json())
    here = evaluate(duplex, plan, EvaluationSettings(scale=SCALE, engine="embree"), cache_dir=False)
    assert ev["metrics"] == report_dict(here, duplex, plan)["metrics"]
    rows = server.get(f"/api/projects/{pid}/evaluations/{eid}/elements").json()["elements"]
    assert [r["VR_i"] for r in rows] == [int(here.metrics.elements.VR[r["index"]]) for r in rows]


def test_an_optimisation_on_the_cluster_makes_the_librarys_plan(server, cluster, tmp_path):
    from sightplan.camera.catalogue import get_camera
    from sightplan.model.load import load_model
    from sightplan.optimize import OptimizeSettings, Targets, optimize
    from sightplan.web.services import flight_settings

    pid = server.post("/api/projects", json={"name": "box"}).json()["id"]
    mid = upload_model(server, pid, "box.obj", data=_box_obj())
    with distributed.get_task_stream(cluster[1]) as stream:
        r = server.post(f"/api/projects/{pid}/plans/optimize", json={"model_id": mid, "k": 2, "scale": SCALE})
        assert r.status_code == 202, r.text
        job = wait_job(server, r.json()["id"])
    assert job["status"] == "done", job
    assert len(_keys(stream, "observe_frames")) > 1  # the candidates, 16 a task
    web = server.get(f"/api/projects/{pid}/plans/{job['plan_id']}/versions/1").json()
    (tmp_path / "box.obj").write_bytes(_box_obj())
    ref = optimize(load_model(tmp_path / "box.obj")[0], get_camera("p4p"), Targets(k=2),
                   flight=flight_settings(web["parameters"]["flight"]),
                   settings=OptimizeSettings(scale=SCALE, cache_dir=False))
    assert np.allclose([f["position"] for f in web["frames"]], ref.plan.C_world)


def _stuck(path, cache_dir):
    """A preparation that reports half done, then waits until its task is cancelled."""
    report = sp_distributed._task_progress()
    report(0.5)
    try:
        while not RELEASE.wait(0.05):
            report(0.5)
    except sp_distributed.PreparationCancelled:
        STOPPED.set()
        raise
    raise SightplanError("released by the test")


def _gone(scheduler, prefix: str, timeout_s: float = 10.0) -> bool:
    deadline = time.monotonic() + timeout_s
    while any(str(k).startswith(prefix) for k in scheduler.tasks):
        if time.monotonic() > deadline:
            return False
        time.sleep(0.05)
    return True


def test_cancelling_a_preparation_cancels_its_task_and_the_server_answers_meanwhile(server, cluster, monkeypatch):
    monkeypatch.setattr(sp_distributed, "prepare_model", _stuck)
    RELEASE.clear()
    STOPPED.clear()
    pid = server.post("/api/projects", json={"name": "cancel"}).json()["id"]
    try:
        r = server.post(f"/api/projects/{pid}/models", files={"file": ("box.obj", _box_obj())})
        assert r.status_code == 202, r.text
        job_id = r.json()["job"]["id"]
        deadline = time.monotonic() + 30
        while server.get(f"/api/jobs/{job_id}").json()["progress_done"] != 0.5:  # the worker's progress, relayed
            assert time.monotonic() < deadline
            time.sleep(0.05)
        # the server answers while the task is stuck on the worker (no time asserted: a busy machine stretches it)
        assert server.get("/api/projects").status_code == 200
        assert server.get(f"/api/jobs/{job_id}").json()["status"] == "running" and not STOPPED.is_set()
        assert server.post(f"/api/jobs/{job_id}/cancel").status_code == 200
        job = wait_job(server, job_id, timeout_s=60)
        assert job["status"] == "failed" and job["error"] == "cancelled"
        assert STOPPED.wait(60)  # the task saw its cancellation at its next progress step
        assert _gone(cluster[0].scheduler, "prepare_model-", timeout_s=60)
    finally:
        RELEASE.set()


def test_a_stopping_server_interrupts_its_cluster_job_and_cancels_the_task(cluster, tmp_path, monkeypatch):
    from sightplan.web.worker import INTERRUPTED

    monkeypatch.setattr(sp_distributed, "prepare_model", _stuck)
    RELEASE.clear()
    STOPPED.clear()
    try:
        with TestClient(create_app(ServerConfig(data_dir=tmp_path / "d", cluster=cluster[0].scheduler_address))) as c:
            state = c.app.state.sightplan
            assert state.cluster.workers() == 1 and state.cluster.workers_without(tmp_path / "d") == []
            assert len(state.cluster.workers_without(tmp_path / "absent")) == 1  # named at start by sightplan serve
            pid = c.post("/api/projects", json={"name": "p"}).json()["id"]
            job_id = c.post(f"/api/projects/{pid}/models", files={"file": ("box.obj", _box_obj())}).json()["job"]["id"]
            deadline = time.monotonic() + 30
            while c.get(f"/api/jobs/{job_id}").json()["progress_done"] != 0.5:
                assert time.monotonic() < deadline
                time.sleep(0.05)
            state.worker.shutdown(grace_s=2.0)  # what SIGTERM does, after the open streams' grace
            job = c.get(f"/api/jobs/{job_id}").json()
            assert job["status"] == "failed" and job["error"] == INTERRUPTED
            assert STOPPED.wait(10) and _gone(cluster[0].scheduler, "prepare_model-")
        assert cluster[1].status == "running"  # the server closed its own client, not the cluster
    finally:
        RELEASE.set()


def test_a_worker_without_the_data_folder_says_so(tmp_path):
    with pytest.raises(SightplanError, match=f"does not see the server's data folder {tmp_path / 'd'}: mount it"):
        sp_distributed.prepare_model(tmp_path / "d" / "models" / "a.ifc", tmp_path / "d" / "cache")


def test_an_unreachable_scheduler_is_one_line_at_start(tmp_path, monkeypatch):
    from typer.testing import CliRunner

    from sightplan.cli.main import app

    monkeypatch.setattr(sp_distributed, "CONNECT_TIMEOUT_S", 0.5)
    address = f"tcp://127.0.0.1:{free_port()}"
    r = CliRunner().invoke(app, ["serve", "--data", str(tmp_path / "d")], env={"SIGHTPLAN_CLUSTER": address,
                                                                              "COLUMNS": "300"})
    assert r.exit_code != 0 and f"cannot reach the dask scheduler at {address}" in r.output, r.output
    assert len(r.output.strip().splitlines()) == 1, r.output
    assert ServerConfig(data_dir=tmp_path, cluster=" ").cluster is None
    with pytest.raises(ServerConfigError, match="local:N"):
        ServerConfig(data_dir=tmp_path, cluster="tcp://a b")


# a server on `--cluster local:1` whose model loads wait on a task that sleeps on the worker process
SERVER = textwrap.dedent("""
    import sys, time
    from sightplan.web import worker
    worker.Worker._load_model = lambda self, job_id: self._wait(job_id, self.cluster.client.submit(time.sleep, 600,
                                                                                                   pure=False))
    from sightplan.cli.main import app
    sys.argv = ["sightplan", "serve", "--data", sys.argv[1], "--port", sys.argv[2], "--workers", "1",
                "--cluster", "local:1"]
    app()
""")


@pytest.mark.bench  # a server process and a local cluster of one worker process (about 10 s)
def test_sigterm_stops_a_server_on_a_local_cluster_with_its_workers(tmp_path):
    import httpx
    import psutil

    from sightplan.web.db import Database
    from sightplan.web.models import Job
    from sightplan.web.worker import INTERRUPTED

    data, port = tmp_path / "data", free_port()
    proc = subprocess.Popen([sys.executable, "-c", SERVER, str(data), str(port)], stdout=subprocess.PIPE,
                            stderr=subprocess.STDOUT, text=True)
    try:
        base = f"http://127.0.0.1:{port}"
        wait_until_serving(base, 600)
        headers = {"Origin": base, "X-Sightplan-Request": "1"}
        pid = httpx.post(f"{base}/api/projects", json={"name": "p"}, headers=headers).json()["id"]
        r = httpx.post(f"{base}/api/projects/{pid}/models", headers=headers, files={"file": ("box.obj", _box_obj())})
        job_id = r.json()["job"]["id"]
        for _ in range(300):
            if httpx.get(f"{base}/api/jobs/{job_id}").json()["status"] == "running":
                break
            time.sleep(0.1)
        children = psutil.Process(proc.pid).children(recursive=True)
        assert children  # the local cluster's worker process
        t0 = time.monotonic()
        proc.send_signal(signal.SIGTERM)
        out, _ = proc.communicate(timeout=30)
        assert time.monotonic() - t0 < 12, out  # the streams' 4 s, the jobs' 3 s, then the cluster's close
        assert "Jobs run on the dask cluster at local:1 (1 worker(s) now)" in out, out
        gone, alive = psutil.wait_procs(children, timeout=10)
        assert not alive  # stopped with the server
    finally:
        if proc.poll() is None:
            proc.kill()
            proc.wait()
    db = Database(f"sqlite:///{data / 'sightplan.db'}")
    with db.session() as s:
        job = s.get(Job, job_id)
        assert job.status == "failed" and job.error == INTERRUPTED
    db.dispose()


def _jobs_on(server, project_name: str) -> tuple[dict, list]:
    """An evaluation of an orbit around the Duplex and an optimisation of a box, as a user runs them on ``server``:
    the evaluation's metrics and the optimised plan's frame positions."""
    pid = server.post("/api/projects", json={"name": project_name}).json()["id"]
    model = upload_model(server, pid, sample_model_path(), name="duplex.ifc")
    plan = server.post(f"/api/projects/{pid}/plans", json={"name": "orbit", "model_id": model, "template": "orbit",
                                                           "radius_m": [25], "height_m": [12.0], "step_deg": 30})
    r = server.post(f"/api/projects/{pid}/evaluations",
                    json={"plan_id": plan.json()["id"], "settings": {"scale": SCALE, "engine": "embree"}})
    assert wait_job(server, r.json()["job"]["id"])["status"] == "done"
    metrics = server.get(f"/api/projects/{pid}/evaluations/{r.json()['evaluation']['id']}").json()["metrics"]
    box = upload_model(server, pid, "box.obj", data=_box_obj())
    r = server.post(f"/api/projects/{pid}/plans/optimize", json={"model_id": box, "k": 2, "scale": SCALE})
    job = wait_job(server, r.json()["id"])
    assert job["status"] == "done", job
    frames = server.get(f"/api/projects/{pid}/plans/{job['plan_id']}/versions/1").json()["frames"]
    return metrics, [f["position"] for f in frames]


@pytest.mark.bench
def test_serve_on_local_two_worker_processes_equals_the_threaded_server(tmp_path):
    """``sightplan serve --cluster local:2``: two worker processes cast an evaluation and an optimisation (seen in
    the task stream, on workers outside this process) whose results equal the threaded server's."""
    with TestClient(create_app(ServerConfig(data_dir=tmp_path / "here"))) as here:
        want = _jobs_on(here, "here")
    app = create_app(ServerConfig(data_dir=tmp_path / "cluster", cluster="local:2"))
    with TestClient(app) as there:
        client = app.state.sightplan.cluster.client
        with distributed.get_task_stream(client) as stream:
            got = _jobs_on(there, "cluster")
        workers = {t["worker"] for t in stream.data if str(t["key"]).startswith("observe_frames")}
        pids = client.run(os.getpid)
    assert got[0] == want[0] and np.allclose(got[1], want[1])
    assert len(_keys(stream, "observe_frames")) > 2 and len(_keys(stream, "prepare_model-")) == 2
    assert workers and all(pids[w] != os.getpid() for w in workers)  # cast in the worker processes
