"""The web server's REST API (``sightplan serve``) through FastAPI's TestClient, and once over real HTTP."""

from __future__ import annotations

import json
import os
import subprocess
import sys
import threading
import time
import urllib.request
import zipfile
from io import BytesIO
from pathlib import Path

import pytest

pytest.importorskip("fastapi")
pytest.importorskip("httpx")

from fastapi.testclient import TestClient  # noqa: E402
from sqlalchemy import create_engine, text  # noqa: E402

from geoid_support import require_geoid  # noqa: E402
from sightplan import geoid  # noqa: E402
from sightplan.model.load import sample_model_path  # noqa: E402
from sightplan.web.app import create_app  # noqa: E402
from sightplan.web.config import ServerConfig, is_loopback  # noqa: E402
from web_support import free_port, wait_job  # noqa: E402

SCALE = 0.05
CUBE_OBJ = """o box
v 0 0 0
v 4 0 0
v 4 4 0
v 0 4 0
v 0 0 3
v 4 0 3
v 4 4 3
v 0 4 3
f 1 3 2
f 1 4 3
f 5 6 7
f 5 7 8
f 1 2 6
f 1 6 5
f 2 3 7
f 2 7 6
f 3 4 8
f 3 8 7
f 4 1 5
f 4 5 8
"""




def files_under(folder: Path) -> set[Path]:
    return {p for p in folder.rglob("*") if p.is_file()}


# --------------------------------------------------------------------------- one server for most tests
@pytest.fixture(scope="module")
def data_dir(tmp_path_factory) -> Path:
    return tmp_path_factory.mktemp("server") / "data"


@pytest.fixture(scope="module")
def client(data_dir):
    with TestClient(create_app(ServerConfig(data_dir=data_dir, workers=2))) as c:
        yield c


@pytest.fixture(scope="module")
def project(client) -> int:
    r = client.post("/api/projects", json={"name": "Duplex"})
    assert r.status_code == 201
    return r.json()["id"]


@pytest.fixture(scope="module")
def model(client, project) -> int:
    """The bundled Duplex, uploaded and tessellated by the worker."""
    with open(sample_model_path(), "rb") as fh:
        r = client.post(f"/api/projects/{project}/models", files={"file": ("Duplex A.ifc", fh)})
    assert r.status_code == 202, r.text
    body = r.json()
    assert body["model"]["status"] == "queued" and body["job"]["kind"] == "load_model"
    assert wait_job(client, body["job"]["id"])["status"] == "done"
    return body["model"]["id"]


@pytest.fixture(scope="module")
def orbit_plans(client, project, model) -> tuple[int, int]:
    """Two different small orbits (12 and 8 frames)."""
    ids = []
    for step, height in ((30, 6.0), (45, 12.0)):
        r = client.post(f"/api/projects/{project}/plans", json={
            "name": f"orbit {step}", "model_id": model, "template": "orbit", "radius_m": [25], "height_m": [height],
            "step_deg": step})
        assert r.status_code == 201, r.text
        ids.append(r.json()["id"])
    return ids[0], ids[1]


@pytest.fixture(scope="module")
def evaluations(client, project, model, orbit_plans) -> list[dict]:
    """Both orbits evaluated at once (two worker threads)."""
    started = []
    for plan_id in orbit_plans:
        r = client.post(f"/api/projects/{project}/evaluations",
                        json={"plan_id": plan_id, "version": 1, "model_id": model,
                              "settings": {"scale": SCALE, "engine": "embree"}})
        assert r.status_code == 202, r.text
        started.append(r.json())
    for s in started:
        assert wait_job(client, s["job"]["id"])["status"] == "done"
    return started


# --------------------------------------------------------------------------- server, docs, projects
def test_info_says_single_user_without_login(client, data_dir):
    info = client.get("/api/info").json()
    assert info["mode"] == "single-user" and info["login"] is False
    assert "no login" in info["message"]
    assert info["database"] == "embedded SQLite" and Path(info["data_dir"]) == data_dir.resolve()
    assert (data_dir / "sightplan.db").is_file()
    assert {"qgc", "wpl", "wpml", "litchi", "kml", "geojson"} <= set(info["export_formats"])  # and any format added
    # the export menu: every format the registry writes, each with its few words (the page's menu entries)
    from sightplan.formats.registry import EXPORT_FORMATS

    assert info["export_formats"] == list(EXPORT_FORMATS)
    assert list(info["export_format_help"]) == list(EXPORT_FORMATS) and all(info["export_format_help"].values())
    assert {"facade", "orbit", "lawnmower", "bridge", "route"} <= set(info["templates"])
    cams = client.get("/api/cameras").json()
    assert any(c["id"] == "p4p" and c["model"] == "pinhole" for c in cams)


