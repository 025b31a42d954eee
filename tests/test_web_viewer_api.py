"""The endpoints behind the web page's viewer, checked against the library: the binary model geometry against the
Scene, plan geometry against the plan JSON, flight checks against the safety distances, feedback and element values
against an evaluation run here, and the simulated view's pixels against the engine's element image."""

from __future__ import annotations

import io
import json
import struct

import numpy as np
import pytest
import trimesh

pytest.importorskip("fastapi")
pytest.importorskip("httpx")

from fastapi.testclient import TestClient  # noqa: E402

from sightplan.model.load import load_model, sample_model_path  # noqa: E402
from sightplan.web.app import create_app  # noqa: E402
from sightplan.web.config import ServerConfig  # noqa: E402
from web_support import wait_job  # noqa: E402

SCALE = 0.05
DTYPES = {"float32": np.float32, "uint32": np.uint32}




def read_geometry(data: bytes) -> tuple[dict, dict[str, np.ndarray]]:
    """An independent reader of the SPG1 layout: magic, uint32 header length, JSON, aligned arrays."""
    assert data[:4] == b"SPG1"
    (n,) = struct.unpack_from("<I", data, 4)
    assert n % 4 == 0
    header = json.loads(data[8:8 + n])
    base = 8 + n
    arrays = {}
    for name, spec in header["arrays"].items():
        assert spec["offset"] % 4 == 0
        start = base + spec["offset"]
        arr = np.frombuffer(data[start:start + spec["bytes"]], DTYPES[spec["dtype"]])
        arrays[name] = arr.reshape(spec["shape"])
    return header, arrays


@pytest.fixture(scope="module")
def scene():
    return load_model("sample")[0]


@pytest.fixture(scope="module")
def client(tmp_path_factory):
    with TestClient(create_app(ServerConfig(data_dir=tmp_path_factory.mktemp("viewer") / "data"))) as c:
        yield c


@pytest.fixture(scope="module")
def project(client) -> int:
    return client.post("/api/projects", json={"name": "viewer"}).json()["id"]


@pytest.fixture(scope="module")
def model(client, project) -> int:
    with open(sample_model_path(), "rb") as fh:
        r = client.post(f"/api/projects/{project}/models", files={"file": ("Duplex.ifc", fh)})
    assert wait_job(client, r.json()["job"]["id"])["status"] == "done"
    return r.json()["model"]["id"]


@pytest.fixture(scope="module")
def plan(client, project, model) -> int:
    r = client.post(f"/api/projects/{project}/plans", json={"model_id": model, "template": "orbit", "radius_m": [22],
                                                             "height_m": [4.0], "step_deg": 30, "name": "ring"})
    assert r.status_code == 201, r.text
    return r.json()["id"]


@pytest.fixture(scope="module")
def evaluation(client, project, model, plan) -> int:
    r = client.post(f"/api/projects/{project}/evaluations",
                    json={"plan_id": plan, "version": 1, "settings": {"scale": SCALE, "engine": "embree"}})
    assert wait_job(client, r.json()["job"]["id"])["status"] == "done"
    return r.json()["evaluation"]["id"]


@pytest.fixture(scope="module")
def reference(client, project, plan, scene):
    """The same evaluation run by the library in this process."""
    from sightplan.evaluate import EvaluationSettings, evaluate
    from sightplan.plan.format import plan_from_dict

    data = plan_from_dict(client.get(f"/api/projects/{project}/plans/{plan}/versions/1").json())
    return data, evaluate(scene, data, EvaluationSettings(scale=SCALE, engine="embree"), cache_dir=False)


# --------------------------------------------------------------------------- the model
def test_geometry_is_the_scene_in_the_viewer_frame(client, project, model, scene):
    r = client.get(f"/api/projects/{project}/models/{model}/geometry", headers={"Accept-Encoding": "identity"})
    assert r.status_code == 200 and r.headers["content-type"] == "application/vnd.sightplan.geometry"
    assert "content-encoding" not in r.headers
    header, a = read_geometry(r.content)
    n_faces = len(scene.faces)
    assert header["triangles"] == n_faces == len(a["index"]) == len(a["triangle_element"]) == 26348
    assert header["elements"] == scene.n_elements == 215
    assert header["vertices"] == len(a["position"]) == len(a["vertex_element"])
    # every element keeps its triangles, and each triangle's three corners belong to its element
    assert np.array_equal(np.bincount(a["triangle_element"], minlength=215), np.bincount(scene.face_element, minlength=215))
    assert np.array_equal(a["vertex_element"][a["index"]], np.repeat(a["triangle_element"][:, None], 3, axis=1))
    # back in the model frame (x, y, z) = (X + ox, −Z + oy, Y + oz): the same box and the same area per element
    o = np.array(header["origin_m"])
    p = a["position"].astype(np.float64)
    model_xyz = np.column_stack([p[:, 0] + o[0], -p[:, 2] + o[1], p[:, 1] + o[2]])
    assert np.allclose([model_xyz.min(0), model_xyz.max(0)], scene.bounds(), atol=1e-3)
    tri = model_xyz[a["index"]]
    area = 0.5 * np.linalg.norm(np.cross(tri[:, 1] - tri[:, 0], tri[:, 2] - tri[:, 0]), axis=1)
    assert np.allclose(np.bincount(a["triangle_element"], weights=area, minlength=215),
                       np.bincount(scene.face_element, weights=scene.face_areas(), minlength=215), rtol=1e-4, atol=1e-5)
    # gzipped for a browser, the same bytes inside
    z = client.get(f"/api/projects/{project}/models/{model}/geometry", headers={"Accept-Encoding": "gzip"})
    assert z.headers["content-encoding"] == "gzip" and z.content == r.content
    assert int(z.headers["content-length"]) < len(r.content)


