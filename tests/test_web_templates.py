"""Every template through the web API, with the flight settings of the plan form (aircraft, VLOS radius, ground
station, altitude limit): the same plans as the library's templates and checks."""

from __future__ import annotations

import io

import numpy as np
import pytest
import trimesh

pytest.importorskip("fastapi")

from fastapi.testclient import TestClient  # noqa: E402

from sightplan.camera.catalogue import get_camera  # noqa: E402
from sightplan.model.load import load_model, sample_model_path  # noqa: E402
from sightplan.plan.checks.feasibility import FlightSettings, plan_flights  # noqa: E402
from sightplan.plan.templates import indoor_route  # noqa: E402
from sightplan.web.app import create_app  # noqa: E402
from sightplan.web.config import ServerConfig  # noqa: E402
from web_support import upload_model  # noqa: E402


def box(size, corner):
    return trimesh.creation.box(size, trimesh.transformations.translation_matrix(np.add(corner, np.divide(size, 2))))




@pytest.fixture(scope="module")
def client(tmp_path_factory):
    with TestClient(create_app(ServerConfig(data_dir=tmp_path_factory.mktemp("tpl") / "d"))) as c:
        yield c




def test_bridge_template_gives_the_hand_counted_frames(client):
    """A 60 × 10 m deck with its underside at 8 m on two piers; passes g = 15 m + √(1.5² + 0.5²) + 0.01 = 16.59 m
    off the axis (the safety distance plus a GNSS drone's position error). Side passes: frames 2·g·0.75·0.2 = 4.98 m
    apart → 14 per pass, 4 layers per side (2·g·0.5·0.2 = 3.32 m apart from the 2.51 m minimum height, 2 m plus
    the 0.5 m vertical error plus 1 cm, to the 10 m top) → 112 frames. Under the deck, 3 m below it (the default
    clearance): 2·3·0.5·0.2 = 0.6 m apart → 60 / 0.6 + 1 = 101 frames. 213 in all."""
    pid = client.post("/api/projects", json={"name": "bridge"}).json()["id"]
    mesh = trimesh.util.concatenate([box((60, 10, 2), (0, -5, 8)), box((4, 2, 8), (28, 3, 0)),
                                     box((4, 2, 8), (28, -5, 0))])
    buf = io.BytesIO()
    mesh.export(buf, file_type="obj")
    mid = upload_model(client, pid, "bridge.obj", data=buf.getvalue())
    r = client.post(f"/api/projects/{pid}/plans", json={
        "model_id": mid, "template": "bridge", "axis": [[0, 0], [60, 0]], "safety_distance_m": 15, "height_m": [],
        "aircraft": "m300", "vlos_radius_m": 0, "altitude_limit_m": 0})
    assert r.status_code == 201, r.text
    plan = client.get(f"/api/projects/{pid}/plans/{r.json()['id']}/versions/1").json()
    assert len(plan["frames"]) == 213 and plan["parameters"]["template"] == "bridge"
    assert plan["parameters"]["deck_z"] == pytest.approx(8.0) and plan["parameters"]["under_deck_z"] == pytest.approx(5.0)
    bad = client.post(f"/api/projects/{pid}/plans", json={"model_id": mid, "template": "bridge", "axis": [[0, 0]]})
    assert bad.status_code == 422 and "axis" in bad.json()["detail"]


