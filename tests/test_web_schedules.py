"""Schedules in the web server: linked in the worker, the site at a date for the viewer's slider, evaluations at a
capture date, and re-evaluation of an edited plan that casts only the changed frames.

The states are checked against dates written into a CSV here (known per element), and against the library's own
``link_schedule`` + ``Scene.at`` on the IFC4 schedule example.
"""

from __future__ import annotations

import json
import re

import numpy as np
import pytest

pytest.importorskip("fastapi")

from fastapi.testclient import TestClient  # noqa: E402

from conftest import shared_file  # noqa: E402
from sightplan.errors import ScheduleError  # noqa: E402
from sightplan.evaluate import EvaluationSettings, evaluate  # noqa: E402
from sightplan.model.load import load_model, sample_model_path  # noqa: E402
from sightplan.plan.format import plan_from_dict  # noqa: E402
from sightplan.web.app import create_app  # noqa: E402
from sightplan.web.config import ServerConfig  # noqa: E402
from web_support import upload_model, wait_job  # noqa: E402

SCALE = 0.05




@pytest.fixture(scope="module")
def client(tmp_path_factory):
    with TestClient(create_app(ServerConfig(data_dir=tmp_path_factory.mktemp("sched") / "data"))) as c:
        yield c




@pytest.fixture(scope="module")
def duplex(client) -> tuple[int, int]:
    pid = client.post("/api/projects", json={"name": "4D"}).json()["id"]
    return pid, upload_model(client, pid, sample_model_path(), "duplex.ifc")


@pytest.fixture(scope="module")
def csv_schedule(client, duplex):
    """Per-element dates: 10 walls finished on 10 January, 5 started on 5 January and finished on the 20th."""
    pid, mid = duplex
    scene, _ = load_model("sample")
    targets = np.flatnonzero(scene.elements.is_target)
    done, busy = targets[:10], targets[10:15]
    rows = ["global_id,start,finish"]
    rows += [f"{scene.elements.global_id[i]},2025-01-02,2025-01-10" for i in done]
    rows += [f"{scene.elements.global_id[i]},2025-01-05,2025-01-20" for i in busy]
    r = client.post(f"/api/projects/{pid}/schedules", data={"model_id": str(mid)},
                    files={"file": ("dates.csv", "\n".join(rows).encode())})
    assert r.status_code == 202, r.text
    assert wait_job(client, r.json()["job"]["id"])["status"] == "done"
    return r.json()["schedule"]["id"], scene, done, busy


def test_states_at_a_date_follow_the_csv_dates(client, duplex, csv_schedule):
    pid, mid = duplex
    sid, scene, done, busy = csv_schedule
    row = client.get(f"/api/projects/{pid}/schedules/{sid}").json()
    assert row["status"] == "ready" and row["first_date"] == "2025-01-02" and row["last_date"] == "2025-01-20"
    assert row["report"]["linked"] == 15
    z = scene.n_elements
    others = np.setdiff1d(np.arange(z), np.concatenate([done, busy]))
    r = client.get(f"/api/projects/{pid}/models/{mid}/states", params={"date": "2025-01-12"})
    assert r.status_code == 200, r.text
    states = {int(k): v for k, v in r.json()["states"].items()}
    assert len(states) == z
    assert all(states[i] == "built" for i in done)
    assert all(states[i] == "in_progress" for i in busy)
    assert all(states[i] == "built" for i in others)  # undated: present by default
    assert r.json()["counts"] == {"built": z - 5, "in_progress": 5, "not_yet": 0}
    early = client.get(f"/api/projects/{pid}/models/{mid}/states",
                       params={"date": "2025-01-03", "unscheduled": "absent"}).json()
    assert early["counts"] == {"built": 0, "in_progress": 10, "not_yet": z - 10}
    late = client.get(f"/api/projects/{pid}/models/{mid}/states", params={"date": "2025-01-20", "basis": "start"}).json()
    assert late["counts"]["built"] == z
    bad = client.get(f"/api/projects/{pid}/models/{mid}/states", params={"date": "12/13/2025"})
    assert bad.status_code == 422 and "date" in bad.json()["detail"]


def test_evaluation_at_a_capture_date_matches_the_library(client, duplex, csv_schedule):
    pid, mid = duplex
    sid, scene, done, busy = csv_schedule
    r = client.post(f"/api/projects/{pid}/plans", json={"model_id": mid, "template": "orbit", "radius_m": [22],
                                                        "height_m": [6.0], "step_deg": 45})
    plan_id = r.json()["id"]
    r = client.post(f"/api/projects/{pid}/evaluations", json={
        "plan_id": plan_id, "settings": {"scale": SCALE, "engine": "embree"}, "date": "2025-01-12",
        "unscheduled": "absent"})
    assert r.status_code == 202, r.text
    assert wait_job(client, r.json()["job"]["id"])["status"] == "done"
    ev = client.get(f"/api/projects/{pid}/evaluations/{r.json()['evaluation']['id']}").json()
    dated = scene.elements.with_dates(*_csv_dates(scene, done, busy))
    from dataclasses import replace

    at = replace(scene, elements=dated).at("2025-01-12", unscheduled="absent")
    assert int(at.targets.sum()) == 10  # only the finished ones stand
    plan = plan_from_dict(client.get(f"/api/projects/{pid}/plans/{plan_id}/versions/1").json())
    ref = evaluate(at, plan, EvaluationSettings(scale=SCALE, engine="embree"), cache_dir=False).metrics.plan
    assert ev["metrics"]["VC_pct"] == pytest.approx(100 * ref.VC) and ev["metrics"]["VR"] == pytest.approx(ref.VR)
    assert ev["settings"]["fourd"] == {"date": "2025-01-12", "schedule_id": sid, "basis": "finish",
                                       "unscheduled": "absent"}
    in_use = client.delete(f"/api/projects/{pid}/schedules/{sid}")
    assert in_use.status_code == 409 and f"evaluation(s) {ev['id']}" in in_use.json()["detail"]
    html = client.get(f"/api/projects/{pid}/evaluations/{ev['id']}/report.html")
    assert html.status_code == 200
    # a date needs a schedule; a schedule needs a date
    other = client.post("/api/projects", json={"name": "no schedule"}).json()["id"]
    cube = upload_model(client, other, sample_model_path(), "duplex.ifc")
    p2 = client.post(f"/api/projects/{other}/plans", json={"model_id": cube, "template": "orbit", "radius_m": [22],
                                                          "height_m": [6.0], "step_deg": 90}).json()["id"]
    r = client.post(f"/api/projects/{other}/evaluations", json={"plan_id": p2, "date": "2025-01-12"})
    assert r.status_code == 422 and "schedule" in r.json()["detail"]
    r = client.post(f"/api/projects/{pid}/evaluations", json={"plan_id": plan_id, "schedule_id": sid})
    assert r.status_code == 422 and "date" in r.json()["detail"]


