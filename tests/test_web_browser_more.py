"""More of the web page in Debian's Chromium (headless, software GL) through Playwright: the bridge template with a
ground station picked in the 3D view, a 4D schedule linked from the page with the date slider on the real endpoint and
an evaluation at that date, reality captures (a coloured point cloud streamed as 3D Tiles, a mesh as GLB) with an
evaluation that takes one as occluders, the selected element outlined, and team mode: login, members, roles, share
links and logout.

Every number the page shows is compared with the API's, and where it can be with a number known beforehand (the
hand-counted 213 frames of the bridge, the element states written into the CSV, the library's own evaluation at the
date). Screenshots of each step go to ``$SIGHTPLAN_TEST_ARTIFACTS`` (default ``test-artifacts/browser/``).
"""

from __future__ import annotations

import http.server
import io
import json
import math
import subprocess
import sys
import threading
from dataclasses import replace
from pathlib import Path

import numpy as np
import pytest
import trimesh
from PIL import Image

from browser_support import ARTIFACTS, VIEWPORT, Server, element_on_screen, launch_browser, open_page, shot, view_pixels
from sightplan.camera.catalogue import get_camera
from sightplan.model.load import load_model, sample_model_path
from sightplan.plan.templates import indoor_route

SCALE = 0.05
MAGENTA = (255, 0, 200)
PASSWORDS = {"olivia": "olivia-secret-1", "victor": "victor-secret-2"}


@pytest.fixture(scope="module")
def browser():
    with launch_browser() as b:
        yield b


@pytest.fixture(scope="module")
def tiles():
    """A tile server on the loopback address: every tile one magenta PNG, every request counted."""
    from PIL import Image

    png = io.BytesIO()
    Image.new("RGB", (256, 256), MAGENTA).save(png, "PNG")
    hits: list[str] = []

    class Tiles(http.server.BaseHTTPRequestHandler):
        def do_GET(self):
            hits.append(self.path)
            self.send_response(200)
            self.send_header("Content-Type", "image/png")
            self.send_header("Access-Control-Allow-Origin", "*")
            self.end_headers()
            self.wfile.write(png.getvalue())

        def log_message(self, *args):
            pass

    httpd = http.server.ThreadingHTTPServer(("127.0.0.1", 0), Tiles)
    threading.Thread(target=httpd.serve_forever, daemon=True).start()
    httpd.hits = hits
    yield httpd
    httpd.shutdown()


@pytest.fixture(scope="module")
def server(tmp_path_factory, tiles):
    basemap = f"http://127.0.0.1:{tiles.server_port}/tiles/{{z}}/{{x}}/{{y}}.png"
    s = Server(tmp_path_factory.mktemp("browser-more") / "data",
               extra_args=("--basemap", basemap, "--basemap-attribution", "loopback test tiles"))
    # the sample Duplex is tessellated in the background while the first test runs
    project = s.request("POST", "/api/projects", {"name": "Duplex 4D"})["id"]
    s.duplex = (project, s.upload(f"/api/projects/{project}/models", "duplex.ifc", sample_model_path().read_bytes()))
    yield s
    s.stop()


@pytest.fixture(scope="module")
def artifacts() -> Path:
    ARTIFACTS.mkdir(parents=True, exist_ok=True)
    return ARTIFACTS


@pytest.fixture(scope="module")
def duplex(server) -> tuple[int, int]:
    """A project with the sample Duplex, uploaded through the API when the server started."""
    project, res = server.duplex
    assert server.wait_job(res["job"]["id"])["status"] == "done"
    return project, res["model"]["id"]


def box(size, corner) -> trimesh.Trimesh:
    return trimesh.creation.box(size, trimesh.transformations.translation_matrix(np.add(corner, np.divide(size, 2))))


def obj_bytes(mesh: trimesh.Trimesh) -> bytes:
    buf = io.BytesIO()
    mesh.export(buf, file_type="obj")
    return buf.getvalue()


def open_project(browser, server, project: int, viewport: dict | None = None):
    return open_page(browser, server, init_script=f"localStorage.setItem('sightplan.project', '{project}')",
                     viewport=viewport)


def click_model_point(page, point) -> dict:
    """Click where the model point [x, y, z] is on screen; returns that screen point."""
    at = page.evaluate(f"window.sightplanTest.view.screenPoint({json.dumps(list(point))})")
    assert at["inView"], (point, at)
    page.mouse.click(at["x"], at["y"])
    return at


def wait_for(page, expression: str, timeout_s: float = 60) -> None:
    """Wait until ``expression`` holds in the page; an error message shown meanwhile fails at once, with its text."""
    page.wait_for_function(f"() => ({expression}) || document.querySelector('.msg.error')", timeout=timeout_s * 1000)
    errors = page.locator(".msg.error").all_inner_texts()
    assert not errors, errors


def metric_cells(page, evaluation: int) -> dict[str, str]:
    row = page.locator(f"#metrics-table tr[data-evaluation='{evaluation}']")
    return {k: row.locator(f"td[data-metric={k}]").inner_text() for k in ("VC_pct", "VR", "R_m_per_px", "O_deg")}


def api_cells(metrics: dict) -> dict[str, str]:
    return {"VC_pct": f"{metrics['VC_pct']:.2f}", "VR": f"{metrics['VR']:.2f}",
            "R_m_per_px": "—" if metrics["R_m_per_px"] is None else f"{metrics['R_m_per_px']:.4f}",
            "O_deg": "—" if metrics["O_deg"] is None else f"{metrics['O_deg']:.2f}"}