def test_route_and_flight_settings_match_the_library(client):
    pid = client.post("/api/projects", json={"name": "duplex"}).json()["id"]
    mid = upload_model(client, pid, sample_model_path(), "duplex.ifc")
    scene, _ = load_model("sample")
    points = [[2.0, 2.0, 1.6], [12.0, 2.0, 1.6], [12.0, 6.0, 1.6]]
    r = client.post(f"/api/projects/{pid}/plans", json={"model_id": mid, "template": "route", "points": points,
                                                        "step_m": 1.0, "camera": "insta360-x3"})
    assert r.status_code == 201, r.text
    route = client.get(f"/api/projects/{pid}/plans/{r.json()['id']}/versions/1").json()
    assert len(route["frames"]) == len(indoor_route(get_camera("insta360-x3"), points, 1.0)) == 15  # 14 m at 1 m
    tiny = client.post(f"/api/projects/{pid}/plans", json={"model_id": mid, "template": "route", "points": points,
                                                           "step_m": 1e-300})
    assert tiny.status_code == 422 and "step" in tiny.json()["detail"]  # the schema bounds the step, as the form does
    # a drone orbit flown from a given pilot position with a short sight line: the library's split
    station = [[-30.0, -30.0, 0.0]]
    body = {"model_id": mid, "template": "orbit", "radius_m": [25], "height_m": [8.0], "step_deg": 10, "vlos_radius_m": 60,
            "ground_station": station, "aircraft": "m3e"}
    r = client.post(f"/api/projects/{pid}/plans", json=body)
    assert r.status_code == 201, r.text
    served = client.get(f"/api/projects/{pid}/plans/{r.json()['id']}/versions/1").json()
    from sightplan.plan.checks.battery import AIRCRAFT
    from sightplan.plan.templates import orbit

    ref = plan_flights(scene, orbit(scene, get_camera("p4p"), [25], [8.0], step_deg=10),
                       FlightSettings(safety_distance_m=10, vlos_radius_m=60, ground_stations=np.array(station),
                                      aircraft=AIRCRAFT["m3e"])).plan
    assert [m["frames"] for m in served["missions"]] == [[m.start, m.stop] for m in ref.missions]
    assert served["missions"][0]["ground_station"] == pytest.approx(station[0])
    for bad, word in (({"aircraft": "jumbo"}, "aircraft"), ({"vlos_radius_m": 5, "safety_distance_m": 10}, "VLOS")):
        r = client.post(f"/api/projects/{pid}/plans", json=body | bad)
        assert r.status_code == 422 and word in r.json()["detail"], r.text


def test_the_flight_checks_use_the_settings_the_plan_was_made_with(client):
    pid = client.post("/api/projects", json={"name": "checks"}).json()["id"]
    mid = upload_model(client, pid, sample_model_path(), "duplex.ifc")
    points = [[2.0, 2.0, 1.6], [12.0, 2.0, 1.6], [12.0, 6.0, 1.6]]
    route = client.post(f"/api/projects/{pid}/plans", json={"model_id": mid, "template": "route", "points": points,
                                                            "step_m": 1.0, "camera": "insta360-x3"}).json()["id"]
    data = client.get(f"/api/projects/{pid}/plans/{route}/versions/1").json()
    assert data["parameters"]["flight"] == {"safety_distance_m": 0.3, "vlos_radius_m": 0.0, "altitude_limit_m": 0.0,
                                            "aircraft": "walker-360"}
    checks = client.get(f"/api/projects/{pid}/plans/{route}/versions/1/checks").json()
    # walked indoors: no line of sight to keep, 0.3 m clearance, a walker's battery
    assert checks["vlos_radius_m"] is None and checks["safety_distance_m"] == 0.3
    assert all(checks["in_sight"]) and not any("sight" in v or "altitude" in v for v in checks["violations"])
    body = {"model_id": mid, "template": "orbit", "radius_m": [25], "height_m": [8.0], "step_deg": 30, "vlos_radius_m": 60,
            "safety_distance_m": 6}
    orbit_id = client.post(f"/api/projects/{pid}/plans", json=body).json()["id"]
    checks = client.get(f"/api/projects/{pid}/plans/{orbit_id}/versions/1/checks").json()
    assert checks["vlos_radius_m"] == 60 and checks["safety_distance_m"] == 6
    wider = client.get(f"/api/projects/{pid}/plans/{orbit_id}/versions/1/checks", params={"vlos_radius_m": 400}).json()
    assert wider["vlos_radius_m"] == 400