def test_element_table(client, project, model, scene):
    t = client.get(f"/api/projects/{project}/models/{model}/elements").json()
    assert t["count"] == 215 and len(t["global_id"]) == 215 and sum(t["target"]) == 154
    assert sum(t["triangles"]) == len(scene.faces)
    assert t["global_id"] == scene.elements.global_id.tolist() and t["ifc_class"][0] == scene.elements.ifc_class[0]
    assert client.get(f"/api/projects/{project}/models/999/elements").status_code == 404
    assert client.get(f"/api/projects/999/models/{model}/geometry").status_code == 404


# --------------------------------------------------------------------------- a plan version
def test_plan_geometry_is_the_plan_json(client, project, plan):
    js = client.get(f"/api/projects/{project}/plans/{plan}/versions/1").json()
    g = client.get(f"/api/projects/{project}/plans/{plan}/versions/1/geometry").json()
    assert g["frames"] == len(js["frames"]) == 12 == len(g["position"]) == len(g["rotation"])
    assert g["position"] == [f["position"] for f in js["frames"]]
    assert g["rotation"] == [sum(f["rotation"], []) for f in js["frames"]]
    assert g["name"] == [f["name"] for f in js["frames"]]
    assert [[m["start"], m["stop"]] for m in g["missions"]] == [m["frames"] for m in js["missions"]]
    assert [m["ground_station"] for m in g["missions"]] == [m.get("ground_station") for m in js["missions"]]
    cam = next(iter(g["cameras"].values()))
    assert cam["hfov_deg"] == pytest.approx(np.degrees(2 * np.arctan(cam["width"] / (2 * cam["fx"]))))
    assert client.get(f"/api/projects/{project}/plans/{plan}/versions/7/geometry").status_code == 404


def test_checks_find_the_frame_moved_too_close(client, project, plan, scene):
    from sightplan.plan.checks.safety import point_distances

    js = client.get(f"/api/projects/{project}/plans/{plan}/versions/1").json()
    c1 = client.get(f"/api/projects/{project}/plans/{plan}/versions/1/checks", params={"safety_distance_m": 3}).json()
    C = np.array([f["position"] for f in js["frames"]])
    assert c1["clearance_m"] == pytest.approx(np.round(point_distances(scene, C), 3).tolist(), abs=1e-3)
    assert c1["ok"] is True and c1["unsafe_frames"] == [] and c1["safety_distance_m"] == 3
    # frame 4 moved to 1 m in front of the nearest wall: too close, and said so
    lo, hi = scene.bounds()
    edited = json.loads(json.dumps(js))
    edited["frames"][4]["position"] = [float(lo[0]) - 1.0, float((lo[1] + hi[1]) / 2), 3.0]
    r = client.put(f"/api/projects/{project}/plans/{plan}", json=edited, params={"note": "too close"})
    assert r.status_code == 201
    c2 = client.get(f"/api/projects/{project}/plans/{plan}/versions/2/checks", params={"safety_distance_m": 3}).json()
    clearance = point_distances(scene, np.array(edited["frames"][4]["position"])[None])[0]
    assert clearance < 3 and c2["clearance_m"][4] == pytest.approx(clearance, abs=1e-3)
    assert 4 in c2["unsafe_frames"] and c2["ok"] is False
    assert any("waypoint 4" in v for v in c2["violations"])
    assert set(c2["unsafe_segments"]) >= {3} or set(c2["unsafe_segments"]) >= {4}
    r = client.get(f"/api/projects/{project}/plans/{plan}/versions/2/checks", params={"safety_distance_m": -1})
    assert r.status_code == 422 and "safety_distance_m" in r.json()["detail"]