# --------------------------------------------------------------------------- (a) a bridge, a picked ground station
def test_bridge_plan_from_the_form_with_a_picked_ground_station(browser, server, artifacts):
    """A 60 × 10 m deck at z 8–10 on two piers; the axis [0, 0] → [60, 0] typed, 15 m off it: the 213 frames counted
    by hand in test_web_templates. The ground station is picked by clicking the ground at (30, −25, 0)."""
    mesh = trimesh.util.concatenate([box((60, 10, 2), (0, -5, 8)), box((4, 2, 8), (28, 3, 0)), box((4, 2, 8), (28, -5, 0))])
    project = server.request("POST", "/api/projects", {"name": "Bridge"})["id"]
    res = server.upload(f"/api/projects/{project}/models", "bridge.obj", obj_bytes(mesh))
    assert server.wait_job(res["job"]["id"])["status"] == "done"
    ctx, page, problems = open_project(browser, server, project)
    try:
        page.wait_for_function("document.body?.dataset.model", timeout=30_000)
        page.click("#plan-new summary")
        page.select_option("#plan-template", "bridge")
        assert page.is_visible("#plan-axis") and page.is_hidden("#plan-points") and page.is_visible("#plan-stations")
        page.select_option("#plan-camera", "p4p")
        page.fill("#plan-safety", "15")
        page.select_option("#plan-aircraft", "m300")
        assert page.locator("#plan-aircraft option[value=walker-360]").count() == 1  # the presets of /api/info

        # an axis point picked on the deck's top (the model), then the axis typed
        page.click("#pick-axis")
        click_model_point(page, [30, 0, 10])
        page.wait_for_function("document.querySelector('#plan-axis').value !== ''")
        x, y = (float(v) for v in page.input_value("#plan-axis").split(","))
        assert (x, y) == (pytest.approx(30, abs=0.3), pytest.approx(0, abs=0.3))
        page.click("#pick-axis")  # done picking
        page.fill("#plan-axis", "0, 0\n60, 0")
        page.dispatch_event("#plan-axis", "input")

        # a ground station picked on the ground south of the bridge
        page.click("#pick-stations")
        assert page.evaluate("document.body.dataset.picking") == "stations"
        click_model_point(page, [30, -25, 0])
        page.wait_for_function("document.querySelector('#plan-stations').value !== ''")
        station = [float(v) for v in page.input_value("#plan-stations").split(",")]
        assert station == [pytest.approx(30, abs=0.3), pytest.approx(-25, abs=0.3), pytest.approx(0, abs=1e-6)]
        markers = page.evaluate("window.sightplanTest.view.markers()")
        assert [m["points"] for m in markers] == [[[0, 0, 0], [60, 0, 0]], [station]]  # axis at the ground's level
        rgb = view_pixels(page, shot(page, artifacts, "20-bridge-form-picked"))
        orange = ((abs(rgb[..., 0] - 0xe6) < 30) & (abs(rgb[..., 1] - 0x7e) < 30) & (rgb[..., 2] < 90)).sum()
        green = ((rgb[..., 1] > rgb[..., 0] + 60) & (rgb[..., 1] > rgb[..., 2] + 20) & (rgb[..., 0] < 60)).sum()
        assert orange > 50 and green > 30, (orange, green)  # the axis line and dots, the station's dot
        page.click("#pick-stations")

        page.click("#plan-create")
        wait_for(page, "window.sightplanTest.view.planFrames() > 0")
        assert page.inner_text("#plan-summary").startswith("213 frames")
        assert page.evaluate("window.sightplanTest.view.planFrames()") == 213
        assert page.evaluate("window.sightplanTest.view.markers().length") == 0  # the form closed: no picked points drawn
        (plan,) = server.get(f"/api/projects/{project}/plans")
        v1 = server.get(f"/api/projects/{project}/plans/{plan['id']}/versions/1")
        assert len(v1["frames"]) == plan["versions"][0]["frames"] == 213
        assert v1["parameters"]["template"] == "bridge" and v1["parameters"]["deck_z"] == pytest.approx(8.0)
        assert v1["missions"][0]["ground_station"] == pytest.approx(station, abs=1e-9)
        assert {tuple(m["ground_station"]) for m in v1["missions"]} == {tuple(station)}
        page.wait_for_function("document.querySelector('#checks-summary').textContent.includes('VLOS')", timeout=30_000)
        shot(page, artifacts, "21-bridge-plan")

        # a walked route: two points picked on the ground, at the height typed (1.6 m above what was clicked)
        page.click("#plan-new summary")
        page.select_option("#plan-template", "route")
        assert page.input_value("#plan-safety") == "15" and page.is_hidden("#plan-axis")  # typed: kept
        page.fill("#plan-safety", "")  # the walker's default
        page.select_option("#plan-camera", "x3")
        page.select_option("#plan-aircraft", "")  # the default: a walker for a route
        page.fill("#plan-stations", "")
        page.fill("#plan-step_m", "2")
        page.click("#pick-points")
        for point in ([10, -20, 0], [50, -20, 0]):
            click_model_point(page, point)
        page.wait_for_function("document.querySelector('#plan-points').value.split('\\n').length === 2")
        points = [[float(v) for v in line.split(",")] for line in page.input_value("#plan-points").splitlines()]
        assert np.allclose(points, [[10, -20, 1.6], [50, -20, 1.6]], atol=0.3) and points[0][2] == 1.6
        assert page.evaluate("window.sightplanTest.view.markers()")[0]["points"] == points
        shot(page, artifacts, "21b-route-form-picked")
        page.click("#plan-create")
        wait_for(page, "window.sightplanTest.planName() === 'route plan'")
        route = server.get(f"/api/projects/{project}/plans")[-1]
        expected = len(indoor_route(get_camera("x3"), points, 2.0))
        assert route["versions"][0]["frames"] == expected
        wait_for(page, f"window.sightplanTest.view.planFrames() === {expected}")  # drawn next
        assert expected == int(np.ceil(np.linalg.norm(np.subtract(points[1], points[0])) / 2 - 1e-9)) + 1  # ≈ 40 m / 2 + 1

        # an optimised plan: the camera and safety distance of the template form, k and the scale of its own form;
        # a job in the tray, then the plan it made listed and opened
        page.click("#plan-new summary")
        page.select_option("#plan-camera", "p4p")
        page.fill("#plan-safety", "15")
        page.click("#plan-optimize summary")
        page.fill("#optimize-k", "1")
        page.fill("#optimize-scale", "0.05")
        page.click("#optimize-run")
        wait_for(page, "(window.sightplanTest.planName() || '').startsWith('optimised')", timeout_s=240)
        made = server.get(f"/api/projects/{project}/plans")[-1]
        assert made["source"] == "optimize (p4p)" and made["versions"][0]["frames"] >= 1
        assert made["name"] == page.evaluate("window.sightplanTest.planName()") == "optimised (k = 1)"
        made_v1 = server.get(f"/api/projects/{project}/plans/{made['id']}/versions/1")
        assert made_v1["parameters"]["checks"]["ok"]
        # made with what the two forms hold, and drawn as the API gives it
        assert made_v1["parameters"]["safety_distance_m"] == 15 and made_v1["parameters"]["scale"] == 0.05
        assert made_v1["parameters"]["targets"]["k"] == 1
        wait_for(page, f"window.sightplanTest.view.planFrames() === {len(made_v1['frames'])}")
        assert not [p for p in problems if "page error" in p], problems
    finally:
        ctx.close()


# --------------------------------------------------------------------------- (b) a schedule and the date slider
@pytest.fixture(scope="module")
def csv_dates():
    """10 targets finished on 10 January 2025 (started the 2nd), 5 started on the 5th and finished on the 20th."""
    scene, _ = load_model("sample")
    targets = np.flatnonzero(scene.elements.is_target)
    done, busy = targets[:10], targets[10:15]
    rows = ["global_id,start,finish"]
    rows += [f"{scene.elements.global_id[i]},2025-01-02,2025-01-10" for i in done]
    rows += [f"{scene.elements.global_id[i]},2025-01-05,2025-01-20" for i in busy]
    return scene, done, busy, "\n".join(rows).encode()