def test_openapi_documents_every_endpoint(client):
    schema = client.get("/openapi.json").json()
    operations = [(path, method, op) for path, ops in schema["paths"].items() for method, op in ops.items()]
    assert len(operations) >= 25
    for path, method, op in operations:
        assert op.get("summary"), f"{method} {path} has no summary"
        assert "200" in op["responses"] or "201" in op["responses"] or "202" in op["responses"] \
            or "204" in op["responses"], f"{method} {path}"
    assert client.get("/docs").status_code == 200


def test_projects_crud(client):
    r = client.post("/api/projects", json={"name": "site A"})
    pid = r.json()["id"]
    assert client.get(f"/api/projects/{pid}").json()["name"] == "site A"
    assert client.patch(f"/api/projects/{pid}", json={"name": "site B"}).json()["name"] == "site B"
    assert pid in [p["id"] for p in client.get("/api/projects").json()]
    assert client.post("/api/projects", json={"name": ""}).status_code == 422
    assert client.delete(f"/api/projects/{pid}").status_code == 204
    r = client.get(f"/api/projects/{pid}")
    assert r.status_code == 404 and r.json() == {"detail": f"project {pid} not found"}


def test_unknown_ids_are_404_with_one_message(client, project, model):
    for url in ("/api/projects/9999", f"/api/projects/{project}/models/9999", f"/api/projects/{project}/plans/9999",
                f"/api/projects/{project}/plans/9999/versions/1", f"/api/projects/{project}/evaluations/9999",
                f"/api/projects/{project}/evaluations/9999/elements", "/api/jobs/9999", "/api/jobs/9999/events",
                "/api/projects/9999/models"):
        r = client.get(url)
        assert r.status_code == 404, url
        assert isinstance(r.json()["detail"], str) and "not found" in r.json()["detail"]
    assert client.delete(f"/api/projects/{project}/models/9999").status_code == 404


# --------------------------------------------------------------------------- models
def test_model_has_its_load_report(client, project, model, data_dir):
    m = client.get(f"/api/projects/{project}/models/{model}").json()
    assert m["status"] == "ready" and m["original_name"] == "Duplex A.ifc"
    assert m["elements"] == 215 and m["targets"] == 154 and m["triangles"] > 20000 and m["skipped"] == 0
    assert m["georeferenced"] is True
    assert m["load_report"]["schema"] == "IFC2X3" and "source" not in m["load_report"]
    assert [x["id"] for x in client.get(f"/api/projects/{project}/models").json()] == [model]
    stored = list((data_dir / "models").iterdir())
    assert len(stored) == 1 and stored[0].suffix == ".ifc" and "Duplex" not in stored[0].name


def test_not_an_ifc_fails_on_the_model_with_the_loaders_message(client, project, data_dir):
    before = files_under(data_dir / "models")
    r = client.post(f"/api/projects/{project}/models", files={"file": ("notes.ifc", b"this is not a building model\n")})
    assert r.status_code == 202
    job = wait_job(client, r.json()["job"]["id"])
    m = client.get(f"/api/projects/{project}/models/{r.json()['model']['id']}").json()
    assert job["status"] == "failed" and m["status"] == "failed"
    assert m["error"] and m["error"] == job["error"] and "Traceback" not in m["error"]
    assert m["error"].startswith("notes.ifc") and "IFC" in m["error"]  # the loader's message, with the client's name
    assert files_under(data_dir / "models") == before  # the unusable file is not kept
    client.delete(f"/api/projects/{project}/models/{m['id']}")


def test_bad_uploads_leave_the_project_as_it_was(client, project, data_dir):
    models_before = client.get(f"/api/projects/{project}/models").json()
    files_before = files_under(data_dir)
    r = client.post(f"/api/projects/{project}/models", files={"file": ("empty.ifc", b"")})
    assert r.status_code == 400 and "empty" in r.json()["detail"]
    r = client.post(f"/api/projects/{project}/models", files={"file": ("drawing.dwg", b"AC1027")})
    assert r.status_code == 415 and ".ifc" in r.json()["detail"]
    r = client.post("/api/projects/9999/models", files={"file": ("a.ifc", b"ISO-10303-21;")})
    assert r.status_code == 404
    assert client.get(f"/api/projects/{project}/models").json() == models_before
    assert files_under(data_dir) - files_before <= {data_dir / "sightplan.db-wal", data_dir / "sightplan.db-shm"}


def test_client_path_never_reaches_the_file_system(client, project, data_dir):
    outside = data_dir.parent.parent / "x.ifc"
    r = client.post(f"/api/projects/{project}/models", files={"file": ("../../x.ifc", CUBE_OBJ.encode())})
    assert r.status_code == 202
    wait_job(client, r.json()["job"]["id"])
    assert not outside.exists() and not (data_dir.parent / "x.ifc").exists()
    m = client.get(f"/api/projects/{project}/models/{r.json()['model']['id']}").json()
    assert m["original_name"] == "x.ifc"
    assert all(p.resolve().is_relative_to(data_dir.resolve()) for p in data_dir.rglob("*"))
    client.delete(f"/api/projects/{project}/models/{m['id']}")