def _csv_dates(scene, done, busy):
    z = scene.n_elements
    start = np.full(z, np.datetime64("NaT"), "datetime64[s]")
    finish = start.copy()
    start[done], finish[done] = np.datetime64("2025-01-02"), np.datetime64("2025-01-10")
    start[busy], finish[busy] = np.datetime64("2025-01-05"), np.datetime64("2025-01-20")
    return start, finish


def test_a_schedule_for_another_model_fails_with_the_reason(client, duplex):
    pid, mid = duplex
    csv = b"global_id,start,finish\n0123456789abcdefghijkl,2025-01-01,2025-01-02\n"
    r = client.post(f"/api/projects/{pid}/schedules", data={"model_id": str(mid)}, files={"file": ("other.csv", csv)})
    assert r.status_code == 202
    job = wait_job(client, r.json()["job"]["id"])
    assert job["status"] == "failed" and "none is in this model" in job["error"]
    row = client.get(f"/api/projects/{pid}/schedules/{r.json()['schedule']['id']}").json()
    assert row["status"] == "failed" and "other.csv" in row["error"]
    assert re.search(r"[0-9a-f]{32}", row["error"]) is None  # the server's own file name never shows
    r = client.post(f"/api/projects/{pid}/schedules", data={"model_id": str(mid)}, files={"file": ("s.pdf", b"%PDF")})
    assert r.status_code == 415


def test_the_ifc_work_schedule_gives_the_librarys_states(client):
    from sightplan.schedule import link_schedule, read_schedule

    path = shared_file("ifc", "construction_scheduling_task.ifc")
    pid = client.post("/api/projects", json={"name": "IFC4 schedule"}).json()["id"]
    mid = upload_model(client, pid, path, "construction_scheduling_task.ifc")
    r = client.post(f"/api/projects/{pid}/schedules", data={"model_id": str(mid)})  # the model's own
    assert r.status_code == 202, r.text
    assert wait_job(client, r.json()["job"]["id"])["status"] == "done"
    row = client.get(f"/api/projects/{pid}/schedules/{r.json()['schedule']['id']}").json()
    assert row["name"] == "model" and row["first_date"] is not None
    scene, _ = load_model(path)
    dated, report = link_schedule(scene, read_schedule("model", model_path=path), model_path=path)
    assert row["report"]["linked"] == report.linked
    for day in np.arange(np.datetime64(row["first_date"]), np.datetime64(row["last_date"]) + 1):
        states = client.get(f"/api/projects/{pid}/models/{mid}/states", params={"date": str(day)}).json()["states"]
        built = np.array([states[str(i)] == "built" for i in range(scene.n_elements)])
        try:
            present = dated.at(str(day)).present
        except ScheduleError:  # no element stands yet: the library refuses the date
            present = np.zeros(scene.n_elements, bool)
        assert np.array_equal(built, present), str(day)


def test_re_evaluating_an_edited_plan_casts_only_the_moved_frame(client, duplex):
    pid, mid = duplex
    r = client.post(f"/api/projects/{pid}/plans", json={"model_id": mid, "template": "orbit", "radius_m": [26],
                                                        "height_m": [9.0], "step_deg": 30})
    plan_id = r.json()["id"]
    first = client.post(f"/api/projects/{pid}/evaluations", json={"plan_id": plan_id, "settings": {"scale": SCALE}})
    assert wait_job(client, first.json()["job"]["id"])["status"] == "done"
    v1 = client.get(f"/api/projects/{pid}/plans/{plan_id}/versions/1").json()
    edited = json.loads(json.dumps(v1))
    edited["frames"][4]["position"][2] += 3.0
    assert client.put(f"/api/projects/{pid}/plans/{plan_id}", json=edited).status_code == 201
    second = client.post(f"/api/projects/{pid}/evaluations", json={"plan_id": plan_id, "settings": {"scale": SCALE}})
    job = wait_job(client, second.json()["job"]["id"])
    n = len(v1["frames"])
    assert job["status"] == "done" and f"{n - 1} of {n} frames unchanged" in job["message"]
    ev = client.get(f"/api/projects/{pid}/evaluations/{second.json()['evaluation']['id']}").json()
    scene, _ = load_model("sample")
    ref = evaluate(scene, plan_from_dict(edited), EvaluationSettings(scale=SCALE), cache_dir=False).metrics.plan
    assert ev["metrics"]["VR"] == pytest.approx(ref.VR) and ev["metrics"]["T"] == pytest.approx(ref.T)