def test_schedule_from_the_page_dates_the_site_and_the_evaluation(browser, server, artifacts, duplex, csv_dates):
    from sightplan.evaluate import EvaluationSettings, evaluate
    from sightplan.plan.format import plan_from_dict

    project, model = duplex
    scene, done, busy, csv = csv_dates
    z = scene.n_elements
    ctx, page, problems = open_project(browser, server, project)
    try:
        page.wait_for_function("document.body?.dataset.model", timeout=30_000)
        assert page.is_hidden("#date-panel")  # no schedule yet
        page.click("#schedule-new summary")
        page.set_input_files("#schedule-file", {"name": "dates.csv", "mimeType": "text/csv", "buffer": csv})
        page.click("#schedule-add")
        page.wait_for_selector("#schedule-report[data-status=ready]", timeout=60_000)
        (sched,) = server.get(f"/api/projects/{project}/schedules")
        assert sched["status"] == "ready" and sched["report"]["linked"] == 15
        assert (sched["first_date"], sched["last_date"]) == ("2025-01-02", "2025-01-20")
        assert page.inner_text("#schedule-report-lines") == "\n".join(sched["report"]["lines"])
        assert sched["report"]["lines"][0] == "schedule dates.csv: 15 tasks"  # the name it was uploaded as
        assert page.inner_text("#schedule-progress .label").startswith("linked")
        assert page.locator(f"#schedule-list li[data-schedule='{sched['id']}'][data-status=ready]").count() == 1

        # the slider on the real states endpoint: 2025-01-12 is day 10 of 2025-01-02 … 2025-01-20
        page.wait_for_selector("#date-panel:not([hidden])")
        assert page.get_attribute("#date-slider", "max") == "18"
        page.fill("#date-slider", "10")
        page.dispatch_event("#date-slider", "input")
        page.wait_for_function("document.getElementById('date-label').dataset.date === '2025-01-12'", timeout=30_000)
        states = server.get(f"/api/projects/{project}/models/{model}/states?date=2025-01-12&schedule_id={sched['id']}")
        label = page.eval_on_selector("#date-label", "e => ({...e.dataset})")
        shown = {"built": int(label["built"]), "in_progress": int(label["inProgress"]), "not_yet": int(label["notYet"])}
        assert shown == states["counts"] == {"built": z - 5, "in_progress": 5, "not_yet": 0}
        assert page.inner_text("#date-label") == f"2025-01-12: {z - 5} built, 5 in progress, 0 not yet"
        looks = page.evaluate(f"[...Array({z}).keys()].map((e) => window.sightplanTest.elementColour(e))")
        assert {e for e, look in enumerate(looks) if look["rgb"] == pytest.approx([0.96, 0.55, 0.12])} == set(busy)
        rgb = view_pixels(page, shot(page, artifacts, "22-schedule-site-at-2025-01-12"))
        orange = ((rgb[..., 0] > 200) & (abs(rgb[..., 1] - 140) < 40) & (rgb[..., 2] < 90)).sum()
        assert orange > 200, orange  # the elements in progress

        # an orbit of 8 frames, evaluated at the slider's date
        page.click("#plan-new summary")
        page.select_option("#plan-template", "orbit")
        page.fill("#plan-radius_m-1", "22")
        page.fill("#plan-height_m-1", "6")
        page.fill("#plan-step_deg", "45")
        page.click("#plan-create")
        wait_for(page, "window.sightplanTest.view.planFrames() === 8")
        page.fill("#eval-scale", str(SCALE))
        assert page.get_attribute("#eval-site", "data-date") == "2025-01-12"
        page.click("#eval-start")
        wait_for(page, "window.sightplanTest.evaluationId() !== null", 90)
        (ev,) = server.get(f"/api/projects/{project}/evaluations")
        assert ev["status"] == "done"
        assert ev["settings"]["fourd"] == {"date": "2025-01-12", "schedule_id": sched["id"], "basis": "finish",
                                           "unscheduled": "present"}
        assert metric_cells(page, ev["id"]) == api_cells(ev["metrics"])
        assert page.inner_text(f"#metrics-table tr[data-evaluation='{ev['id']}'] td[data-site]") == "at 2025-01-12"
        # the library at that date: the 5 elements in progress do not stand yet
        start = np.full(z, np.datetime64("NaT"), "datetime64[s]")
        finish = start.copy()
        start[done], finish[done] = np.datetime64("2025-01-02"), np.datetime64("2025-01-10")
        start[busy], finish[busy] = np.datetime64("2025-01-05"), np.datetime64("2025-01-20")
        at = replace(scene, elements=scene.elements.with_dates(start, finish)).at("2025-01-12")
        assert int(at.targets.sum()) == int(scene.elements.is_target.sum()) - 5
        plan = plan_from_dict(server.get(f"/api/projects/{project}/plans/{ev['plan_id']}/versions/1"))
        ref = evaluate(at, plan, EvaluationSettings(scale=SCALE, engine=ev["settings"]["engine"]), cache_dir=False)
        assert ev["metrics"]["VC_pct"] == pytest.approx(100 * ref.metrics.plan.VC)
        assert ev["metrics"]["VR"] == pytest.approx(ref.metrics.plan.VR)
        shot(page, artifacts, "23-evaluated-at-a-date")
        assert not [p for p in problems if "page error" in p], problems
    finally:
        ctx.close()


# --------------------------------------------------------------------------- (b2) on site: the pilot's position, the
# checked take-off and return, and an export that fails its checks
def test_pilot_position_take_off_and_return_and_export_anyway(browser, server, artifacts, duplex):
    from sightplan.geo import Georeference

    project, model = duplex
    scene = load_model("sample")[0]
    lat, lon, _ = Georeference.from_scene_metadata(scene.metadata).to_geodetic([[-30.0, -20.0, 0.0]])
    ctx, page, problems = open_project(browser, server, project)
    try:
        # the phone's position is the pilot's: 30 m west, 20 m south of the model's origin
        ctx.grant_permissions(["geolocation"], origin=server.url)
        ctx.set_geolocation({"latitude": float(lat[0]), "longitude": float(lon[0]), "accuracy": 3})
        page.click("#plan-new summary")
        page.select_option("#plan-template", "orbit")
        page.fill("#plan-name", "on site")
        page.fill("#plan-radius_m-1", "22")
        page.fill("#plan-height_m-1", "4")
        page.fill("#plan-step_deg", "30")
        page.click("#my-position")
        page.wait_for_function("document.querySelector('#plan-stations').value.includes(',')")
        page.select_option("#plan-position-error", "rtk")
        page.click("#plan-create")
        wait_for(page, "window.sightplanTest.view.planFrames() === 12 && window.sightplanTest.flightChecked()")
        plan = next(p for p in server.get(f"/api/projects/{project}/plans") if p["name"] == "on site")
        v1 = server.get(f"/api/projects/{project}/plans/{plan['id']}/versions/1")
        assert {tuple(np.round(m["ground_station"], 2)) for m in v1["missions"]} == {(-30.0, -20.0, 1.5)}
        assert v1["parameters"]["flight"]["position_error_m"] == [0.1, 0.1]
        # each mission's flight out and home, three legs each, drawn from the checks
        checks = server.get(f"/api/projects/{project}/plans/{plan['id']}/versions/1/checks")
        missions = len(checks["trajectory"])
        assert missions == len(v1["missions"]) >= 1
        assert page.evaluate("window.sightplanTest.view.flightLines()") == [
            {"name": "flight out", "segments": 3 * missions}, {"name": "flight home", "segments": 3 * missions}]
        assert "checked at ±0.1 m horizontal" in page.inner_text("#checks-summary")
        shot(page, artifacts, "23b-take-off-and-return")

        # version 2: frame 4 a metre from the west wall; the export is refused with the violations listed
        lo, hi = scene.bounds()
        v1["frames"][4]["position"] = [float(lo[0]) - 1.0, float((lo[1] + hi[1]) / 2), 3.0]
        server.request("PUT", f"/api/projects/{project}/plans/{plan['id']}?note=by+the+wall", v1)
        page.reload()
        page.wait_for_function("document.body?.dataset.state === 'ready'", timeout=30_000)
        page.select_option("#plan-select", str(plan["id"]))
        page.wait_for_function("window.sightplanTest.planId() !== null")
        page.select_option("#version-select", "2")
        wait_for(page, "window.sightplanTest.planVersion() === 2 && window.sightplanTest.flightChecked()")
        page.click("#export-qgc")
        page.wait_for_selector("#force-dialog[open]")
        listed = page.locator("#force-violations li").all_inner_texts()
        assert any("waypoint 4" in v for v in listed)
        shot(page, artifacts, "23c-export-refused")
        page.click("#force-cancel")
        page.wait_for_selector("#force-dialog", state="hidden")
        assert "Not exported" in page.inner_text("#messages")
        page.click("#export-qgc")
        page.wait_for_selector("#force-dialog[open]")
        with page.expect_download() as info:
            page.click("#force-export")
        assert info.value.suggested_filename.endswith((".plan", ".zip"))
        page.wait_for_function("document.querySelector('#messages').textContent.includes('despite')")
        page.locator("#messages .msg.error button").click()  # read: closed

        # version 1 evaluated as PX4 flies it, and under an RTK position error: the band below its row
        page.select_option("#version-select", "1")
        wait_for(page, "window.sightplanTest.planVersion() === 1")
        page.click("#sec-eval details summary")
        page.fill("#eval-scale", str(SCALE))
        page.select_option("#eval-as-flown", "px4")
        page.select_option("#eval-error", "rtk")
        page.fill("#eval-draws", "4")
        page.fill("#eval-omega", "400")
        page.click("#eval-start")
        wait_for(page, "document.querySelector('#metrics-table tr.band') !== null", 120)
        (ev,) = [e for e in server.get(f"/api/projects/{project}/evaluations") if e["settings"].get("as_flown")]
        assert ev["settings"]["robustness"]["draws"] == 4
        row = page.locator(f"#metrics-table tr[data-evaluation='{ev['id']}']")
        assert row.locator("td[data-site]").inner_text().startswith("as flown (PX4)")  # and the slider's date
        band = page.locator(f"#metrics-table tr[data-band-of='{ev['id']}']")
        vc = ev["metrics"]["robustness"]["metrics"]["VC_pct"]
        assert band.locator("td[data-band=VC_pct]").inner_text() == f"{vc['p5']:.2f}–{vc['p95']:.2f}"
        assert "4 draws, ±0.1 m / ±0.1 m" in band.inner_text()
        shot(page, artifacts, "23d-as-flown-with-band")
        # every metric label of the table says what it means, as the library's glossary does, with the thresholds
        # of the evaluation shown (Ω = 400 px here, not the default 625)
        from sightplan.metrics.glossary import glossary
        from sightplan.metrics.params import MetricParams

        wait_for(page, f"window.sightplanTest.evaluationId() === {ev['id']}")
        help_ = glossary(MetricParams(omega=400))
        titles = page.eval_on_selector_all("#metrics-table th[data-metric]",
                                           "ths => ths.map((t) => [t.dataset.metric, t.title])")
        assert len(titles) == 8 and all(t == help_[k]["text"] for k, t in titles), titles
        assert "400" in dict(titles)["VC_pct"] and "625" not in dict(titles)["VC_pct"]
        assert not [p for p in problems if "page error" in p], problems
    finally:
        ctx.close()