def test_upload_over_the_limit_is_413(tmp_path):
    with TestClient(create_app(ServerConfig(data_dir=tmp_path / "d", max_upload_bytes=1000))) as c:
        pid = c.post("/api/projects", json={"name": "p"}).json()["id"]
        r = c.post(f"/api/projects/{pid}/models", files={"file": ("big.obj", b"v 0 0 0\n" * 200_000)})
        assert r.status_code == 413 and "limit" in r.json()["detail"]
        # a body without a declared length is counted as it streams in
        def chunks():
            yield b"--b\r\nContent-Disposition: form-data; name=\"file\"; filename=\"big.obj\"\r\n\r\n"
            for _ in range(10):
                yield b"v 0 0 0\n" * 50
            yield b"\r\n--b--\r\n"
        r = c.post(f"/api/projects/{pid}/models", content=chunks(),
                   headers={"content-type": "multipart/form-data; boundary=b"})
        assert r.status_code == 413 and "limit" in r.json()["detail"]
        assert c.get(f"/api/projects/{pid}/models").json() == []
        assert files_under(tmp_path / "d" / "models") == set() and files_under(tmp_path / "d" / "tmp") == set()


# --------------------------------------------------------------------------- plans
def test_template_plans(client, project, model):
    r = client.post(f"/api/projects/{project}/plans",
                    json={"model_id": model, "template": "facade", "safety_distance_m": 8, "camera": "p4p"})
    assert r.status_code == 201, r.text
    facade = r.json()
    # 32 columns of 4 layers from 2.51 m above the ground (the door sills at z = 0) to the top, and the top row, at
    # 8 m + the GNSS position error's reach + 1 cm (9.59 m): the grid passes its checks at that error
    assert facade["latest_version"] == 1 and facade["versions"][0]["frames"] == 160
    assert facade["versions"][0]["missions"] == 4 and facade["source"] == "template facade (p4p)"
    plan = client.get(f"/api/projects/{project}/plans/{facade['id']}/versions/1").json()
    assert plan["format"] == "sightplan-plan" and len(plan["frames"]) == 160
    assert plan["georeference"]["kind"] == "topocentric" and "takeoff_m" in plan["parameters"]
    r = client.post(f"/api/projects/{project}/plans",
                    json={"model_id": model, "template": "lawnmower", "altitude_m": 40, "overlap": 0.6, "side_overlap": 0.5})
    assert r.status_code == 201 and r.json()["versions"][0]["frames"] > 0
    # an orbit without radius and height takes them from the model's box and the safety distance
    r = client.post(f"/api/projects/{project}/plans", json={"model_id": model, "template": "orbit"})
    assert r.status_code == 201 and r.json()["versions"][0]["frames"] > 0
    r = client.post(f"/api/projects/{project}/plans",
                    json={"model_id": model, "template": "orbit", "radius_m": [25], "height_m": [0]})
    assert r.status_code == 422 and "minimum height" in r.json()["detail"]
    r = client.post(f"/api/projects/{project}/plans",
                    json={"model_id": model, "template": "facade", "camera": "no such camera"})
    assert r.status_code == 422 and "camera" in r.json()["detail"]
    r = client.post(f"/api/projects/{project}/plans", json={"model_id": model, "template": "spiral"})
    assert r.status_code == 422 and isinstance(r.json()["detail"], str)
    assert client.post(f"/api/projects/{project}/plans", json={"model_id": 9999, "template": "facade"}).status_code == 404


def test_plan_upload_in_any_format_and_bad_plan(client, project, model, orbit_plans, data_dir):
    plan_json = client.get(f"/api/projects/{project}/plans/{orbit_plans[0]}/versions/1").content
    r = client.post(f"/api/projects/{project}/plans/upload", files={"file": ("my plan.json", plan_json)},
                    data={"model_id": str(model)})
    assert r.status_code == 201, r.text
    assert r.json()["name"] == "my plan.json" and r.json()["versions"][0]["frames"] == 12
    qgc = client.get(f"/api/projects/{project}/plans/{orbit_plans[0]}/versions/1/export",
                     params={"format": "qgc", "mission": 1})
    r = client.post(f"/api/projects/{project}/plans/upload", files={"file": ("ring.plan", qgc.content)},
                    data={"model_id": str(model), "name": "from QGC"})
    assert r.status_code == 201, r.text
    assert r.json()["versions"][0]["frames"] > 0 and r.json()["source"] == "upload ring.plan"
    plans_before = client.get(f"/api/projects/{project}/plans").json()
    files_before = files_under(data_dir / "plans")
    r = client.post(f"/api/projects/{project}/plans/upload", files={"file": ("broken.json", b'{"format": "sightplan-')})
    assert r.status_code == 422 and "broken.json" in r.json()["detail"]
    r = client.post(f"/api/projects/{project}/plans/upload",
                    files={"file": ("future.json", json.dumps({**json.loads(plan_json), "version": 99}).encode())})
    assert r.status_code == 422 and "newer" in r.json()["detail"]
    r = client.post(f"/api/projects/{project}/plans/upload", files={"file": ("empty.csv", b"")})
    assert r.status_code == 400
    assert client.get(f"/api/projects/{project}/plans").json() == plans_before
    assert files_under(data_dir / "plans") == files_before and files_under(data_dir / "tmp") == set()