def test_checks_draw_the_checked_flight_out_and_home(client, project, plan):
    js = client.get(f"/api/projects/{project}/plans/{plan}/versions/1").json()
    c = client.get(f"/api/projects/{project}/plans/{plan}/versions/1/checks").json()
    C = np.array([f["position"] for f in js["frames"]])
    assert c["ground"]["source"] == "exterior door" and c["position_error_m"] == [1.5, 0.5]
    assert len(c["trajectory"]) == len(js["missions"]) >= 1
    for m, t in zip(js["missions"], c["trajectory"]):
        out, home = np.array(t["out"]), np.array(t["home"])
        start, stop = m["frames"]
        T = np.array(t["takeoff_m"])
        assert T[2] == pytest.approx(c["ground"]["level_m"])  # on the ground, not 1.5 m up at the pilot's eyes
        # out: the take-off, straight up to the climb height, over to the first frame, down to it; home the reverse
        assert np.allclose(out, [T, [*T[:2], t["climb_z_m"]], [*C[start][:2], t["climb_z_m"]], C[start]], atol=1e-3)
        assert np.allclose(home, [C[stop - 1], [*C[stop - 1][:2], t["return_z_m"]], [*T[:2], t["return_z_m"]], T],
                           atol=1e-3)
    # the same heights the plan recorded when it was made, which its exports fly
    recorded = js["parameters"]["trajectory"]["missions"]
    assert [(r["climb_z_m"], r["return_z_m"]) for r in recorded] == [(t["climb_z_m"], t["return_z_m"])
                                                                      for t in c["trajectory"]]


def test_a_failing_export_lists_its_violations_and_exports_only_when_forced(client, project, plan, scene, caplog):
    js = client.get(f"/api/projects/{project}/plans/{plan}/versions/1").json()
    lo, hi = scene.bounds()
    js["frames"][4]["position"] = [float(lo[0]) - 1.0, float((lo[1] + hi[1]) / 2), 3.0]  # 1 m from the west wall
    number = client.put(f"/api/projects/{project}/plans/{plan}", json=js, params={"note": "by the wall"}).json()
    number = number["latest_version"]
    url = f"/api/projects/{project}/plans/{plan}/versions/{number}/export"
    r = client.get(url, params={"format": "kml"})
    assert r.status_code == 409
    violations = r.json()["violations"]
    assert any("waypoint 4" in v for v in violations) and r.json()["detail"].startswith("the plan fails its flight")
    assert r.headers["x-sightplan-flight-violations"] == str(len(violations))
    with caplog.at_level("WARNING", logger="sightplan.web"):
        r = client.get(url, params={"format": "kml", "force": True})
    assert r.status_code == 200 and b"<kml" in r.content
    assert r.headers["x-sightplan-flight-violations"] == str(len(violations))
    logged = [rec.getMessage() for rec in caplog.records if "despite its flight checks" in rec.getMessage()]
    assert [m.split("despite its flight checks: ", 1)[1] for m in logged] == violations


def test_a_pilot_station_by_latitude_and_longitude(client, project, model, scene):
    from sightplan.geo import Georeference

    geo = Georeference.from_scene_metadata(scene.metadata)
    lat, lon, _ = geo.to_geodetic([[-30.0, -20.0, 0.0]])
    r = client.post(f"/api/projects/{project}/plans", json={
        "model_id": model, "template": "orbit", "radius_m": [22], "height_m": [4.0], "step_deg": 30,
        "ground_station_geo": [[float(lat[0]), float(lon[0])]], "position_error": "rtk"})
    assert r.status_code == 201, r.text
    js = client.get(f"/api/projects/{project}/plans/{r.json()['id']}/versions/1").json()
    assert js["missions"][0]["ground_station"] == pytest.approx([-30.0, -20.0, 0.0 + 1.5], abs=0.01)
    assert js["parameters"]["flight"]["position_error_m"] == [0.1, 0.1]
    r = client.post(f"/api/projects/{project}/plans", json={
        "model_id": model, "template": "orbit", "radius_m": [22], "height_m": [4.0],
        "ground_station_geo": [[float(lon[0]), float(lat[0])]]})  # the wrong way round
    assert r.status_code == 422 and "km from the model" in r.json()["detail"]
    r = client.post(f"/api/projects/{project}/plans", json={"model_id": model, "template": "orbit", "radius_m": [22],
                                                             "height_m": [4.0], "position_error": "2,x"})
    assert r.status_code == 422 and "position error" in r.json()["detail"]