# --------------------------------------------------------------------------- (b3) on a phone, and on a desktop
# where every box of the page lies, its width and the canvas's height, read in one go
LAYOUT = """() => ({
  scrollWidth: document.documentElement.scrollWidth,
  canvas: document.querySelector('#canvas-box canvas').getBoundingClientRect().height,
  beyond: [...document.querySelectorAll('#missions-table td, #metrics-table td, #checks-summary')]
    .filter((n) => n.offsetParent && n.getBoundingClientRect().right > window.innerWidth + 0.5).length,
})"""


def test_the_page_on_a_phone_and_on_a_desktop(browser, server, artifacts, duplex):
    """At 375 × 812 nothing scrolls sideways, the 3D view fills most of the screen under folded toolbars, and the
    panels are sheets opened from the bottom bar, the flight checks' and the metrics' tables stacked within the
    screen's width; the same page at 1440 × 900 is the desktop's three columns."""
    project, model = duplex
    if not server.get(f"/api/projects/{project}/plans"):  # this test alone
        server.request("POST", f"/api/projects/{project}/plans", {"model_id": model, "template": "orbit",
                                                                   "radius_m": [22], "height_m": [6], "step_deg": 45})
    ctx, page, problems = open_project(browser, server, project, viewport={"width": 375, "height": 812})
    try:
        wait_for(page, "window.sightplanTest.flightChecked()")
        phone = page.evaluate(LAYOUT)
        assert phone["scrollWidth"] <= 375 and phone["canvas"] >= 0.6 * 812, phone
        assert page.is_hidden("#layer-toolbar") and page.is_hidden("#sidebar") and page.is_hidden("#bottom")
        shot(page, artifacts, "phone-375x812")
        page.click("#phone-bar button[data-sheet=checks]")
        page.wait_for_selector("#missions-table tbody tr")
        box = page.locator("#missions-table").bounding_box()
        assert box["x"] >= 0 and box["x"] + box["width"] <= 375 and page.is_visible("#checks-summary"), box
        assert page.get_attribute("#missions-table td:nth-child(6)", "data-label") == "battery"  # under its heading
        assert page.evaluate(LAYOUT)["beyond"] == 0
        shot(page, artifacts, "phone-375x812-checks")
        page.click("#phone-bar button[data-sheet=metrics]")
        metrics = page.evaluate(LAYOUT)
        assert metrics["scrollWidth"] <= 375 and metrics["beyond"] == 0, metrics
        shot(page, artifacts, "phone-375x812-metrics")
        # the plan sheet steps aside while a ground station is picked in the view
        page.click("#phone-bar button[data-sheet=plan]")
        page.click("#plan-new summary")
        page.click("#pick-stations")
        assert page.evaluate("document.body.dataset.sheet") == "" and page.is_hidden("#sidebar")
        page.keyboard.press("Escape")
        page.wait_for_selector("#sidebar", state="visible")
        page.click("#plan-new summary")
        # the map instead of the 3D view, across the screen, with the site drawn
        page.click("#phone-bar button[data-sheet='']")
        page.click("#view-switch button[data-view=map]")
        wait_for(page, "window.sightplanTest.map.ready()")
        box = page.locator("#map-canvas").bounding_box()
        assert box["width"] >= 360 and box["height"] >= 0.5 * 812 and page.evaluate(LAYOUT)["scrollWidth"] <= 375, box
        assert page.evaluate("window.sightplanTest.map.drawn('footprint').features.length") >= 1
        shot(page, artifacts, "phone-375x812-map")
        page.click("#view-switch button[data-view='3d']")
        # the same page on a desktop: sidebar, view, inspector and bottom tabs, the frame editing in the sidebar
        page.set_viewport_size({"width": 1440, "height": 900})
        page.evaluate("document.getElementById('sidebar').scrollTop = 0")
        page.wait_for_function("document.querySelector('#sec-edit').parentElement.id === 'sidebar'")
        for sel in ("#sidebar", "#inspector", "#bottom", "#layer-toolbar", "#sec-edit"):
            assert page.is_visible(sel), sel
        assert page.is_hidden("#phone-bar") and page.is_hidden("#view-bar")
        assert page.evaluate(LAYOUT)["scrollWidth"] == 1440
        shot(page, artifacts, "desktop-1440x900")
        assert not [p for p in problems if "page error" in p], problems
    finally:
        ctx.close()


# --------------------------------------------------------------------------- (c) reality captures
def ply_wall(n: int = 200_000) -> bytes:
    """A wall of blue points 5 m east of the house: x 14, y −20 … 2, z −1.5 … 6."""
    import plyfile

    rng = np.random.default_rng(3)
    vertex = np.empty(n, dtype=[("x", "f4"), ("y", "f4"), ("z", "f4"), ("red", "u1"), ("green", "u1"), ("blue", "u1")])
    vertex["x"] = 14.0 + rng.normal(0, 0.01, n)
    vertex["y"] = rng.uniform(-20, 2, n)
    vertex["z"] = rng.uniform(-1.5, 6, n)
    vertex["red"], vertex["green"], vertex["blue"] = 20, 40, 250
    buf = io.BytesIO()
    plyfile.PlyData([plyfile.PlyElement.describe(vertex, "vertex")]).write(buf)
    return buf.getvalue()