def test_a_download_keeps_a_non_ascii_plan_name(client, project, model, orbit_plans):
    from email.message import Message

    plan_json = client.get(f"/api/projects/{project}/plans/{orbit_plans[0]}/versions/1").content
    r = client.post(f"/api/projects/{project}/plans/upload", files={"file": ("p.json", plan_json)},
                    data={"model_id": str(model), "name": "Façade Süd / Ост 2"})
    assert r.status_code == 201, r.text
    export = client.get(f"/api/projects/{project}/plans/{r.json()['id']}/versions/1/export", params={"format": "geojson"})
    assert export.status_code == 200
    header = Message()
    header["content-disposition"] = export.headers["content-disposition"]
    assert "filename*=utf-8''" in export.headers["content-disposition"].lower()  # RFC 5987
    assert header.get_filename() == "Façade_Süd_Ост_2_v1.geojson"  # decoded by the standard library's parser

def test_editing_makes_version_2_and_keeps_version_1(client, project, orbit_plans, data_dir):
    pid = orbit_plans[0]
    v1 = client.get(f"/api/projects/{project}/plans/{pid}/versions/1").json()
    edited = json.loads(json.dumps(v1))
    del edited["frames"][3]                                       # delete a frame
    edited["frames"][0]["position"][2] += 2.0                     # move one
    edited["frames"].insert(5, json.loads(json.dumps(edited["frames"][5])) | {"name": "extra"})  # insert one
    edited.pop("missions", None)
    r = client.put(f"/api/projects/{project}/plans/{pid}", json=edited, params={"note": "moved, deleted, inserted"})
    assert r.status_code == 201, r.text
    plan = r.json()
    assert plan["latest_version"] == 2 and [v["number"] for v in plan["versions"]] == [1, 2]
    assert plan["versions"][1]["note"] == "moved, deleted, inserted"
    assert client.get(f"/api/projects/{project}/plans/{pid}/versions/1").json() == v1
    v2 = client.get(f"/api/projects/{project}/plans/{pid}/versions/2").json()
    assert len(v2["frames"]) == len(v1["frames"]) and v2["frames"][5]["name"] == "extra"
    assert v2["frames"][0]["position"][2] == pytest.approx(v1["frames"][0]["position"][2] + 2.0)
    bad = json.loads(json.dumps(v1))
    bad["frames"][2]["rotation"] = [[1, 0, 0], [0, 1, 0], [0, 0, 3]]
    r = client.put(f"/api/projects/{project}/plans/{pid}", json=bad)
    assert r.status_code == 422 and "frame 2" in r.json()["detail"] and "orthonormal" in r.json()["detail"]
    assert client.get(f"/api/projects/{project}/plans/{pid}").json()["latest_version"] == 2
    assert client.get(f"/api/projects/{project}/plans/{pid}/versions/3").status_code == 404


# --------------------------------------------------------------------------- evaluations
def test_concurrent_evaluations_match_the_library(client, project, model, orbit_plans, evaluations):
    from sightplan.evaluate import EvaluationSettings, evaluate
    from sightplan.model.load import load_model
    from sightplan.plan.format import plan_from_dict

    scene, _ = load_model("sample")
    seen = []
    for plan_id, started in zip(orbit_plans, evaluations):
        eid = started["evaluation"]["id"]
        ev = client.get(f"/api/projects/{project}/evaluations/{eid}").json()
        assert ev["status"] == "done" and ev["plan_id"] == plan_id and ev["plan_version"] == 1
        assert ev["progress_done"] == ev["progress_total"] == ev["metrics"]["frames"]
        plan = plan_from_dict(client.get(f"/api/projects/{project}/plans/{plan_id}/versions/1").json())
        ref = evaluate(scene, plan, EvaluationSettings(scale=SCALE, engine="embree"), cache_dir=False)
        p = ref.metrics.plan
        assert ev["metrics"]["VC_pct"] == pytest.approx(100 * p.VC)
        assert ev["metrics"]["VR"] == pytest.approx(p.VR) and ev["metrics"]["T"] == pytest.approx(p.T)
        rows = client.get(f"/api/projects/{project}/evaluations/{eid}/elements").json()["elements"]
        assert len(rows) == 154
        assert [r["VR_i"] for r in rows] == [int(ref.metrics.elements.VR[r["index"]]) for r in rows]
        seen.append(ev["metrics"]["VR"])
    assert seen[0] != seen[1]  # two different plans, two different results
    listed = client.get(f"/api/projects/{project}/evaluations").json()
    assert {e["id"] for e in listed} >= {s["evaluation"]["id"] for s in evaluations}