# --------------------------------------------------------------------------- an evaluation
def test_feedback_matches_the_library(client, project, evaluation, reference):
    from sightplan.report.colours import default_bounds, visibility_class

    _, ref = reference
    em, fm = ref.metrics.elements, ref.metrics.frames
    fb = client.get(f"/api/projects/{project}/evaluations/{evaluation}/feedback").json()
    assert fb["metrics"]["visibility"] == visibility_class(em).tolist()
    ssd = [None if not np.isfinite(v) else v for v in em.R]
    assert fb["metrics"]["ssd"] == pytest.approx(ssd)
    assert fb["metrics"]["vr"] == [int(v) if vis else None for v, vis in zip(em.VR, em.visible)]
    assert fb["frames"]["nu"] == fm.nu.tolist() and fb["frames"]["stable"] == fm.stable.tolist()
    assert fb["labels"]["ssd"]["bounds"] == pytest.approx(list(default_bounds(em, "ssd")))
    assert fb["labels"]["vr"]["higher_better"] is True and fb["labels"]["ssd"]["higher_better"] is False
    assert fb["params"]["min_features"] == 50 and fb["plan_version"] == 1
    assert sum(fb["elements"]["target"]) == 154 and len(fb["metrics"]["visibility"]) == 215
    # the cached JSON is exactly the documented response: every key typed, nothing left over
    from sightplan.web.schemas import FeedbackOut

    typed = FeedbackOut.model_validate(fb)
    assert typed.model_dump(exclude_unset=True) == fb


def test_element_values_and_best_frames(client, project, evaluation, reference):
    _, ref = reference
    em, obs = ref.metrics.elements, ref.observations
    rows = client.get(f"/api/projects/{project}/evaluations/{evaluation}/elements").json()["elements"]
    i = int(np.flatnonzero(em.visible & (em.VR >= 3))[0])
    d = client.get(f"/api/projects/{project}/evaluations/{evaluation}/elements/{i}", params={"limit": 50}).json()
    assert d["element"] == next(r for r in rows if r["index"] == i)
    assert d["element"]["VR_i"] == int(em.VR[i]) and d["element"]["R_i_m_per_px"] == pytest.approx(em.R[i])
    best = d["best_frames"]
    sel = obs.element == i
    assert len(best) == min(50, int(sel.sum()))
    counted = [f for f in best if f["counts"]]
    assert len(counted) == em.VR[i]
    # R_i is the mean of the k finest sampling distances among the frames that count: the first k listed
    k = ref.metrics.params.k
    assert np.mean([f["ssd_m_per_px"] for f in counted[:k]]) == pytest.approx(em.R[i])
    assert [f["ssd_m_per_px"] for f in counted] == sorted(f["ssd_m_per_px"] for f in counted)
    assert all(f["pixels"] >= 625 for f in counted) and all(f["pixels"] < 625 for f in best if not f["counts"])
    occluder = int(np.flatnonzero(~em.is_target)[0])
    d = client.get(f"/api/projects/{project}/evaluations/{evaluation}/elements/{occluder}").json()
    assert d["target"] is False and d["element"]["visibility"] == "occluder" and d["element"]["VR_i"] is None
    assert client.get(f"/api/projects/{project}/evaluations/{evaluation}/elements/215").status_code == 404


def _rgb(png: bytes) -> np.ndarray:
    from PIL import Image

    return np.asarray(Image.open(io.BytesIO(png)).convert("RGB"))


def test_view_png_is_the_engines_element_image(client, project, evaluation, reference, scene):
    from sightplan.engines.registry import make_engine
    from sightplan.report.colours import metric_colours

    data, ref = reference
    frame = 3
    bounds = (0.002, 0.006)
    r = client.get(f"/api/projects/{project}/evaluations/{evaluation}/frames/{frame}/view.png",
                   params={"metric": "ssd", "lo": bounds[0], "hi": bounds[1], "width": 240, "shading": False})
    assert r.status_code == 200 and r.headers["content-type"] == "image/png"
    img = _rgb(r.content)
    cam = data.camera_of(frame)
    with make_engine("embree", scene) as engine:
        ids, _, _ = engine.shaded_view(cam, data.R_world_camera[frame], data.C_world[frame], 240 / cam.width)
    assert img.shape[:2] == ids.shape == (round(cam.height * 240 / cam.width), 240)
    assert (ids >= 0).sum() > 1000, "the frame looks at the model"
    expected = np.full((*ids.shape, 3), 255, np.uint8)
    colours = np.round(metric_colours(ref.metrics.elements, "ssd", bounds)[:, :3] * 255).astype(np.uint8)
    expected[ids >= 0] = colours[ids[ids >= 0]]
    assert np.array_equal(img, expected)
    assert int(r.headers["x-sightplan-elements-seen"]) == len(np.unique(ids[ids >= 0]))
    # shaded: the same pixels hit, never brighter than the flat colour
    s = _rgb(client.get(f"/api/projects/{project}/evaluations/{evaluation}/frames/{frame}/view.png",
                        params={"metric": "ssd", "lo": bounds[0], "hi": bounds[1], "width": 240}).content)
    assert np.array_equal((s != 255).any(axis=2) | (ids >= 0), ids >= 0)
    assert (s[ids >= 0].astype(int) <= expected[ids >= 0].astype(int) + 1).all()


