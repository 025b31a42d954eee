"""Reality captures in the web server: a point cloud served as 3D Tiles (every point once, read back with struct and
json), a mesh as GLB with glTF's Y up, a capture as occluders in an evaluation (as the library's ``combine``), and
no file left behind when the project goes."""

from __future__ import annotations

import io
import json
import struct

import numpy as np
import pytest
import trimesh
from scipy.spatial import cKDTree

pytest.importorskip("fastapi")
plyfile = pytest.importorskip("plyfile")

from fastapi.testclient import TestClient  # noqa: E402

from sightplan.errors import ReportError  # noqa: E402
from sightplan.evaluate import EvaluationSettings, evaluate  # noqa: E402
from sightplan.model.load import load_model, sample_model_path  # noqa: E402
from sightplan.model.reality import combine, load_reality  # noqa: E402
from sightplan.plan.format import plan_from_dict  # noqa: E402
from sightplan.report.html import find_three  # noqa: E402
from sightplan.web.app import create_app  # noqa: E402
from sightplan.web.config import ServerConfig  # noqa: E402
from web_support import wait_job  # noqa: E402

SCALE = 0.05




def glb_parts(data: bytes) -> tuple[dict, bytes]:
    magic, version, total = struct.unpack_from("<III", data)
    assert magic == 0x46546C67 and version == 2 and total == len(data)
    n_json, _ = struct.unpack_from("<II", data, 12)
    doc = json.loads(data[20:20 + n_json])
    n_bin, _ = struct.unpack_from("<II", data, 20 + n_json)
    return doc, data[28 + n_json:28 + n_json + n_bin]


def tile_points(doc: dict, binary: bytes) -> np.ndarray:
    """The tile's POSITION in model coordinates (Z up): node translation added, glTF's (x, y, z) = model (x, z, −y)."""
    acc = doc["accessors"][doc["meshes"][0]["primitives"][0]["attributes"]["POSITION"]]
    view = doc["bufferViews"][acc["bufferView"]]
    local = np.frombuffer(binary, np.float32, acc["count"] * 3, view.get("byteOffset", 0)).reshape(-1, 3)
    g = local.astype(np.float64) + doc["nodes"][0].get("translation", [0, 0, 0])
    return np.column_stack([g[:, 0], -g[:, 2], g[:, 1]])


@pytest.fixture(scope="module")
def client(tmp_path_factory):
    with TestClient(create_app(ServerConfig(data_dir=tmp_path_factory.mktemp("real") / "d"))) as c:
        yield c


@pytest.fixture(scope="module")
def project(client) -> int:
    return client.post("/api/projects", json={"name": "reality"}).json()["id"]


def test_point_cloud_is_served_as_tiles_holding_every_point_once(client, project):
    rng = np.random.default_rng(7)
    n = 120_000
    pts = np.column_stack([rng.uniform(0, 30, n), np.full(n, 12.0) + rng.normal(0, 0.01, n), rng.uniform(0, 9, n)])
    vertex = np.empty(n, dtype=[("x", "f8"), ("y", "f8"), ("z", "f8")])
    vertex["x"], vertex["y"], vertex["z"] = pts.T
    buf = io.BytesIO()
    plyfile.PlyData([plyfile.PlyElement.describe(vertex, "vertex")]).write(buf)
    r = client.post(f"/api/projects/{project}/reality", files={"file": ("scan.ply", buf.getvalue())})
    assert r.status_code == 202, r.text
    assert r.json()["reality"]["kind"] == "points"
    assert wait_job(client, r.json()["job"]["id"])["status"] == "done"
    row = client.get(f"/api/projects/{project}/reality/{r.json()['reality']['id']}").json()
    assert row["status"] == "ready" and row["points"] == n
    np.testing.assert_allclose(row["bounds"]["lo"], pts.min(axis=0))
    np.testing.assert_allclose(row["bounds"]["hi"], pts.max(axis=0))
    tileset = client.get(row["view_url"]).json()
    base = row["view_url"].rsplit("/", 1)[0]
    found, stack = [], [tileset["root"]]
    while stack:
        tile = stack.pop()
        stack += tile.get("children", [])
        if "content" in tile:
            data = client.get(f"{base}/{tile['content']['uri']}")
            assert data.status_code == 200 and data.headers["content-type"] == "model/gltf-binary"
            found.append(tile_points(*glb_parts(data.content)))
    got = np.concatenate(found)
    assert len(got) == n  # every point once
    dist, idx = cKDTree(pts).query(got)
    assert dist.max() < 1e-4 and len(np.unique(idx)) == n  # each input point, found once (float32 in the tiles)
    for bad in ("../../tileset.json", "x.glb", "..%2F..%2Fsightplan.db", "..%2Ftileset.json"):
        r = client.get(f"{base}/tiles/{bad}")
        assert r.status_code in (404, 422) and "root" not in r.text and "SQLite" not in r.text, bad