def test_events_stream_progress_then_done(client, project, model, orbit_plans):
    r = client.post(f"/api/projects/{project}/evaluations",
                    json={"plan_id": orbit_plans[1], "settings": {"scale": SCALE, "engine": "embree"}})
    assert r.status_code == 202
    job_id = r.json()["job"]["id"]
    events = []
    with client.stream("GET", f"/api/jobs/{job_id}/events") as s:
        assert s.headers["content-type"].startswith("text/event-stream")
        event = None
        for line in s.iter_lines():
            if line.startswith("event: "):
                event = line.removeprefix("event: ")
            elif line.startswith("data: "):
                events.append((event, json.loads(line.removeprefix("data: "))))
    assert events[0][0] == "progress" and events[-1][0] == "done"
    assert all(e == "progress" for e, _ in events[:-1])
    assert events[-1][1]["progress_done"] == events[-1][1]["progress_total"] == 8
    assert client.get(f"/api/jobs/{job_id}").json()["status"] == "done"
    assert any(j["id"] == job_id for j in client.get("/api/jobs", params={"project_id": project}).json())


def test_evaluation_refusals(client, project, model, orbit_plans):
    url = f"/api/projects/{project}/evaluations"
    r = client.post(url, json={"plan_id": orbit_plans[0], "settings": {"scale": 2}})
    assert r.status_code == 422 and "scale" in r.json()["detail"]
    assert client.post(url, json={"plan_id": orbit_plans[0], "version": 7}).status_code == 404
    assert client.post(url, json={"plan_id": 9999}).status_code == 404
    r = client.post(url, json={"plan_id": orbit_plans[0], "settings": {"omega": -1}})
    assert r.status_code == 422


def _raw(client, method: str, url: str, text: str):
    """A request whose JSON body is written as text: ``NaN`` and ``Infinity`` as a careless client sends them."""
    return client.request(method, url, content=text.encode(), headers={"content-type": "application/json"})


def test_absurd_numbers_are_refused_naming_field_and_value(client, project, model, orbit_plans, data_dir):
    """One frame at [1e308, 0, 5] (or NaN, or 50 km away) is refused; a plan file holding one anyway (written before
    the check) gives 422 on every read, never a 500 or a file with nan in it."""
    pid = orbit_plans[1]
    url = f"/api/projects/{project}/plans/{pid}"
    v1 = client.get(f"{url}/versions/1").json()
    before = client.get(url).json()["latest_version"]
    for position, words in (([1e308, 0, 5], ("position", "[1e308, 0, 5]", "out of range")),
                            ([50_000.0, 0, 5], ("position", "50000", "km from the model"))):
        bad = json.loads(json.dumps(v1))
        bad["frames"][0]["position"] = position
        r = client.put(url, json=bad)
        assert r.status_code == 422 and all(w in r.json()["detail"] for w in words), r.text
    text = json.dumps(v1).replace(json.dumps(v1["frames"][0]["position"]), "[NaN, 0, Infinity]", 1)
    r = _raw(client, "PUT", url, text)
    assert r.status_code == 422 and "[NaN, 0, Infinity]" in r.json()["detail"], r.text
    bad = json.loads(json.dumps(v1))
    bad["frames"][1]["time"] = 1e308
    r = client.put(url, json=bad)
    assert r.status_code == 422 and "time" in r.json()["detail"] and "1e308" in r.json()["detail"], r.text
    assert client.get(url).json()["latest_version"] == before  # nothing was stored
    # a version stored with such a frame before the check: every read of it is one 422, none writes nan
    assert client.put(url, json=v1).status_code == 201
    number = client.get(url).json()["latest_version"]
    stored = max((data_dir / "plans").iterdir(), key=lambda p: p.stat().st_mtime_ns)
    legacy = json.loads(stored.read_text())
    legacy["frames"][0]["position"] = [1e308, 0, 5]
    stored.write_text(json.dumps(legacy))
    for fmt in ("kml", "qgc", "wpml", "wpl", "litchi", "geojson"):
        for force in (False, True):
            r = client.get(f"{url}/versions/{number}/export", params={"format": fmt, "force": force, "aircraft":
                                                                       "m3e" if fmt == "wpml" else None})
            assert r.status_code == 422 and "1e308" in r.json()["detail"], (fmt, r.status_code, r.text[:200])
    r = client.get(f"{url}/versions/{number}/checks")
    assert r.status_code == 422 and "1e308" in r.json()["detail"], r.text
    r = client.post(f"/api/projects/{project}/evaluations", json={"plan_id": pid, "version": number,
                                                                  "settings": {"scale": SCALE}})
    assert r.status_code in (202, 422), r.text
    if r.status_code == 202:  # a queued evaluation of it fails with the reader's message
        assert "1e308" in wait_job(client, r.json()["job"]["id"])["error"]
    # the exports of a good version write finite numbers only
    r = client.get(f"{url}/versions/1/export", params={"format": "kml", "speed": "nan"})
    assert r.status_code == 422 and r.json()["detail"] == "speed: NaN is not a finite number", r.text
    r = client.get(f"{url}/versions/1/export", params={"format": "kml", "speed": "1e308"})
    assert r.status_code == 422 and "1e308" in r.json()["detail"], r.text
    r = client.get(f"{url}/versions/1/export", params={"format": "kml"})
    assert r.status_code == 200 and b"nan" not in r.content.lower()