def test_view_png_refusals(client, project, evaluation, plan):
    base = f"/api/projects/{project}/evaluations/{evaluation}/frames"
    r = client.get(f"{base}/0/view.png", params={"metric": "height"})
    assert r.status_code == 422 and "visibility, vr, ssd, orientation" in r.json()["detail"]
    r = client.get(f"{base}/0/view.png", params={"metric": "ssd", "lo": 0.01})
    assert r.status_code == 422 and "both" in r.json()["detail"]
    r = client.get(f"{base}/0/view.png", params={"metric": "ssd", "lo": 0.01, "hi": 0.002})
    assert r.status_code == 422 and "LO < HI" in r.json()["detail"]
    r = client.get(f"{base}/12/view.png")
    assert r.status_code == 404 and "frames 0 to 11" in r.json()["detail"]
    assert client.get(f"/api/projects/{project}/evaluations/999/feedback").status_code == 404


def test_plan_view_without_evaluation(client, project, plan, model, scene, reference):
    from sightplan.engines.registry import make_engine

    data, _ = reference
    r = client.get(f"/api/projects/{project}/plans/{plan}/versions/1/frames/0/view.png", params={"width": 160})
    assert r.status_code == 200
    img = _rgb(r.content)
    cam = data.camera_of(0)
    with make_engine("embree", scene) as engine:
        ids, _, _ = engine.shaded_view(cam, data.R_world_camera[0], data.C_world[0], 160 / cam.width)
    assert np.array_equal((img != 255).any(axis=2), ids >= 0)


# --------------------------------------------------------------------------- the page and its packages
def test_page_and_vendor_files(client):
    from sightplan.report.html import THREE_DIR

    page = client.get("/")
    assert page.status_code == 200 and page.headers["content-type"].startswith("text/html")
    importmap = json.loads(page.text.split('<script type="importmap">', 1)[1].split("</script>", 1)[0])
    assert importmap["imports"]["three"] == "/vendor/three/build/three.module.js"
    js = client.get("/static/app.js")
    assert js.status_code == 200 and js.headers["content-type"].startswith("text/javascript")
    assert client.get("/static/app.css").headers["content-type"].startswith("text/css")
    if THREE_DIR.is_dir():
        three = client.get("/vendor/three/build/three.module.js")
        assert three.status_code == 200 and three.headers["content-type"].startswith("text/javascript")
        assert three.content == (THREE_DIR / "build" / "three.module.js").read_bytes()
    for url in ("/vendor/three/..%2F..%2Fpackage.json", "/vendor/three/%2e%2e/%2e%2e/package.json",
                "/vendor/three/../../package-lock.json", "/vendor/fflate/package.json", "/vendor/..%2Fthree/package.json",
                "/static/..%2Froutes%2Fviewer.py", "/static/%2e%2e/app.py", "/vendor/three/%2Fetc%2Fpasswd",
                "/static/", "/vendor/three/"):
        r = client.get(url)
        assert r.status_code == 404, url
        assert "root:" not in r.text and "sightplan-web" not in r.text


def test_the_point_cloud_streamer_and_its_imports_are_served(client):
    """pointcloud.js imports 3d-tiles-renderer by the importmap's entry; every module that build reaches by a relative
    path is served, and its bare imports are three.js paths the importmap maps (nothing of its own dependencies)."""
    import re

    from sightplan.report.html import THREE_DIR

    page = client.get("/")
    imports = json.loads(page.text.split('<script type="importmap">', 1)[1].split("</script>", 1)[0])["imports"]
    entry = imports["3d-tiles-renderer"]
    assert entry == "/vendor/3d-tiles-renderer/build/index.three.js"
    root = THREE_DIR.parent / "3d-tiles-renderer" / "build"
    if not root.is_dir():
        pytest.skip("web/node_modules/3d-tiles-renderer is not installed (make setup)")
    todo, seen, bare = [entry], set(), set()
    while todo:
        url = todo.pop()
        if url in seen:
            continue
        seen.add(url)
        r = client.get(url)
        assert r.status_code == 200 and r.headers["content-type"].startswith("text/javascript"), url
        assert r.content == (root / url.rsplit("/", 1)[1]).read_bytes()
        for spec in re.findall(r"""(?:from|import)\s*\(?\s*["']([^"']+)["']""", r.text):
            if spec.startswith("./"):
                todo.append(url.rsplit("/", 1)[0] + "/" + spec[2:])
            else:
                bare.add(spec)
    assert len(seen) >= 3  # the entry and its chunks
    for spec in bare:
        assert spec in imports or any(spec.startswith(k) for k in imports if k.endswith("/")), spec
    assert client.get("/vendor/pbf/package.json").status_code == 404  # its own dependencies stay unserved
    assert client.get("/vendor/3d-tiles-renderer/%2e%2e/%2e%2e/package-lock.json").status_code == 404