@pytest.mark.bench  # its API twin, test_web_reality.py's mesh capture that occludes, runs in make test
def test_reality_captures_are_drawn_beside_the_model_and_occlude(browser, server, artifacts, duplex):
    pytest.importorskip("plyfile")
    project, model = duplex
    server.request("POST", f"/api/projects/{project}/plans", {"model_id": model, "template": "orbit", "radius_m": [24],
                                                              "height_m": [5.0], "step_deg": 60})
    hoarding = box((2, 2, 3), (-8, -12, -1.5))  # a mesh west of the house
    ctx, page, problems = open_project(browser, server, project)
    try:
        page.wait_for_function("document.body?.dataset.model && window.sightplanTest.view.planFrames() !== null", timeout=30_000)
        if page.is_visible("#date-on"):
            page.uncheck("#date-on")  # the site as built
        for name, data in (("wall.ply", ply_wall()), ("hoarding.obj", obj_bytes(hoarding))):
            page.set_input_files("#reality-file", {"name": name, "mimeType": "application/octet-stream", "buffer": data})
            page.click("#reality-upload")
            page.wait_for_selector(f"#reality-list li[data-status=ready]:has-text('{name}')", timeout=90_000)
        cloud, mesh = server.get(f"/api/projects/{project}/reality")
        assert (cloud["kind"], cloud["points"], mesh["kind"], mesh["triangles"]) == ("points", 200_000, "mesh", 12)
        page.click("#view-fit")
        page.wait_for_function("""() => { const r = window.sightplanTest.view.realityInfo();
            return r.length === 2 && r.every((x) => x.shown && x.box) && r[0].pointsVisible > 0 && r[0].loading === 0; }""",
                               timeout=60_000)
        info = {r["kind"]: r for r in page.evaluate("window.sightplanTest.view.realityInfo()")}
        # placed in the model's frame: the boxes are the captures' bounds through the viewer's own mapping
        for kind, row, tol in (("points", cloud, 0.2), ("mesh", mesh, 1e-3)):
            corners = page.evaluate(f"[{json.dumps(row['bounds']['lo'])}, {json.dumps(row['bounds']['hi'])}]"
                                    ".map((p) => window.sightplanTest.view.toViewer(p))")
            expected = np.sort(np.array(corners), axis=0)
            assert np.allclose(info[kind]["box"], expected, atol=tol), (kind, info[kind]["box"], expected)
        assert info["mesh"]["triangles"] == 12
        assert 0 < info["points"]["pointsVisible"] <= 200_000
        rgb = view_pixels(page, shot(page, artifacts, "24-reality-captures"))
        blue = ((rgb[..., 2] > 200) & (rgb[..., 0] < 80) & (rgb[..., 1] < 110)).sum()
        tan = ((abs(rgb[..., 0] - 0xc9) < 45) & (abs(rgb[..., 1] - 0xa2) < 45) & (rgb[..., 2] < 120)).sum()
        assert blue > 3000 and tan > 100, (blue, tan)  # the wall's points in their own colour; the mesh
        # hidden by its toggle: no blue left
        page.uncheck(f"#reality-list li[data-reality='{cloud['id']}'] input[type=checkbox]")
        page.wait_for_timeout(300)
        rgb = view_pixels(page, shot(page, artifacts, "25-point-cloud-hidden"))
        assert ((rgb[..., 2] > 200) & (rgb[..., 0] < 80) & (rgb[..., 1] < 110)).sum() < blue / 50
        page.check(f"#reality-list li[data-reality='{cloud['id']}'] input[type=checkbox]")

        # an evaluation with the wall as occluders
        page.click("#sec-eval details summary")
        page.select_option("#eval-reality", str(cloud["id"]))
        assert "wall.ply as occluders" in page.inner_text("#eval-site")
        page.fill("#eval-scale", str(SCALE))
        page.click("#eval-start")
        wait_for(page, "window.sightplanTest.evaluation()?.settings.reality_id", 90)
        ev = [e for e in server.get(f"/api/projects/{project}/evaluations") if e["settings"].get("reality_id")][-1]
        assert ev["settings"]["reality_id"] == cloud["id"] and "fourd" not in ev["settings"]
        assert metric_cells(page, ev["id"]) == api_cells(ev["metrics"])
        assert page.inner_text(f"#metrics-table tr[data-evaluation='{ev['id']}'] td[data-site]") == "+ wall.ply"

        # (4) the selected element outlined in the 3D view
        classes = server.get(f"/api/projects/{project}/evaluations/{ev['id']}/feedback")["elements"]["ifc_class"]
        target = element_on_screen(page, [e for e, cls in enumerate(classes) if cls.startswith("IfcWall")])
        assert target is not None
        before = view_pixels(page, shot(page, artifacts, "26-before-selection"))
        page.mouse.click(target["x"], target["y"])
        page.wait_for_selector(f"#element-card[data-element='{target['e']}']:not([hidden])")
        assert page.evaluate("window.sightplanTest.view.highlightedElement()") == target["e"]
        after = view_pixels(page, shot(page, artifacts, "27-element-outlined"))

        def magenta(a):
            return ((a[..., 0] > 180) & (a[..., 1] < 120) & (a[..., 2] > 110)).sum()

        assert magenta(after) > magenta(before) + 300, (magenta(before), magenta(after))

        # a reload shows the captures again, in the frame of the model that arrives after them
        page.reload()
        page.wait_for_function("""() => { const r = document.body?.dataset.model && window.sightplanTest.view.realityInfo();
            return r && r.length === 2 && r.every((x) => x.shown && x.box) && r[0].pointsVisible > 0; }""",
                               timeout=60_000)
        again = {r["kind"]: r for r in page.evaluate("window.sightplanTest.view.realityInfo()")}
        for kind in ("points", "mesh"):
            assert np.allclose(again[kind]["box"], info[kind]["box"], atol=0.2), kind
        assert not [p for p in problems if "page error" in p], problems
    finally:
        ctx.close()


# --------------------------------------------------------------------------- (d) team mode
def add_user(data: Path, name: str) -> None:
    """``sightplan users add NAME --data DIR --password-stdin``."""
    r = subprocess.run([sys.executable, "-m", "sightplan", "users", "add", name, "--data", str(data), "--password-stdin"],
                       input=PASSWORDS[name] + "\n", capture_output=True, text=True, timeout=60)
    assert r.returncode == 0, r.stdout + r.stderr


def log_in(page, name: str, password: str | None = None) -> None:
    page.wait_for_selector("#login-dialog[open]")
    page.fill("#login-user", name)
    page.fill("#login-password", password or PASSWORDS[name])
    page.click("#login-submit")


@pytest.fixture(scope="module")
def team_server(tmp_path_factory):
    data = tmp_path_factory.mktemp("browser-team") / "data"
    for name in PASSWORDS:
        add_user(data, name)
    s = Server(data, ("--team",))
    yield s
    s.stop()


