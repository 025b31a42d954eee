"""An optimisation job takes the flight settings of the plan form as a template plan does: its plan takes off from
the ground station given, is split for the aircraft given, and records the flight it was made with."""

from __future__ import annotations

import io

import numpy as np
import pytest
import trimesh

pytest.importorskip("fastapi")

from fastapi.testclient import TestClient  # noqa: E402

from sightplan.camera.catalogue import get_camera  # noqa: E402
from sightplan.model.load import load_model  # noqa: E402
from sightplan.optimize import Budget, OptimizeSettings, Targets, optimize  # noqa: E402
from sightplan.plan.checks import battery  # noqa: E402
from sightplan.plan.checks.feasibility import FlightSettings  # noqa: E402
from sightplan.web.app import create_app  # noqa: E402
from sightplan.web.config import ServerConfig  # noqa: E402
from web_support import upload_model, wait_job  # noqa: E402

STATION = [30.0, -20.0, 1.5]  # south-east of the 12 × 8 × 6 m box, on the ground (the box stands on z = 0)


@pytest.fixture(scope="module")
def client(tmp_path_factory):
    with TestClient(create_app(ServerConfig(data_dir=tmp_path_factory.mktemp("opt") / "d"))) as c:
        yield c


def test_an_optimisation_takes_off_from_the_ground_station_given(client, tmp_path):
    mesh = trimesh.creation.box((12, 8, 6), trimesh.transformations.translation_matrix((6, 4, 3)))
    buf = io.BytesIO()
    mesh.export(buf, file_type="obj")
    pid = client.post("/api/projects", json={"name": "station"}).json()["id"]
    mid = upload_model(client, pid, "box.obj", data=buf.getvalue())
    body = {"model_id": mid, "k": 2, "budget_frames": 14, "scale": 0.05, "ground_station": [STATION],
            "aircraft": "m3e", "vlos_radius_m": 300}
    r = client.post(f"/api/projects/{pid}/plans/optimize", json=body)
    assert r.status_code == 202, r.text
    job = wait_job(client, r.json()["id"], timeout_s=300)
    assert job["status"] == "done", job
    web = client.get(f"/api/projects/{pid}/plans/{job['plan_id']}/versions/1").json()
    assert web["missions"] and all(m["ground_station"] == STATION for m in web["missions"])
    assert web["parameters"]["takeoff_m"] == pytest.approx([30.0, -20.0, 0.0])  # on the ground under the station
    assert web["parameters"]["flight"] == {"safety_distance_m": 10.0, "vlos_radius_m": 300, "altitude_limit_m": 120.0,
                                           "aircraft": "m3e", "min_height_m": 2.0}
    # the plan the library makes with the same flight settings: the same frames, split alike
    path = tmp_path / "box.obj"
    mesh.export(path)
    flight = FlightSettings(safety_distance_m=10.0, vlos_radius_m=300.0, ground_stations=np.array([STATION]),
                            aircraft=battery.AIRCRAFT["m3e"], min_height_m=2.0)
    ref = optimize(load_model(path)[0], get_camera("p4p"), Targets(k=2), Budget(frames=14), flight=flight,
                   settings=OptimizeSettings(scale=0.05, cache_dir=False))
    assert np.allclose([f["position"] for f in web["frames"]], ref.plan.C_world)
    assert [m["frames"] for m in web["missions"]] == [[m.start, m.stop] for m in ref.plan.missions]
    # and without a station the take-off is elsewhere: a corner of the plan's region
    r = client.post(f"/api/projects/{pid}/plans/optimize", json={k: v for k, v in body.items() if k != "ground_station"})
    job = wait_job(client, r.json()["id"], timeout_s=300)
    other = client.get(f"/api/projects/{pid}/plans/{job['plan_id']}/versions/1").json()
    assert other["parameters"]["takeoff_m"][:2] != pytest.approx(STATION[:2])


@pytest.mark.bench  # a browser and an optimisation (12 s); the API's optimisation tests stay in make test
def test_the_page_s_optimise_form_sends_the_ground_stations_of_the_flight_settings(tmp_path):
    """In Chromium: a ground station typed in the plan form's flight settings goes with the Optimise request, and
    the plan the job makes takes off from it."""
    from browser_support import Server, launch_browser, open_page

    server = Server(tmp_path / "data")
    try:
        project = server.request("POST", "/api/projects", {"name": "station"})["id"]
        mesh = trimesh.creation.box((12, 8, 6), trimesh.transformations.translation_matrix((6, 4, 3)))
        buf = io.BytesIO()
        mesh.export(buf, file_type="obj")
        res = server.upload(f"/api/projects/{project}/models", "box.obj", buf.getvalue())
        assert server.wait_job(res["job"]["id"])["status"] == "done"
        with launch_browser() as browser:
            ctx, page, problems = open_page(browser, server, init_script=f"localStorage.setItem('sightplan.project', "
                                                                         f"'{project}')")
            try:
                page.wait_for_function("window.sightplanTest && document.querySelector('#plan-camera').options.length")
                page.click("#plan-new summary")
                page.fill("#plan-stations", ", ".join(str(v) for v in STATION))
                page.click("#plan-optimize summary")
                page.fill("#optimize-k", "2")
                page.fill("#optimize-frames", "14")
                page.fill("#optimize-scale", "0.05")
                with page.expect_request(lambda r: r.method == "POST" and r.url.endswith("/plans/optimize")) as sent:
                    page.click("#optimize-run")
                body = sent.value.post_data_json
                assert body["ground_station"] == [STATION] and body["k"] == 2, body
                job = server.wait_job(sent.value.response().json()["id"], timeout_s=300)
                assert job["status"] == "done", job
                plan = server.get(f"/api/projects/{project}/plans/{job['plan_id']}/versions/1")
                assert all(m["ground_station"] == STATION for m in plan["missions"])
                assert plan["parameters"]["takeoff_m"][:2] == pytest.approx(STATION[:2])
                assert not [p for p in problems if "page error" in p], problems
            finally:
                ctx.close()
    finally:
        server.stop()