def test_openapi_documents_the_viewer_routes(client):
    schema = client.get("/openapi.json").json()
    viewer = {path for path, ops in schema["paths"].items() for op in ops.values() if "viewer" in op.get("tags", [])}
    assert viewer == {
        "/api/projects/{project_id}/models/{model_id}/geometry", "/api/projects/{project_id}/models/{model_id}/elements",
        "/api/projects/{project_id}/plans/{plan_id}/versions/{number}/geometry",
        "/api/projects/{project_id}/plans/{plan_id}/versions/{number}/checks",
        "/api/projects/{project_id}/evaluations/{evaluation_id}/feedback",
        "/api/projects/{project_id}/evaluations/{evaluation_id}/elements/{index}",
        "/api/projects/{project_id}/evaluations/{evaluation_id}/frames/{frame}/view.png",
        "/api/projects/{project_id}/plans/{plan_id}/versions/{number}/frames/{frame}/view.png",
        "/api/projects/{project_id}/models/{model_id}/site", "/api/projects/{project_id}/basemap",
        "/api/projects/{project_id}/basemap/image.png", "/api/projects/{project_id}/basemap/tiles/{z}/{x}/{y}",
    }
    for path in viewer:
        op = schema["paths"][path]["get"]
        assert op["summary"] and "404" in op["responses"], path


def test_every_json_response_is_a_named_model(client):
    """The contract the page's types are generated from: no JSON answer is an untyped object."""
    schema = client.get("/openapi.json").json()
    for path, ops in schema["paths"].items():
        for method, op in ops.items():
            for code, response in op["responses"].items():
                body = response.get("content", {}).get("application/json", {}).get("schema")
                if body is None or not code.startswith("2"):
                    continue
                ref = body.get("$ref") or body.get("items", {}).get("$ref")
                assert ref, (method, path, code, body)


def test_an_export_its_replay_refuses_is_a_409_the_page_can_force(client, project, model, monkeypatch):
    """The replay's verdict (sightplan.export.ReplayRefusal) reaches the page as the flight checks' do: a 409 with
    the reason in ``violations``, and force=true writes the file."""
    import sightplan.export as export

    r = client.post(f"/api/projects/{project}/plans", json={"model_id": model, "template": "orbit", "name": "replayed"})
    assert r.status_code == 201, r.text
    url = f"/api/projects/{project}/plans/{r.json()['id']}/versions/1/export"
    assert client.get(url, params={"format": "qgc"}).status_code == 200
    monkeypatch.setattr(export, "_longer_than_a_battery", lambda *a: "mission 'x' flies 30.0 min in the replay")
    r = client.get(url, params={"format": "qgc"})
    assert r.status_code == 409 and len(r.json()["violations"]) == 1
    assert r.json()["violations"][0].startswith("mission 'x' flies 30.0 min in the replay; split the plan")
    assert client.get(url, params={"format": "qgc", "force": True}).status_code == 200


def test_an_evaluation_as_flown_and_under_position_error(client, project, plan, reference):
    """``as_flown``: the version's PX4 export replayed takes every photo on its frame, so the metrics are the plan's
    (the library's evaluation here); ``position_error``: the metrics' band over the draws, the plan inside it."""
    _, ref = reference
    r = client.post(f"/api/projects/{project}/evaluations", json={
        "plan_id": plan, "version": 1, "settings": {"scale": SCALE, "engine": "embree"}, "as_flown": "px4",
        "position_error": "rtk", "draws": 4})
    assert r.status_code == 202, r.text
    assert wait_job(client, r.json()["job"]["id"])["status"] == "done"
    ev = client.get(f"/api/projects/{project}/evaluations/{r.json()['evaluation']['id']}").json()
    assert ev["settings"]["as_flown"] == "px4" and ev["settings"]["robustness"]["draws"] == 4
    m = ev["metrics"]
    assert m["VC_pct"] == pytest.approx(100 * ref.metrics.plan.VC) and m["VR"] == pytest.approx(ref.metrics.plan.VR,
                                                                                                  rel=1e-3)
    band = m["robustness"]
    assert band["draws"] == 4 and band["label"] == "±0.1 m / ±0.1 m"
    vc = band["metrics"]["VC_pct"]
    assert vc["nominal"] == pytest.approx(m["VC_pct"]) and vc["p5"] <= vc["mean"] <= vc["p95"]
    for body, word in (({"draws": 4}, "position_error"), ({"position_error": "x"}, "position error"),
                       ({"as_flown": "dji"}, "as_flown")):
        r = client.post(f"/api/projects/{project}/evaluations", json={"plan_id": plan, **body})
        assert r.status_code == 422 and word in r.json()["detail"], (body, r.text)