@pytest.mark.bench  # its API twins, test_web_access.py's login, roles and share links, run in make test
def test_team_mode_login_members_share_links_and_roles(browser, team_server, artifacts):
    server = team_server
    cube = box((6, 4, 3), (0, 0, 0))
    ctx, page, problems = open_page(browser, server, wait_ready=False)
    try:
        # not logged in: the page settles on 'login' (the session, the cameras and the templates read) and only then
        # opens the dialog; nothing else loads
        page.wait_for_function("document.body?.dataset.state === 'login'", timeout=30_000)
        assert page.is_visible("#login-dialog") and page.evaluate("document.querySelector('#login-dialog').open")
        shot(page, artifacts, "30-login-dialog")
        log_in(page, "olivia", "not-her-password")
        page.wait_for_selector("#login-error:not([hidden])")
        assert "wrong user name or password" in page.inner_text("#login-error")
        page.keyboard.press("Escape")  # the dialog stays
        assert page.is_visible("#login-dialog")
        log_in(page, "olivia")
        page.wait_for_function("document.body?.dataset.state === 'ready'", timeout=30_000)
        assert page.inner_text("#user-name") == "olivia" and page.is_visible("#logout")
        assert page.inner_text("#mode-badge") == "team mode"

        # her project: she owns it; a model and a plan
        page.fill("#project-name", "Team site")
        page.click("#project-create")
        page.wait_for_function("document.querySelector('#project-select').selectedOptions[0]?.text === 'Team site'")
        page.wait_for_function("document.getElementById('user-role').textContent === 'owner'")
        project = int(page.input_value("#project-select"))
        page.set_input_files("#model-file", {"name": "cube.obj", "mimeType": "text/plain", "buffer": obj_bytes(cube)})
        page.click("#model-upload")
        wait_for(page, "document.body?.dataset.model")
        page.click("#plan-new summary")
        page.select_option("#plan-template", "orbit")
        # two rings, a radius and a height a row: a third row added and removed again
        page.fill("#plan-radius_m-1", "12")
        page.fill("#plan-height_m-1", "3")
        page.click("#plan-add-ring")
        page.click("#plan-add-ring")
        page.fill("#plan-radius_m-3", "16")
        page.fill("#plan-height_m-3", "6")
        page.click("#plan-rows-ring tbody tr:nth-child(2) button")
        assert page.input_value("#plan-radius_m-2") == "16" and page.locator("#plan-rows-ring tbody tr").count() == 2
        page.fill("#plan-step_deg", "90")
        page.click("#plan-create")
        wait_for(page, "window.sightplanTest.view.planFrames() === 8")
        plan = page.evaluate("window.sightplanTest.planId()")
        v1 = page.request.get(f"{server.url}/api/projects/{project}/plans/{plan}/versions/1").json()
        assert (v1["parameters"]["radii_m"], v1["parameters"]["heights_m"]) == ([12, 16], [3, 6])
        rings = [(round(float(np.hypot(x - 3, y - 2)), 3), z) for x, y, z in (f["position"] for f in v1["frames"])]
        assert sorted(rings) == [(12, 3)] * 4 + [(16, 6)] * 4  # around the cube's centre (3, 2)

        # Victor joins as a viewer
        assert page.locator("#members-table tr[data-member=olivia][data-role=owner]").count() == 1
        page.fill("#member-name", "victor")
        page.select_option("#member-role", "viewer")
        page.click("#member-add")
        page.wait_for_selector("#members-table tr[data-member=victor][data-role=viewer]")
        members = page.request.get(f"{server.url}/api/projects/{project}/members").json()
        assert sorted((m["username"], m["role"]) for m in members) == [("olivia", "owner"), ("victor", "viewer")]
        shot(page, artifacts, "31-owner-members")

        # evaluated, then shared by a link, shown once, opened without an account as a read-only page, then revoked
        job = page.request.post(f"{server.url}/api/projects/{project}/evaluations", headers={"X-Sightplan-Request": "1"},
                                data={"plan_id": plan, "settings": {"scale": SCALE}}).json()["job"]["id"]
        for _ in range(600):
            if page.request.get(f"{server.url}/api/jobs/{job}").json()["status"] in ("done", "failed"):
                break
            page.wait_for_timeout(200)
        assert page.request.get(f"{server.url}/api/jobs/{job}").json()["status"] == "done"
        page.click("#share-box summary")
        page.click("#share-create")
        page.wait_for_selector("#share-new:not([hidden])")
        url = page.input_value("#share-url")
        assert url.startswith(f"{server.url}/shared/spl")
        link = int(page.get_attribute("#share-url", "data-link"))
        page.wait_for_selector(f"#share-links li[data-link='{link}'][data-state=active]")
        shot(page, artifacts, "32-share-link")
        stranger = browser.new_context(viewport=VIEWPORT, bypass_csp=True)
        try:
            other = stranger.new_page()
            sent = []
            other.on("request", lambda r: sent.append((r.method, r.url)))
            assert other.goto(url).status == 200
            wait_for(other, "document.body?.dataset.state === 'ready' && window.sightplanTest.evaluationId() !== null"
                            " && window.sightplanTest.view.modelTriangles() === 12")
            assert other.evaluate("window.sightplanTest.view.planFrames()") == 8
            assert "Shared plan “orbit plan”" in other.inner_text("#topbar")
            row = other.inner_text("#metrics-table tbody tr")
            assert row.startswith("orbit plan v1") and "\t8\t" in row
            other.click("button[data-tab=checks]")
            other.wait_for_selector("#missions-table tbody tr")
            other.click("button[data-tab=metrics]")
            shot(other, artifacts, "32b-share-view")
            # nothing that changes anything is on offer, and the page asked for nothing but reads
            for sel in ("#eval-start", "#plan-save", "#frame-delete", "#model-upload", "#model-delete",
                        "#project-create", "#share-create", "#plan-create", "#optimize-run", "#plan-upload",
                        "#schedule-add", "#reality-upload", "#member-add", "#move-apply", "#sec-edit", "#plan-new"):
                assert other.is_hidden(sel), sel
            other.click("button[data-tab=frames]")
            other.click("#frame-list tbody tr[data-frame='1']")
            wait_for(other, "window.sightplanTest.selectedFrame() === 1")
            assert {m for m, _ in sent} == {"GET"}, sorted({m for m, _ in sent})
            assert all("/api/projects" not in u for _, u in sent)
            assert other.context.request.get(f"{server.url}/api/projects/{project}").status == 401  # no account
            shared = other.context.request.get(url.replace("/shared/", "/api/shared/")).json()  # the JSON stays
            assert shared["plan"]["id"] == plan and shared["plan"]["versions"][0]["frames"] == 8
            page.click(f"#share-links li[data-link='{link}'] button")
            page.wait_for_selector(f"#share-links li[data-link='{link}'][data-state=revoked]")
            other.goto(url)
            wait_for(other, "document.body?.dataset.state === 'ready'")
            assert "revoked" in other.inner_text("#view-empty")
            assert other.context.request.get(url.replace("/shared/", "/api/shared/")).status == 404
        finally:
            stranger.close()
        links = page.request.get(f"{server.url}/api/projects/{project}/links").json()
        assert [(x["id"], x["revoked_at"] is not None) for x in links] == [(link, True)]

        # log out: the login dialog; Victor logs in and only reads
        page.click("#logout")
        page.wait_for_selector("#login-dialog[open]", timeout=30_000)
        shot(page, artifacts, "33-logged-out")
        log_in(page, "victor")
        page.wait_for_function("document.body?.dataset.state === 'ready' && document.body?.dataset.model", timeout=30_000)
        assert page.inner_text("#user-name") == "victor" and page.inner_text("#user-role") == "viewer"
        assert page.locator("#project-select option").all_inner_texts() == ["Team site"]
        page.wait_for_function("window.sightplanTest.view.planFrames() === 8", timeout=30_000)
        for sel in ("#model-upload", "#model-delete", "#eval-start", "#member-add"):
            assert page.is_disabled(sel) or page.is_hidden(sel), sel
        for sel in ("#plan-new", "#plan-upload-box", "#sec-edit", "#share-box", "#schedule-new", "#reality-file",
                    "#member-form", "#model-file"):
            assert page.is_hidden(sel), sel
        assert page.is_visible("#members-table") and page.locator("#members-table select").count() == 0
        assert page.is_visible("#export-qgc") and page.is_enabled("#export-qgc")  # reading stays
        page.click("button[data-tab=frames]")
        page.click("#frame-list tbody tr[data-frame='0']")
        page.wait_for_function("window.sightplanTest.selectedFrame() === 0")
        page.keyboard.press("Delete")  # the edit keys do nothing for a viewer
        assert page.evaluate("window.sightplanTest.frameCount()") == 8 and not page.evaluate("window.sightplanTest.dirty()")
        refused = page.request.post(f"{server.url}/api/projects/{project}/plans",
                                    data={"model_id": 1, "template": "orbit", "radius_m": [9], "height_m": [2]})
        assert refused.status == 403  # what the page does not offer, the API refuses
        shot(page, artifacts, "34-viewer")

        # a session that ends under the page: the next request brings up the login dialog
        ctx.clear_cookies()
        page.click("button[data-tab=frames]")
        page.click("#frame-list tbody tr[data-frame='1']")
        page.wait_for_selector("#login-dialog[open]", timeout=30_000)
        log_in(page, "victor")
        page.wait_for_function("document.body?.dataset.state === 'ready'", timeout=30_000)
        page.click("#logout")
        page.wait_for_selector("#login-dialog[open]", timeout=30_000)
        shot(page, artifacts, "35-viewer-logged-out")
        assert not [p for p in problems if "page error" in p], problems
    finally:
        ctx.close()