def test_the_command_line_and_the_api_make_the_same_plan(client, tmp_path):
    """One dispatch (plan.templates.registry) behind `sightplan plan` and POST …/plans: the same orbit around the
    Duplex, with the same flight settings, has the same frames, missions and take-off point either way."""
    import json

    from test_cli import run_cli

    out = tmp_path / "orbit.json"
    res = run_cli("plan", "orbit", "sample", "--radius", "25", "--height", "8", "--step", "30", "-o", str(out),
                  cwd=tmp_path)
    assert res.returncode == 0, res.stderr
    cli = json.loads(out.read_text())
    pid = client.post("/api/projects", json={"name": "same"}).json()["id"]
    mid = upload_model(client, pid, sample_model_path())
    r = client.post(f"/api/projects/{pid}/plans", json={"model_id": mid, "template": "orbit", "radius_m": [25],
                                                        "height_m": [8], "step_deg": 30})
    assert r.status_code == 201, r.text
    web = client.get(f"/api/projects/{pid}/plans/{r.json()['id']}/versions/1").json()
    assert len(cli["frames"]) == len(web["frames"]) == 12
    assert np.allclose([f["position"] for f in cli["frames"]], [f["position"] for f in web["frames"]])
    assert [m["frames"] for m in cli["missions"]] == [m["frames"] for m in web["missions"]]
    assert np.allclose([m["ground_station"] for m in cli["missions"]], [m["ground_station"] for m in web["missions"]])
    assert cli["parameters"]["takeoff_m"] == pytest.approx(web["parameters"]["takeoff_m"])
    assert cli["parameters"]["checks"]["settings"] == web["parameters"]["checks"]["settings"]


def test_an_optimised_plan_from_the_api_is_the_librarys(client, tmp_path):
    """POST /plans/optimize runs as a job and makes a plan of one version: the plan `optimize` makes with the same
    settings (the same frames), checked; bad input is refused before the job."""
    from sightplan.optimize import Budget, OptimizeSettings, Targets, optimize
    from sightplan.plan.checks.feasibility import FlightSettings
    from web_support import wait_job

    pid = client.post("/api/projects", json={"name": "optimised"}).json()["id"]
    mesh = box((12, 8, 6), (0, 0, 0))
    buf = io.BytesIO()
    mesh.export(buf, file_type="obj")
    mid = upload_model(client, pid, "box.obj", data=buf.getvalue())
    body = {"model_id": mid, "k": 2, "budget_frames": 14, "scale": 0.05}
    r = client.post(f"/api/projects/{pid}/plans/optimize", json=body)
    assert r.status_code == 202 and r.json()["kind"] == "optimize", r.text
    job = wait_job(client, r.json()["id"], timeout_s=300)
    assert job["status"] == "done" and job["plan_id"] and "targets met" in job["message"], job
    plan = client.get(f"/api/projects/{pid}/plans/{job['plan_id']}").json()
    assert plan["source"] == "optimize (p4p)" and len(plan["versions"]) == 1
    web = client.get(f"/api/projects/{pid}/plans/{plan['id']}/versions/1").json()
    scene = load_model(_write(mesh, tmp_path))[0]
    ref = optimize(scene, get_camera("p4p"), Targets(k=2), Budget(frames=14), flight=FlightSettings(safety_distance_m=10),
                   settings=OptimizeSettings(scale=0.05, cache_dir=False))
    assert len(web["frames"]) == len(ref.plan) <= 14
    assert np.allclose([f["position"] for f in web["frames"]], ref.plan.C_world)
    assert web["parameters"]["checks"]["ok"] is True
    for bad, word in (({"camera": "x3"}, "perspective"), ({"aircraft": "jumbo"}, "aircraft"), ({"k": 0}, "k")):
        r = client.post(f"/api/projects/{pid}/plans/optimize", json=body | bad)
        assert r.status_code == 422 and word in r.text, r.text


def _write(mesh, folder):
    path = folder / "box.obj"
    mesh.export(path)
    return path


def test_an_optimisation_job_s_progress_only_goes_forward():
    """Every stage optimize() reports has its band of the job's bar, so the bar never goes back (the aimed views'
    second round of casting included) and ends at 1."""
    import importlib

    from sightplan.web.worker import OPTIMIZE_STAGES, staged_progress

    assert set(importlib.import_module("sightplan.optimize.run").STAGES) == set(OPTIMIZE_STAGES)
    seen: list[float] = []
    progress = staged_progress(seen.append, OPTIMIZE_STAGES)
    for stage in OPTIMIZE_STAGES:
        n = 4 if stage.startswith("casting") else 1
        for i in range(n + 1):
            progress(stage, i, n)
    assert seen == sorted(seen) and seen[0] == 0.0 and seen[-1] == pytest.approx(1.0)
    assert seen[4] == pytest.approx(0.6) and seen[-3] == pytest.approx(0.9)  # candidates end where aimed views begin