def test_the_page_has_an_icon(client):
    page = client.get("/").text
    assert '<link rel="icon" href="/static/favicon.svg"' in page
    for url in ("/static/favicon.svg", "/favicon.ico"):
        r = client.get(url)
        assert r.status_code == 200 and r.headers["content-type"].startswith("image/svg+xml") and b"<svg" in r.content


def test_the_site_of_the_duplex_on_the_map(client, project, model, scene):
    """The Duplex stands at its IfcSite's latitude/longitude: the footprint covers the walls' extent, and the affine
    map the page draws with agrees with pyproj's geodesic from the site's reference point to centimetres."""
    from pyproj import Geod

    site = client.get(f"/api/projects/{project}/models/{model}/site").json()
    assert site["georeferenced"] and "IfcSite" in site["source"]
    ring = np.array(site["footprint_xy"][0])
    lo, hi = scene.bounds()
    assert (ring.min(axis=0) >= lo[:2] - 1e-3).all() and (ring.max(axis=0) <= hi[:2] + 1e-3).all()
    assert np.ptp(ring[:, 0]) > 0.9 * (hi[0] - lo[0]) and np.ptp(ring[:, 1]) > 0.9 * (hi[1] - lo[1])
    ref = scene.metadata["site_location"]
    f = site["to_lat_lon"]
    for x, y in [(0.0, 0.0), (300.0, -200.0), (-250.0, 400.0)]:  # the origin and two points a pilot might stand on
        lat = f["origin_lat_lon"][0] + np.dot(f["matrix"][0], np.subtract([x, y], f["origin_xy"]))
        lon = f["origin_lat_lon"][1] + np.dot(f["matrix"][1], np.subtract([x, y], f["origin_xy"]))
        ox, oy = np.asarray(ref.get("origin_m") or (0, 0, 0))[:2]
        heading = np.degrees(np.arctan2(x - ox, y - oy)) + (ref.get("true_north_deg") or 0.0)
        want_lon, want_lat, _ = Geod(ellps="WGS84").fwd(ref["longitude_deg"], ref["latitude_deg"], heading,
                                                         np.hypot(x - ox, y - oy))
        assert Geod(ellps="WGS84").inv(lon, lat, want_lon, want_lat)[2] < 0.1
    assert site["to_lat_lon"]["max_error_m"] < 0.1


def test_a_mesh_without_georeference_is_drawn_about_zero_zero(client, project):
    box = trimesh.creation.box((10.0, 4.0, 3.0))
    buf = io.BytesIO()
    box.export(buf, file_type="obj")
    r = client.post(f"/api/projects/{project}/models", files={"file": ("box.obj", buf.getvalue())})
    assert wait_job(client, r.json()["job"]["id"])["status"] == "done"
    site = client.get(f"/api/projects/{project}/models/{r.json()['model']['id']}/site").json()
    assert not site["georeferenced"] and "no georeference" in site["note"]
    assert site["centre_lat_lon"] == pytest.approx([0.0, 0.0], abs=1e-6)
    ring = np.array(site["footprint_xy"][0])
    assert np.ptp(ring, axis=0) == pytest.approx([10.0, 4.0], abs=0.11)  # the box, widened by nothing


def test_a_basemap_is_configured_checked_and_allowed(tmp_path):
    from sightplan.web.config import ServerConfigError

    with pytest.raises(ServerConfigError, match=r"\{z\}, \{x\} and \{y\}"):
        ServerConfig(data_dir=tmp_path, basemap_url="https://tiles.example.com/tile.png")
    url = "https://tiles.example.com/{z}/{x}/{-y}.png"
    with TestClient(create_app(ServerConfig(data_dir=tmp_path, basemap_url=url, basemap_attribution="© tiles"))) as c:
        r = c.get("/api/info")
        assert r.json()["basemap"] == {"url": url, "attribution": "© tiles"}
        policy = r.headers["content-security-policy"]
        assert "img-src 'self' data: blob: https://tiles.example.com;" in policy
        assert "connect-src 'self' https://tiles.example.com;" in policy