def test_misleading_messages_now_say_what_is_wrong(client, project, model, orbit_plans):
    plans = f"/api/projects/{project}/plans"
    r = _raw(client, "POST", plans, f'{{"model_id": {model}, "template": "orbit", "safety_distance_m": NaN}}')
    assert r.status_code == 422 and r.json()["detail"] == "orbit.safety_distance_m: NaN is not a finite number"
    r = _raw(client, "POST", plans, f'{{"model_id": {model}, "template": "orbit", "vlos_radius_m": Infinity}}')
    assert r.status_code == 422 and r.json()["detail"] == "orbit.vlos_radius_m: Infinity is not a finite number"
    r = _raw(client, "POST", plans, f'{{"model_id": {model}, "template": "orbit", "vlos_radius_m": 1e308}}')
    assert r.status_code == 422 and "vlos_radius_m" in r.json()["detail"] and "1e308" in r.json()["detail"]
    r = _raw(client, "POST", plans, f'{{"model_id": {model}, "template": "orbit", "radius_m": [NaN]}}')
    assert r.status_code == 422 and "radius_m" in r.json()["detail"] and "NaN" in r.json()["detail"], r.text
    evaluations = f"/api/projects/{project}/evaluations"
    r = _raw(client, "POST", evaluations, f'{{"plan_id": {orbit_plans[0]}, "settings": {{"scale": NaN}}}}')
    assert r.status_code == 422 and r.json()["detail"] == "settings.scale: NaN is not a finite number"
    for huge in (10**30, 2**63):
        r = client.post(evaluations, json={"plan_id": huge})
        assert r.status_code in (404, 422) and str(huge) in r.json()["detail"], r.text
        assert "SQLite" not in r.json()["detail"] and "convert" not in r.json()["detail"]
    # ids in the path are plain ASCII whole numbers: a superscript two or Arabic-Indic digits are not
    for path in ("/api/projects/%C2%B2", f"/api/projects/{project}/plans/%D9%A1", "/api/jobs/%EF%BC%91",
                 f"/api/projects/{project}/plans/{orbit_plans[0]}/versions/%C2%B2"):
        r = client.get(path)
        assert r.status_code in (404, 422) and "whole number" in r.json()["detail"], (path, r.text)


def test_html_report_download(client, project, evaluations):
    from sightplan.errors import ReportError
    from sightplan.report.html import find_three

    eid = evaluations[0]["evaluation"]["id"]
    r = client.get(f"/api/projects/{project}/evaluations/{eid}/report.html")
    try:
        find_three()
    except ReportError:
        assert r.status_code == 503 and "make setup" in r.json()["detail"]
        return
    assert r.status_code == 200 and r.headers["content-type"].startswith("text/html")
    assert "attachment" in r.headers["content-disposition"]
    assert r.text.startswith("<!DOCTYPE html>") and "plan-metrics" in r.text