def test_account_dialog_tokens_and_password(browser, team_server, artifacts):
    server = team_server
    ctx, page, problems = open_page(browser, server, wait_ready=False)
    try:
        log_in(page, "victor")
        page.wait_for_function("document.body?.dataset.state === 'ready'", timeout=30_000)
        page.click("#account")
        page.wait_for_selector("#account-dialog[open]")
        page.fill("#token-name", "nightly export")
        page.click("#token-create")
        page.wait_for_selector("#token-new:not([hidden])")
        secret = page.input_value("#token-secret")
        token_id = page.get_attribute("#token-secret", "data-token")
        assert secret.startswith("spt_")
        page.wait_for_selector(f"#token-list li[data-token='{token_id}']")
        assert "nightly export" in page.inner_text(f"#token-list li[data-token='{token_id}']")
        shot(page, artifacts, "36-account-token")
        bearer = {"Authorization": f"Bearer {secret}"}
        fresh = browser.new_context()  # no cookie: the token alone
        try:
            me = fresh.request.get(f"{server.url}/api/auth/me", headers=bearer)
            assert me.status == 200 and me.json()["username"] == "victor"
            page.click(f"#token-list li[data-token='{token_id}'] button")
            page.wait_for_selector(f"#token-list li[data-token='{token_id}']", state="detached")
            assert fresh.request.get(f"{server.url}/api/auth/me", headers=bearer).status == 401
        finally:
            fresh.close()
        # a wrong current password: said in the dialog, which stays (it is not a lost session)
        page.fill("#pw-old", "not-the-password")
        page.fill("#pw-new", "victor-new-secret")
        page.click("#pw-save")
        page.wait_for_selector("#pw-error:not([hidden])")
        assert "current password is wrong" in page.inner_text("#pw-error")
        assert page.is_visible("#account-dialog") and not page.is_visible("#login-dialog")
        page.fill("#pw-old", PASSWORDS["victor"])
        page.click("#pw-save")
        page.wait_for_selector("#login-dialog[open]", timeout=30_000)  # the sessions ended
        log_in(page, "victor", "victor-new-secret")
        page.wait_for_function("document.body?.dataset.state === 'ready'", timeout=30_000)
        assert page.inner_text("#user-name") == "victor"
        assert not [p for p in problems if "page error" in p], problems
    finally:
        ctx.close()


# --------------------------------------------------------------------------- (f) true north
def test_headings_and_the_north_button_follow_true_north(browser, server, artifacts, tmp_path):
    """A site whose model +Y points to 310° true (its TrueNorth is 50° off the y axis): the frame card shows the
    heading the exported WPL flies, to 0.1°, and N moves a frame toward true north, not along +Y. Then the frame
    edits are undone and redone (Ctrl+Z, Ctrl+Y, Ctrl+Shift+Z, the Undo button), each back to the exact pose, and
    Delete deletes the selected frame, except while typing in a field."""
    import math
    import urllib.request

    from site_fixture import write_basement_house

    a = math.radians(50.0)
    ifc = write_basement_house(tmp_path / "turned.ifc", true_north=(math.sin(a), math.cos(a)))
    project = server.request("POST", "/api/projects", {"name": "Turned site"})["id"]
    res = server.upload(f"/api/projects/{project}/models", "turned.ifc", ifc.read_bytes())
    assert server.wait_job(res["job"]["id"])["status"] == "done"
    plan = server.request("POST", f"/api/projects/{project}/plans",
                          {"model_id": res["model"]["id"], "template": "orbit", "name": "turned", "radius_m": [20],
                           "height_m": [3], "step_deg": 45})
    base = f"/api/projects/{project}/plans/{plan['id']}/versions/1"
    assert server.get(f"{base}/geometry")["north_offset_deg"] == pytest.approx(310.0, abs=1e-3)
    req = urllib.request.Request(server.url + f"{base}/export?format=wpl&mission=1&force=true",
                                 headers={"Authorization": f"Bearer {server.token}"} if server.token else {})
    with urllib.request.urlopen(req, timeout=120) as r:
        rows = [line.split("\t") for line in r.read().decode().splitlines()[1:]]
    exported = next(float(c[4]) for c in rows if int(c[3]) == 115)  # frame 0's CONDITION_YAW (ArduPilot)
    ctx, page, problems = open_project(browser, server, project)
    try:
        page.select_option("#plan-select", str(plan["id"]))
        wait_for(page, "window.sightplanTest.planVersion() === 1")
        page.click("button[data-tab=frames]")
        page.click("#frame-list tbody tr[data-frame='0']")
        wait_for(page, "window.sightplanTest.selectedFrame() === 0")
        shown = json.loads(page.get_attribute("#frame-info dd[data-field='heading (true)']", "data-value"))
        assert abs((shown - exported + 180) % 360 - 180) < 0.1, (shown, exported)
        before = json.loads(page.get_attribute("#frame-info dd[data-field='position (m)']", "data-value"))
        page.fill("#move-step", "1")
        page.click("button[data-move='y+']")
        wait_for(page, "window.sightplanTest.dirty()")
        after = json.loads(page.get_attribute("#frame-info dd[data-field='position (m)']", "data-value"))
        assert np.subtract(after, before) == pytest.approx([math.sin(a), math.cos(a), 0.0], abs=1e-6)
        shot(page, artifacts, "26-true-north")

        # undo and redo of frame edits (keys and buttons), and the Delete key
        def pose(i: int = 0) -> dict:
            return page.evaluate(f"window.sightplanTest.framePose({i})")

        n = page.evaluate("window.sightplanTest.frameCount()")
        moved = pose()
        page.keyboard.press("Control+z")  # the focus is on the N button
        wait_for(page, "!window.sightplanTest.dirty()")  # back to the version saved: not edited
        assert pose()["position"] == before and page.is_disabled("#edit-undo") and page.is_enabled("#edit-redo")
        page.keyboard.press("Control+y")
        wait_for(page, "window.sightplanTest.dirty()")
        assert pose() == moved
        page.click("#edit-undo")
        wait_for(page, "!window.sightplanTest.dirty()")
        saved, second = pose(), pose(1)
        page.keyboard.press("Delete")
        wait_for(page, f"window.sightplanTest.frameCount() === {n - 1}")
        now = pose()  # the next frame, selected (drawn from the edited plan file, not the server's geometry)
        assert np.allclose(now["position"] + now["rotation"], second["position"] + second["rotation"], atol=1e-9)
        assert page.evaluate("window.sightplanTest.selectedFrame()") == 0
        page.keyboard.press("Control+z")
        wait_for(page, f"window.sightplanTest.frameCount() === {n} && !window.sightplanTest.dirty()")
        assert pose() == saved and pose(1) == second
        page.keyboard.press("Control+Shift+z")
        wait_for(page, f"window.sightplanTest.frameCount() === {n - 1} && window.sightplanTest.dirty()")
        page.keyboard.press("Control+z")
        wait_for(page, f"window.sightplanTest.frameCount() === {n}")
        page.fill("#move-dx", "12")
        page.press("#move-dx", "Control+a")
        page.press("#move-dx", "Delete")  # deletes the text, not the frame
        assert page.input_value("#move-dx") == "" and page.evaluate("window.sightplanTest.frameCount()") == n
        assert not page.evaluate("window.sightplanTest.dirty()") and page.is_disabled("#edit-undo")
        assert not [p for p in problems if "page error" in p], problems
    finally:
        ctx.close()