def _geotiff(path, easting: float, northing: float, epsg: int | None = 32616, size=(40, 60)) -> None:
    """A small RGB GeoTIFF: 5 cm pixels, its top-left corner at (easting, northing) in EPSG ``epsg``."""
    import tifffile

    rgb = np.zeros((*size, 3), np.uint8)
    rgb[..., 1] = 180
    keys = [1, 1, 0, 3, 1024, 0, 1, 1, 1025, 0, 1, 1, 3072, 0, 1, epsg or 32767]
    tags = [(33550, "d", 3, (0.05, 0.05, 0.0), False), (34735, "H", len(keys), keys, False),
            (33922, "d", 6, (0.0, 0.0, 0.0, easting, northing, 0.0), False)]
    tifffile.imwrite(path, rgb, photometric="rgb", extratags=tags)


def test_a_project_background_from_an_orthomosaic_and_from_mbtiles(client, project, tmp_path):
    """A GeoTIFF orthomosaic is placed by its own tags (its corners against pyproj's UTM → WGS 84); an MBTiles file is
    served tile by tile with its rows counted from the south; a TIFF without a georeference and vector tiles are
    refused with what to do."""
    import sqlite3

    import tifffile
    from pyproj import Transformer

    tif = tmp_path / "ortho.tif"
    _geotiff(tif, 447000.0, 4636000.0)
    r = client.post(f"/api/projects/{project}/basemap", files={"file": ("ortho.tif", tif.read_bytes())})
    assert r.status_code == 200, r.text
    bg = r.json()
    assert bg["kind"] == "image" and (bg["width_px"], bg["height_px"]) == (60, 40)
    to_geo = Transformer.from_crs("EPSG:32616", "EPSG:4326", always_xy=True)
    want = [to_geo.transform(447000.0 + dx, 4636000.0 - dy) for dx, dy in ((0, 0), (3, 0), (3, 2), (0, 2))]
    assert np.allclose(bg["corners"], want, atol=1e-9)
    png = client.get(bg["url"])
    assert png.status_code == 200 and png.content[:8] == b"\x89PNG\r\n\x1a\n"
    assert client.get(f"/api/projects/{project}/basemap").json()["basemap"]["corners"] == bg["corners"]
    # MBTiles: one tile at z 1, x 0, XYZ row 0 (the file's row 1)
    mb = tmp_path / "site.mbtiles"
    with sqlite3.connect(mb) as db:
        db.execute("CREATE TABLE metadata (name TEXT, value TEXT)")
        db.execute("CREATE TABLE tiles (zoom_level INTEGER, tile_column INTEGER, tile_row INTEGER, tile_data BLOB)")
        db.executemany("INSERT INTO metadata VALUES (?, ?)", [("format", "png"), ("bounds", "-88,41,-87,42"),
                                                              ("attribution", "drone survey")])
        db.execute("INSERT INTO tiles VALUES (1, 0, 1, ?)", (b"\x89PNG-north-west",))
    r = client.post(f"/api/projects/{project}/basemap", files={"file": ("site.mbtiles", mb.read_bytes())})
    assert r.status_code == 200 and r.json()["kind"] == "tiles" and r.json()["bounds"] == [-88, 41, -87, 42]
    assert client.get(f"/api/projects/{project}/basemap/tiles/1/0/0").content == b"\x89PNG-north-west"
    assert client.get(f"/api/projects/{project}/basemap/tiles/1/0/1").status_code == 404
    # refusals, and the previous background kept
    bad = tmp_path / "plain.tif"
    tifffile.imwrite(bad, np.zeros((8, 8, 3), np.uint8))
    r = client.post(f"/api/projects/{project}/basemap", files={"file": ("plain.tif", bad.read_bytes())})
    assert r.status_code == 422 and "GeoTIFF" in r.json()["detail"]
    _geotiff(bad, 447000.0, 4636000.0, epsg=None)  # a user-defined CRS
    r = client.post(f"/api/projects/{project}/basemap", files={"file": ("local.tif", bad.read_bytes())})
    assert r.status_code == 422 and "EPSG code" in r.json()["detail"]
    with sqlite3.connect(mb) as db:
        db.execute("UPDATE metadata SET value = 'pbf' WHERE name = 'format'")
    r = client.post(f"/api/projects/{project}/basemap", files={"file": ("vector.mbtiles", mb.read_bytes())})
    assert r.status_code == 422 and "raster tiles" in r.json()["detail"]
    assert client.get(f"/api/projects/{project}/basemap").json()["basemap"]["kind"] == "tiles"
    assert client.delete(f"/api/projects/{project}/basemap").status_code == 204
    assert client.get(f"/api/projects/{project}/basemap").json() == {"basemap": None}