def test_mesh_capture_is_a_y_up_glb_and_occludes_in_evaluations(client, project):
    """A 40 × 1 × 12 m hoarding south of the Duplex: the evaluation with it as occluder is the library's with
    ``combine(scene, reality, "occluder")``, and sees less than without it."""
    wall = trimesh.creation.box((40, 1, 12), trimesh.transformations.translation_matrix((5, -14, 6)))
    obj = io.BytesIO()
    wall.export(obj, file_type="obj")
    r = client.post(f"/api/projects/{project}/reality", files={"file": ("hoarding.obj", obj.getvalue())})
    assert r.status_code == 202 and r.json()["reality"]["kind"] == "mesh"
    assert wait_job(client, r.json()["job"]["id"])["status"] == "done"
    rid = r.json()["reality"]["id"]
    row = client.get(f"/api/projects/{project}/reality/{rid}").json()
    assert row["triangles"] == 12
    doc, binary = glb_parts(client.get(row["view_url"]).content)
    acc = doc["accessors"][doc["meshes"][0]["primitives"][0]["attributes"]["POSITION"]]
    at = np.asarray(doc["nodes"][0].get("translation", [0, 0, 0]))  # the node's place plus its vertices' offsets
    np.testing.assert_allclose([acc["min"] + at, acc["max"] + at], [[-15, 0, 13.5], [25, 12, 14.5]], atol=1e-5)  # (x, z, −y)
    assert client.get(f"/api/projects/{project}/reality/{rid}/tileset.json").status_code == 404  # not a cloud
    with open(sample_model_path(), "rb") as fh:
        up = client.post(f"/api/projects/{project}/models", files={"file": ("duplex.ifc", fh)}).json()
    assert wait_job(client, up["job"]["id"])["status"] == "done"
    plan_id = client.post(f"/api/projects/{project}/plans", json={
        "model_id": up["model"]["id"], "template": "orbit", "radius_m": [24], "height_m": [5.0], "step_deg": 30}).json()["id"]
    metrics = {}
    for with_wall in (False, True):
        body = {"plan_id": plan_id, "settings": {"scale": SCALE, "engine": "embree"}}
        if with_wall:
            body["reality_id"] = rid
        ev = client.post(f"/api/projects/{project}/evaluations", json=body).json()
        assert wait_job(client, ev["job"]["id"])["status"] == "done"
        metrics[with_wall] = client.get(f"/api/projects/{project}/evaluations/{ev['evaluation']['id']}").json()
    scene, _ = load_model("sample")
    obj_path = client.app.state.sightplan.storage.reality_path(
        next(p.name for p in client.app.state.sightplan.storage.reality.iterdir() if p.suffix == ".obj"))
    occluded = combine(scene, load_reality(obj_path, cache=False), "occluder")
    plan = plan_from_dict(client.get(f"/api/projects/{project}/plans/{plan_id}/versions/1").json())
    ref = evaluate(occluded, plan, EvaluationSettings(scale=SCALE, engine="embree"), cache_dir=False).metrics.plan
    assert metrics[True]["metrics"]["VR"] == pytest.approx(ref.VR)
    assert metrics[True]["metrics"]["VR"] < metrics[False]["metrics"]["VR"]
    assert metrics[True]["settings"]["reality_id"] == rid
    eid = metrics[True]["id"]
    feedback = client.get(f"/api/projects/{project}/evaluations/{eid}/feedback")
    assert feedback.status_code == 200, feedback.text
    # the simulated view from the southernmost frame, behind the hoarding, sees the hoarding instead of the house
    south = int(np.argmin(plan.C_world[:, 1]))
    from PIL import Image

    from sightplan.report.overview import OCCLUDER

    grey = []
    for e in (metrics[False]["id"], eid):
        view = client.get(f"/api/projects/{project}/evaluations/{e}/frames/{south}/view.png",
                          params={"width": 200, "shading": False})
        assert view.status_code == 200 and view.headers["content-type"] == "image/png"
        rgb = np.asarray(Image.open(io.BytesIO(view.content)).convert("RGB")).reshape(-1, 3).astype(int)
        grey.append(float(np.mean(np.abs(rgb - np.round(np.asarray(OCCLUDER[:3]) * 255)).max(axis=1) <= 2)))
    assert grey[1] > grey[0] + 0.2  # the hoarding, an occluder, fills much of the view
    in_use = client.delete(f"/api/projects/{project}/reality/{rid}")
    assert in_use.status_code == 409 and f"evaluation(s) {eid}" in in_use.json()["detail"]
    report = client.get(f"/api/projects/{project}/evaluations/{eid}/report.html")
    try:
        find_three()
    except ReportError:
        assert report.status_code == 503 and "make setup" in report.json()["detail"]
    else:
        assert report.status_code == 200 and report.headers["content-type"].startswith("text/html")


def test_deleting_the_project_removes_its_captures_and_schedules(client):
    pid = client.post("/api/projects", json={"name": "short-lived"}).json()["id"]
    r = client.post(f"/api/projects/{pid}/reality", files={"file": ("box.stl", trimesh.creation.box().export(
        file_type="stl"))})
    assert wait_job(client, r.json()["job"]["id"])["status"] == "done"
    folder = client.app.state.sightplan.storage.reality
    before = {p.name for p in folder.iterdir()}
    assert len(before) >= 2  # the upload and its GLB
    assert client.delete(f"/api/projects/{pid}").status_code == 204
    after = {p.name for p in folder.iterdir()}
    assert len(before - after) == 2
    bad = client.post("/api/projects", json={"name": "bad"}).json()["id"]
    assert client.post(f"/api/projects/{bad}/reality", files={"file": ("x.pdf", b"%PDF")}).status_code == 415