# --------------------------------------------------------------------------- (g) the map
def _geodetic(point, lat0, lon0, north_deg):
    """Latitude/longitude of a model point of the fixture, from its site's reference point and its model +Y's true
    heading, by pyproj's geodesic (not by sightplan's georeference)."""
    from pyproj import Geod

    t = math.radians(north_deg)
    x, y = point
    east, north = x * math.cos(t) + y * math.sin(t), -x * math.sin(t) + y * math.cos(t)
    lon, lat, _ = Geod(ellps="WGS84").fwd(lon0, lat0, math.degrees(math.atan2(east, north)), math.hypot(east, north))
    return lat, lon


def _click_map_at(page, lat: float, lon: float) -> None:
    """A mouse click on the map where (lat, lon) is drawn, its position taken in the same moment as the click (on a
    busy machine, a message appearing between the two would move the map under the mouse)."""
    page.evaluate(f"""(() => {{
        const p = window.sightplanTest.map.screenPoint({lat}, {lon});
        const target = document.elementFromPoint(p.x, p.y);
        for (const type of ['mousedown', 'mouseup', 'click'])
            target.dispatchEvent(new MouseEvent(type, {{clientX: p.x, clientY: p.y, bubbles: true, button: 0}}));
    }})()""")


def test_the_map_shows_the_site_where_it_stands_and_places_a_pilot(browser, server, tiles, artifacts, tmp_path):
    """The turned house (model +Y at 310° true) on the map: its footprint's corners at the latitude/longitude the
    site's reference point gives, within 1 m; the loopback tiles drawn behind it; a click places mission 1's pilot,
    saved as a new version whose flight checks start there."""
    from pyproj import Geod

    from site_fixture import write_basement_house

    a = math.radians(50.0)
    lat0, lon0 = 51 + 50 / 60 + 16.8 / 3600, 5 + 52 / 60 + 12 / 3600
    ifc = write_basement_house(tmp_path / "turned.ifc", true_north=(math.sin(a), math.cos(a)))
    project = server.request("POST", "/api/projects", {"name": "Mapped site"})["id"]
    res = server.upload(f"/api/projects/{project}/models", "turned.ifc", ifc.read_bytes())
    assert server.wait_job(res["job"]["id"])["status"] == "done"
    plan = server.request("POST", f"/api/projects/{project}/plans",
                          {"model_id": res["model"]["id"], "template": "orbit", "name": "mapped", "radius_m": [20],
                           "height_m": [3], "step_deg": 45})
    geod = Geod(ellps="WGS84")
    ctx, page, problems = open_page(browser, server, init_script=f"localStorage.setItem('sightplan.project', "
                                                                 f"'{project}'); localStorage.setItem('sightplan.map', '1')")
    try:
        page.select_option("#plan-select", str(plan["id"]))
        wait_for(page, "window.sightplanTest.planVersion() === 1 && window.sightplanTest.flightChecked()")
        wait_for(page, "window.sightplanTest.map.ready() && window.sightplanTest.map.drawn('pilots') !== null")
        ring = page.evaluate("window.sightplanTest.map.drawn('footprint')")["features"][0]["geometry"]["coordinates"][0]
        for corner in [(0.0, 0.0), (12.0, 0.0), (12.0, 8.0), (0.0, 8.0)]:  # the house's walls, model frame
            lat, lon = _geodetic(corner, lat0, lon0, 310.0)
            gaps = [geod.inv(lon, lat, q[0], q[1])[2] for q in ring]
            assert min(gaps) < 1.0, (corner, min(gaps))
        # the loopback tiles were fetched and drawn: magenta fills the map where nothing else is drawn
        assert any(h.startswith("/tiles/") for h in tiles.hits)
        box = page.locator("#map-canvas").bounding_box()
        pixels = np.asarray(Image.open(io.BytesIO(page.screenshot(clip=box))).convert("RGB"), int)
        assert (np.abs(pixels - MAGENTA).sum(axis=2) < 30).mean() > 0.3
        assert "loopback test tiles" in page.inner_text("#map-canvas")
        # place mission 1's pilot 40 m south-west of the house (true bearings), then save and check from there
        want_lon, want_lat, _ = geod.fwd(lon0, lat0, 225.0, 40.0)
        page.select_option("#map-place", "0")
        wait_for(page, "window.sightplanTest.map.still()")
        _click_map_at(page, want_lat, want_lon)
        wait_for(page, "window.sightplanTest.dirty()")
        placed = page.evaluate("window.sightplanTest.map.drawn('pilots')")["features"]
        lon_p, lat_p = next(f for f in placed if f["properties"]["mission"] == 0)["geometry"]["coordinates"]
        assert geod.inv(want_lon, want_lat, lon_p, lat_p)[2] < 1.0
        page.click("#plan-save")
        wait_for(page, "window.sightplanTest.planVersion() === 2 && window.sightplanTest.flightChecked()")
        checks = server.get(f"/api/projects/{project}/plans/{plan['id']}/versions/2/checks")
        east, north = 40 * math.sin(math.radians(225)), 40 * math.cos(math.radians(225))
        t = math.radians(310.0)  # model x, y of that point, inverting the rotation above
        want_xy = [east * math.cos(t) - north * math.sin(t), east * math.sin(t) + north * math.cos(t)]
        assert checks["missions"][0]["ground_station"][:2] == pytest.approx(want_xy, abs=1.0)
        # a click with "ground station of the new-plan form" writes its latitude, longitude there
        page.select_option("#map-place", "form")
        _click_map_at(page, want_lat, want_lon)
        typed = [float(v) for v in page.input_value("#plan-stations").splitlines()[-1].split(",")]
        assert geod.inv(want_lon, want_lat, typed[1], typed[0])[2] < 1.0
        shot(page, artifacts, "27-map")
        assert not [p for p in problems if "page error" in p], problems
    finally:
        ctx.close()