# --------------------------------------------------------------------------- exports
def test_exports_every_format(client, project, orbit_plans, data_dir):
    pid = orbit_plans[0]
    def kmz_per_mission(b: bytes) -> bool:
        outer = zipfile.ZipFile(BytesIO(b))
        return len(outer.namelist()) == 2 and all(
            "wpmz/waylines.wpml" in zipfile.ZipFile(BytesIO(outer.read(n))).namelist() for n in outer.namelist())

    for fmt, check in (("qgc", lambda b: len(zipfile.ZipFile(BytesIO(b)).namelist()) == 2),  # a file per mission
                       ("wpl", lambda b: len(zipfile.ZipFile(BytesIO(b)).namelist()) == 2),
                       ("wpml", kmz_per_mission),
                       ("litchi", lambda b: len(zipfile.ZipFile(BytesIO(b)).namelist()) == 2),
                       ("kml", lambda b: b"<kml" in b),
                       ("geojson", lambda b: json.loads(b)["type"] == "FeatureCollection")):
        if fmt in ("wpml", "geojson") and not geoid.available():  # their heights are WGS84 ellipsoidal
            if os.environ.get("CI"):
                require_geoid()  # a failure in CI; elsewhere the other formats are still checked
            continue
        extra = {"aircraft": "m3e"} if fmt == "wpml" else {}  # the plans' Phantom 4 Pro is no DJI Pilot 2 aircraft
        r = client.get(f"/api/projects/{project}/plans/{pid}/versions/1/export", params={"format": fmt, **extra})
        assert r.status_code == 200, (fmt, r.text)
        assert "attachment" in r.headers["content-disposition"] and check(r.content), fmt
    r = client.get(f"/api/projects/{project}/plans/{pid}/versions/1/export", params={"format": "wpml"})
    assert r.status_code == 422 and "m3e" in r.json()["detail"] and "Phantom 4 Pro" in r.json()["detail"]
    r = client.get(f"/api/projects/{project}/plans/{pid}/versions/1/export", params={"format": "wpl", "mission": 2})
    assert r.status_code == 200 and r.content.startswith(b"QGC WPL 110")
    assert b"\t115\t" in r.content  # ArduPilot by default: the headings as CONDITION_YAW
    r = client.get(f"/api/projects/{project}/plans/{pid}/versions/1/export",
                   params={"format": "wpl", "mission": 2, "autopilot": "px4"})
    assert r.status_code == 200 and b"\t115\t" not in r.content  # PX4 refuses CONDITION_YAW
    r = client.get(f"/api/projects/{project}/plans/{pid}/versions/1/export", params={"format": "dxf"})
    assert r.status_code == 422
    r = client.get(f"/api/projects/{project}/plans/{pid}/versions/1/export", params={"format": "kml", "mission": 9})
    assert r.status_code == 422 and "mission 9" in r.json()["detail"]
    assert not any((data_dir / "tmp").iterdir())  # no export folder is left behind, refused or downloaded


def test_export_without_georeference_is_422_naming_it(client, project, data_dir):
    r = client.post(f"/api/projects/{project}/models", files={"file": ("box.obj", CUBE_OBJ.encode())})
    mesh = r.json()["model"]["id"]
    assert wait_job(client, r.json()["job"]["id"])["status"] == "done"
    assert client.get(f"/api/projects/{project}/models/{mesh}").json()["georeferenced"] is False
    r = client.post(f"/api/projects/{project}/plans", json={"model_id": mesh, "template": "orbit", "radius_m": [10],
                                                             "height_m": [3], "step_deg": 90})
    assert r.status_code == 201, r.text
    plan_id = r.json()["id"]
    r = client.get(f"/api/projects/{project}/plans/{plan_id}/versions/1/export", params={"format": "kml"})
    assert r.status_code == 422 and "georeference" in r.json()["detail"] and f"model {mesh}" in r.json()["detail"]
    assert files_under(data_dir / "tmp") == set()
    # deleting the model removes its file; the plan stays, for no model
    stored = files_under(data_dir / "models")
    assert client.delete(f"/api/projects/{project}/models/{mesh}").status_code == 204
    assert len(files_under(data_dir / "models")) == len(stored) - 1
    assert client.get(f"/api/projects/{project}/plans/{plan_id}").json()["model_id"] is None
    assert client.delete(f"/api/projects/{project}/plans/{plan_id}").status_code == 204


# --------------------------------------------------------------------------- restart
def test_restart_keeps_everything_and_fails_interrupted_jobs(client, project, model, orbit_plans, evaluations,
                                                             data_dir):
    before = {u: client.get(u).json() for u in (
        "/api/projects", f"/api/projects/{project}/models", f"/api/projects/{project}/plans",
        f"/api/projects/{project}/evaluations", f"/api/projects/{project}/plans/{orbit_plans[0]}/versions/1",
        f"/api/projects/{project}/evaluations/{evaluations[0]['evaluation']['id']}/elements")}
    # a job a killed server left running
    engine = create_engine(f"sqlite:///{data_dir / 'sightplan.db'}")
    with engine.begin() as conn:
        conn.execute(text("INSERT INTO jobs (project_id, kind, status, progress_done, progress_total, message, "
                          "created_at) VALUES (:p, 'evaluate', 'running', 3, 12, 'evaluating', '2025-01-01 00:00:00')"),
                     {"p": project})
        stale = conn.execute(text("SELECT max(id) FROM jobs")).scalar_one()
    engine.dispose()
    with TestClient(create_app(ServerConfig(data_dir=data_dir))) as again:
        for url, body in before.items():
            assert again.get(url).json() == body, url
        job = again.get(f"/api/jobs/{stale}").json()
        assert job["status"] == "failed" and "interrupted" in job["error"]
        assert again.get(f"/api/jobs/{evaluations[0]['job']['id']}").json()["status"] == "done"


def test_delete_project_removes_its_files(tmp_path):
    data = tmp_path / "d"
    with TestClient(create_app(ServerConfig(data_dir=data))) as c:
        pid = c.post("/api/projects", json={"name": "p"}).json()["id"]
        r = c.post(f"/api/projects/{pid}/models", files={"file": ("box.obj", CUBE_OBJ.encode())})
        wait_job(c, r.json()["job"]["id"])
        mid = r.json()["model"]["id"]
        r = c.post(f"/api/projects/{pid}/plans", json={"model_id": mid, "template": "orbit", "radius_m": [10],
                                                         "height_m": [3], "step_deg": 90})
        assert r.status_code == 201
        assert files_under(data / "models") and files_under(data / "plans")
        assert c.delete(f"/api/projects/{pid}").status_code == 204
        assert files_under(data / "models") == set() and files_under(data / "plans") == set()
        assert c.get(f"/api/projects/{pid}/plans").status_code == 404


# --------------------------------------------------------------------------- serving
def test_other_addresses_than_loopback_mean_team_mode(tmp_path):
    for host in ("127.0.0.1", "::1", "localhost"):
        assert is_loopback(host) and not ServerConfig(data_dir=tmp_path, host=host).team
    for host in ("0.0.0.0", "192.168.1.20", "::"):
        assert not is_loopback(host) and ServerConfig(data_dir=tmp_path, host=host).team
    assert ServerConfig(data_dir=tmp_path, team=True).team


def test_real_server_starts_and_answers(tmp_path):
    port = free_port()
    env = {**os.environ, "PYTHONUNBUFFERED": "1"}
    proc = subprocess.Popen([sys.executable, "-m", "sightplan", "serve", "--port", str(port), "--data", str(tmp_path / "d")],
                            stdout=subprocess.PIPE, stderr=subprocess.STDOUT, env=env, text=True)
    output: list[str] = []
    reader = threading.Thread(target=lambda: output.extend(proc.stdout), daemon=True)  # type: ignore[arg-type]
    reader.start()
    try:
        deadline = time.monotonic() + 30
        info = None
        while time.monotonic() < deadline and proc.poll() is None:
            try:
                with urllib.request.urlopen(f"http://127.0.0.1:{port}/api/info", timeout=2) as r:
                    info = json.loads(r.read())
                    break
            except OSError:
                time.sleep(0.2)
        assert info is not None, "".join(output)
        assert info["mode"] == "single-user" and (tmp_path / "d" / "sightplan.db").is_file()
    finally:
        proc.terminate()
        proc.wait(timeout=15)
        reader.join(timeout=5)
    assert "single-user mode, no login" in "".join(output)


# --------------------------------------------------------------------------- hostile or broken requests
def test_hostile_requests_get_one_clear_4xx(tmp_path):
    with TestClient(create_app(ServerConfig(data_dir=tmp_path / "d", max_upload_bytes=1024 * 1024))) as c:
        pid = c.post("/api/projects", json={"name": "p"}).json()["id"]
        big = 10**20  # past a database integer
        for url in (f"/api/projects/{big}", f"/api/jobs/{big}", f"/api/projects/{pid}/plans/{big}",
                    f"/api/jobs?project_id={big}", f"/api/projects/{pid}/plans/1/versions/{big}"):
            r = c.get(url)
            assert r.status_code == 404 and "not found" in r.json()["detail"], url
        r = c.post(f"/api/projects/{pid}/plans", json={"model_id": big, "template": "orbit"})
        assert r.status_code == 422 and "out of range" in r.json()["detail"]
        r = c.post(f"/api/projects/{pid}/plans/upload", files={"file": ("deep.json", b"[" * 100_000)})
        assert r.status_code == 422 and "nested too deeply" in r.json()["detail"]

        def chunks():  # a multipart body sent in chunks, without a length: refused once past the limit
            yield b'--XX\r\nContent-Disposition: form-data; name="file"; filename="big.ifc"\r\n\r\n'
            for _ in range(64):
                yield b"x" * (1 << 20)

        r = c.post(f"/api/projects/{pid}/models", content=chunks(),
                   headers={"content-type": "multipart/form-data; boundary=XX"})
        assert r.status_code == 413 and "limit of 1 MB" in r.json()["detail"]
        assert not any((tmp_path / "d" / "tmp").iterdir()) and not any((tmp_path / "d" / "models").iterdir())
        # single-user mode answers only its loopback names, and refuses changes from other sites' pages
        r = c.get("/api/projects", headers={"host": "evil.example"})
        assert r.status_code == 400 and "loopback" in r.json()["detail"]
        r = c.post("/api/projects", json={"name": "x"}, headers={"origin": "https://evil.example"})
        assert r.status_code == 403 and "another site" in r.json()["detail"]
        r = c.post("/api/projects", json={"name": "mine"}, headers={"host": "127.0.0.1:8000",
                                                                     "origin": "http://127.0.0.1:8000"})
        assert r.status_code == 201
        assert [p["name"] for p in c.get("/api/projects").json()] == ["p", "mine"]
