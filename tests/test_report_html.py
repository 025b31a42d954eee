"""The coloured glTF and the self-contained HTML report, read back by independent parsers.

The GLB is parsed here with struct and json alone (not with trimesh, which wrote it); the
HTML with the standard library's html.parser. Where Debian's Chromium is installed, the
page is opened headless and its screenshot must show the coloured model.
"""

from __future__ import annotations

import base64
import io
import json
import os
import re
import struct
import subprocess
from html.parser import HTMLParser
from pathlib import Path

import numpy as np
import pytest

from sightplan.camera.models import PinholeCamera
from sightplan.errors import ReportError
from sightplan.evaluate import Evaluation, EvaluationSettings, evaluate
from sightplan.metrics import MetricParams
from sightplan.model.load import load_model
from sightplan.model.scene import ElementTable, Scene
from sightplan.plan.ring import ring_plan
from sightplan.plan.types import Plan
from sightplan.report.gltf import scene_glb, write_gltf
from sightplan.report.html import worst_elements, write_html
from sightplan.report.overview import OCCLUDER, UNSEEN, VISIBLE

CHROMIUM = Path("/usr/bin/chromium")


# --------------------------------------------------------------------------- an analytic scene
def _rect(x0, x1, y0, y1, z0, z1) -> tuple[np.ndarray, np.ndarray]:
    """An axis-aligned rectangle (one extent is zero): four corners, two triangles."""
    if y0 == y1:
        v = [[x0, y0, z0], [x1, y0, z0], [x1, y0, z1], [x0, y0, z1]]
    elif z0 == z1:
        v = [[x0, y0, z0], [x1, y0, z0], [x1, y1, z0], [x0, y1, z0]]
    else:
        raise ValueError("only walls y = const and floors z = const")
    return np.array(v, float), np.array([[0, 1, 2], [0, 2, 3]])


def analytic_scene() -> Scene:
    """A wall facing south (seen), a panel hidden behind it (unseen), a ground occluder, one element without geometry."""
    parts = [(0, _rect(-5, 5, 10, 10, 0, 5)),        # WALL: in front of every camera
             (1, _rect(-1, 1, 12, 12, 1, 2)),        # HIDDEN: behind the wall
             (2, _rect(-20, 20, -10, 30, 0, 0))]     # GROUND: an occluder, not a target
    verts, faces, face_el, off = [], [], [], 0
    for element, (v, f) in parts:
        verts.append(v)
        faces.append(f + off)
        face_el += [element] * len(f)
        off += len(v)
    table = ElementTable.build(["WALL-0001", "HIDDEN-002", "GROUND-003", "NOGEOM-004"],
                               name=["south wall", "hidden panel", "ground", "no geometry"],
                               ifc_class=["IfcWall", "IfcPlate", "IfcSite", "IfcBuildingElementProxy"],
                               is_target=[True, True, False, True])
    return Scene.from_arrays(np.concatenate(verts), np.concatenate(faces), np.array(face_el), table)


def analytic_plan(n: int = 6) -> Plan:
    """``n`` frames 10 m south of the wall at 2.5 m, looking north, stepping east."""
    cam = PinholeCamera(160, 120, 100.0, 100.0, 80.0, 60.0, name="test")
    R_north = np.array([[1.0, 0.0, 0.0], [0.0, 0.0, 1.0], [0.0, -1.0, 0.0]])
    C = np.column_stack([np.linspace(-1, 1, n), np.zeros(n), np.full(n, 2.5)])
    return Plan.build(cam, np.repeat(R_north[None], n, axis=0), C)


@pytest.fixture(scope="module")
def analytic() -> tuple[Scene, Plan, Evaluation]:
    scene, plan = analytic_scene(), analytic_plan()
    ev = evaluate(scene, plan, EvaluationSettings(metric=MetricParams(omega=100, min_features=5)), cache_dir=False)
    em = ev.metrics.elements
    assert em.visible[0] and em.VR[0] == len(plan), "the wall is seen by every frame"
    assert not em.observed[1], "the panel behind the wall is hidden"
    assert not em.is_target[2]
    return scene, plan, ev


@pytest.fixture(scope="module")
def sample() -> tuple[Scene, Plan, Evaluation]:
    scene, _ = load_model("sample")
    plan = ring_plan(scene, PinholeCamera(400, 300, 300.0, 300.0, 200.0, 150.0, name="small"), n_frames=6)
    return scene, plan, evaluate(scene, plan, EvaluationSettings(scale=0.5), cache_dir=False)


# --------------------------------------------------------------------------- an independent GLB reader
COMPONENTS = {5121: np.uint8, 5123: np.uint16, 5125: np.uint32, 5126: np.float32}
WIDTH = {"SCALAR": 1, "VEC2": 2, "VEC3": 3, "VEC4": 4}


def read_glb(data: bytes) -> tuple[dict, bytes]:
    magic, version, length = struct.unpack_from("<4sII", data, 0)
    assert magic == b"glTF" and version == 2 and length == len(data)
    chunks, off = [], 12
    while off < length:
        size, kind = struct.unpack_from("<I4s", data, off)
        chunks.append((kind, data[off + 8:off + 8 + size]))
        off += 8 + size
    assert chunks[0][0] == b"JSON"
    binary = chunks[1][1] if len(chunks) > 1 and chunks[1][0] == b"BIN\x00" else b""
    return json.loads(chunks[0][1]), binary


def accessor(gltf: dict, binary: bytes, k: int) -> np.ndarray:
    acc = gltf["accessors"][k]
    view = gltf["bufferViews"][acc["bufferView"]]
    dtype = np.dtype(COMPONENTS[acc["componentType"]])
    width = WIDTH[acc["type"]]
    start = view.get("byteOffset", 0) + acc.get("byteOffset", 0)
    stride = view.get("byteStride", dtype.itemsize * width)
    rows = [np.frombuffer(binary, dtype, width, start + i * stride) for i in range(acc["count"])] \
        if stride != dtype.itemsize * width else [np.frombuffer(binary, dtype, acc["count"] * width, start)]
    return np.concatenate(rows).reshape(acc["count"], width) if width > 1 else np.concatenate(rows)


def node_triangles(gltf: dict, binary: bytes, node: dict) -> np.ndarray:
    """(F, 3, 3) the node's triangles in the file's coordinates (node matrices applied)."""
    tris = []
    matrix = np.array(node.get("matrix", np.eye(4).T.ravel())).reshape(4, 4).T
    for prim in gltf["meshes"][node["mesh"]]["primitives"]:
        assert prim.get("mode", 4) == 4
        pos = accessor(gltf, binary, prim["attributes"]["POSITION"]).astype(np.float64)
        pos = pos @ matrix[:3, :3].T + matrix[:3, 3]
        idx = accessor(gltf, binary, prim["indices"]).astype(np.int64).reshape(-1, 3)
        tris.append(pos[idx])
    return np.concatenate(tris)


def srgb(linear) -> np.ndarray:
    c = np.asarray(linear, float)
    return np.where(c <= 0.0031308, 12.92 * c, 1.055 * c ** (1 / 2.4) - 0.055)


def node_colour(gltf: dict, node: dict) -> tuple[np.ndarray, dict]:
    """sRGB colour and material of the node's (first) primitive."""
    material = gltf["materials"][gltf["meshes"][node["mesh"]]["primitives"][0]["material"]]
    rgba = material["pbrMetallicRoughness"]["baseColorFactor"]
    return srgb(rgba[:3]), material


def expected_viewer_triangles(scene: Scene, element: int) -> np.ndarray:
    """The element's triangles centred on the model's box, Z-up turned Y-up: (x, y, z) → (x, z, −y)."""
    used = scene.vertices[np.unique(scene.faces)]
    centre = (used.min(0) + used.max(0)) / 2
    tri = scene.vertices[scene.faces[scene.face_element == element]] - centre
    return np.stack([tri[..., 0], tri[..., 2], -tri[..., 1]], axis=-1)


def canonical(tris: np.ndarray) -> np.ndarray:
    """Triangles as sorted rows, independent of vertex order within a triangle and of triangle order."""
    r = np.round(tris, 4)
    r = np.sort(r.view([("x", float), ("y", float), ("z", float)]).reshape(len(r), 3), axis=1)
    r = np.array(r.tolist()).reshape(len(r), 9)
    return r[np.lexsort(r.T[::-1])]


# --------------------------------------------------------------------------- glTF
def test_glb_nodes_colours_and_geometry(analytic, tmp_path):
    scene, _, ev = analytic
    path = write_gltf(scene, ev.metrics, tmp_path / "model.glb")
    gltf, binary = read_glb(path.read_bytes())
    nodes = {n["name"]: n for n in gltf["nodes"] if "mesh" in n}
    # one node per element with geometry, named by GlobalId; the element without faces has none
    assert sorted(nodes) == ["GROUND-003", "HIDDEN-002", "WALL-0001"]
    assert nodes["WALL-0001"]["extras"]["element"] == 0
    assert nodes["WALL-0001"]["extras"]["name"] == "south wall"
    assert nodes["WALL-0001"]["extras"]["ifc_class"] == "IfcWall"
    assert nodes["WALL-0001"]["extras"]["VR_i"] == 6 and nodes["WALL-0001"]["extras"]["visibility"] == "visible"
    assert nodes["HIDDEN-002"]["extras"]["visibility"] == "unseen" and nodes["HIDDEN-002"]["extras"]["R_i_m_per_px"] is None
    # colours: seen green, unseen target red, occluder grey and see-through
    wall, _ = node_colour(gltf, nodes["WALL-0001"])
    hidden, _ = node_colour(gltf, nodes["HIDDEN-002"])
    ground, ground_mat = node_colour(gltf, nodes["GROUND-003"])
    np.testing.assert_allclose(wall, VISIBLE, atol=0.01)
    np.testing.assert_allclose(hidden, UNSEEN, atol=0.01)
    assert hidden[0] > 0.7 and hidden[1] < 0.3 and wall[1] > wall[0] and wall[1] > wall[2]
    np.testing.assert_allclose(ground, OCCLUDER, atol=0.01)
    assert ground_mat["alphaMode"] == "BLEND" and ground_mat["pbrMetallicRoughness"]["baseColorFactor"][3] < 0.6
    # geometry: every triangle kept, centred, Y up
    total = 0
    for node in nodes.values():
        got = node_triangles(gltf, binary, node)
        element = node["extras"]["element"]
        total += len(got)
        np.testing.assert_allclose(canonical(got), canonical(expected_viewer_triangles(scene, element)), atol=1e-3)
    assert total == len(scene.faces)
    wall_tris = node_triangles(gltf, binary, nodes["WALL-0001"])
    ground_tris = node_triangles(gltf, binary, nodes["GROUND-003"])
    assert np.ptp(wall_tris[..., 1]) == pytest.approx(5.0, abs=1e-4)       # the wall's 5 m height is along +Y
    assert np.ptp(ground_tris[..., 1]) == pytest.approx(0.0, abs=1e-4)     # the ground is level: constant Y …
    assert ground_tris[..., 1].max() <= wall_tris[..., 1].min() + 1e-4      # … below the wall
    hidden_tris = node_triangles(gltf, binary, nodes["HIDDEN-002"])
    assert hidden_tris[..., 2].max() < wall_tris[..., 2].min()              # north (model +Y) is glTF −Z


@pytest.mark.parametrize("colour_by, bounds, wall_colour", [
    ("vr", (0.0, 6.0), VISIBLE),            # VR: more frames is better, 6 of 6 → green
    ("vr", (6.0, 20.0), UNSEEN),            # … at the low end → red
    ("ssd", None, None),                    # a single visible element: the middle of the gradient, yellow
    ("orientation", (90.0, 180.0), VISIBLE),  # O: smaller is better
])
def test_glb_metric_gradient(analytic, colour_by, bounds, wall_colour):
    scene, _, ev = analytic
    gltf, _ = read_glb(scene_glb(scene, ev.metrics, colour_by, bounds))
    nodes = {n["name"]: n for n in gltf["nodes"] if "mesh" in n}
    wall, _ = node_colour(gltf, nodes["WALL-0001"])
    if wall_colour is None:
        assert wall[0] > 0.8 and wall[1] > 0.6 and wall[2] < 0.3, wall
    else:
        np.testing.assert_allclose(wall, wall_colour, atol=0.01)
    np.testing.assert_allclose(node_colour(gltf, nodes["HIDDEN-002"])[0], UNSEEN, atol=0.01)
    ssd = ev.metrics.elements.R[0]
    gltf, _ = read_glb(scene_glb(scene, ev.metrics, "ssd", (ssd / 4, ssd / 2)))
    worse = node_colour(gltf, {n["name"]: n for n in gltf["nodes"]}["WALL-0001"])[0]
    np.testing.assert_allclose(worse, UNSEEN, atol=0.01)   # an SSD above the upper bound is red


def test_bad_colour_options(analytic, tmp_path):
    scene, plan, ev = analytic
    with pytest.raises(ReportError, match="unknown metric"):
        scene_glb(scene, ev.metrics, "colour")  # type: ignore[arg-type]
    with pytest.raises(ReportError, match="LO < HI"):
        scene_glb(scene, ev.metrics, "vr", (3.0, 3.0))
    with pytest.raises(ReportError, match="not to visibility"):
        scene_glb(scene, ev.metrics, "visibility", (0.0, 1.0))
    with pytest.raises(ReportError, match="make setup"):
        write_html(ev, scene, plan, tmp_path / "r.html", three_dir=tmp_path / "no-three")
    blocker = tmp_path / "file"
    blocker.write_text("")
    with pytest.raises(ReportError, match="cannot write"):
        write_gltf(scene, ev.metrics, blocker / "model.glb")


# --------------------------------------------------------------------------- HTML
class Page(HTMLParser):
    """Tags with their attributes, script texts, and the cells of every table by id."""

    def __init__(self) -> None:
        super().__init__(convert_charrefs=True)
        self.tags: list[tuple[str, dict]] = []
        self.scripts: list[tuple[dict, str]] = []
        self.styles: list[str] = []
        self.cells: dict[str, list[tuple[dict, str]]] = {}
        self._stack: list[tuple[str, dict]] = []
        self._text: list[str] = []
        self._table: list[str] = []

    def handle_starttag(self, tag, attrs):
        a = {k: v or "" for k, v in attrs}
        self.tags.append((tag, a))
        if tag == "table":
            self._table.append(a.get("id", ""))
        if tag in ("script", "style", "td", "th"):
            self._stack.append((tag, a))
            self._text = []

    def handle_endtag(self, tag):
        if tag == "table" and self._table:
            self._table.pop()
        if self._stack and self._stack[-1][0] == tag:
            _, a = self._stack.pop()
            text = "".join(self._text)
            if tag == "script":
                self.scripts.append((a, text))
            elif tag == "style":
                self.styles.append(text)
            elif tag == "td" and self._table:
                self.cells.setdefault(self._table[-1], []).append((a, text.strip()))

    def handle_data(self, data):
        self._text.append(data)


URL_ATTRS = {"src", "href", "action", "data", "poster", "srcset", "formaction", "background", "manifest", "ping"}
STATIC_IMPORT = re.compile(r"""^(?:import|export)\b[^;'"]*?\bfrom\s*['"]([^'"\n]+)['"]|^import\s*['"]([^'"\n]+)['"]""", re.M)
DYNAMIC_LOAD = re.compile(r"""(?:\bimport|\bfetch|\bimportScripts|\bnew\s+(?:Worker|WebSocket|EventSource))\s*\(\s*['"`]"""
                          r"""\s*(?:https?:)?//""")


def parse_page(path: Path) -> Page:
    page = Page()
    page.feed(path.read_text(encoding="utf-8"))
    page.close()
    return page


def table2(ev: Evaluation) -> dict[str, str]:
    p = ev.metrics.plan

    def f(x, spec, scale=1.0):
        return "—" if x is None else format(scale * x, spec)

    return {"VC": f(p.VC, ".2f", 100), "VC_bar": f(p.VC_bar, ".2f", 100), "VR": f(p.VR, ".2f"), "R": f(p.R, ".4f"),
            "O": f(p.O, ".2f"), "T": f(p.T, ".1f")}


@pytest.fixture(scope="module")
def sample_html(sample, tmp_path_factory) -> Path:
    scene, plan, ev = sample
    path = tmp_path_factory.mktemp("html") / "report.html"
    return write_html(ev, scene, plan, path, model_label="sample", plan_label="ring of 6", colour_by="ssd")


def test_html_metric_table_and_data(sample, sample_html):
    scene, plan, ev = sample
    page = parse_page(sample_html)
    cells = {a["data-metric"]: text for a, text in page.cells["plan-metrics"] if "data-metric" in a}
    assert cells == table2(ev)
    assert list(cells) == ["VC", "VC_bar", "VR", "R", "O", "T"]   # the order of the paper's Table 2
    em = ev.metrics.elements
    unseen = page.cells["worst-unseen"]
    assert len(unseen) == 8 * min(10, int((em.is_target & ~em.visible).sum()))
    data = json.loads(next(t for a, t in page.scripts if a.get("id") == "sightplan-data"))
    assert data["elements"]["global_id"] == scene.elements.global_id.tolist()
    assert data["metrics"]["vr"] == [int(v) if vis else None for v, vis in zip(em.VR, em.visible)]
    assert data["colour_by"] == "ssd" and len(data["cameras"]) == len(plan)
    pngs = [a["src"] for t, a in page.tags if t == "img"]
    assert len(pngs) == 2 and all(s.startswith("data:image/png;base64,") for s in pngs)
    assert all(base64.b64decode(s.split(",", 1)[1])[:8] == b"\x89PNG\r\n\x1a\n" for s in pngs)


def test_worst_unseen_elements_come_most_pixels_first_then_by_class_and_name(sample):
    scene, _, ev = sample
    em, el = ev.metrics.elements, scene.elements
    unseen = [i for i in range(scene.n_elements) if em.is_target[i] and not em.visible[i]]
    expected = sorted(unseen, key=lambda i: (-float(em.pixels_total[i]), str(el.ifc_class[i]), str(el.name[i])))
    _, rows, total = worst_elements(ev, scene, n=len(unseen))["unseen"]
    assert len(unseen) > 1 and total == len(unseen) and rows.tolist() == expected


def test_html_embeds_a_valid_glb(sample, sample_html):
    scene, _, _ = sample
    page = parse_page(sample_html)
    glb = base64.b64decode(next(t for a, t in page.scripts if a.get("id") == "sightplan-glb"), validate=True)
    gltf, binary = read_glb(glb)
    nodes = [n for n in gltf["nodes"] if "mesh" in n]
    with_faces = np.unique(scene.face_element)
    assert len(nodes) == len(with_faces)
    assert sorted(n["name"] for n in nodes) == sorted(scene.elements.global_id[with_faces].tolist())
    primitives = [p for n in nodes for p in gltf["meshes"][n["mesh"]]["primitives"]]
    triangles = sum(accessor(gltf, binary, p["indices"]).size // 3 for p in primitives)
    assert triangles == len(scene.faces)


def test_html_loads_nothing_from_outside(sample_html):
    page = parse_page(sample_html)
    for tag, attrs in page.tags:
        for name, value in attrs.items():
            if name in URL_ATTRS:
                assert not re.match(r"\s*(https?:)?//", value, re.I), (tag, name, value[:80])
    for css in page.styles:
        assert not re.search(r"url\(\s*['\"]?\s*(https?:)?//|@import", css, re.I)
    inlined = {a["data-specifier"] for a, _ in page.scripts if a.get("type") == "text/x-sightplan-module"}
    assert "three" in inlined
    for attrs, text in page.scripts:
        if attrs.get("type") in ("text/x-sightplan-module", "module"):
            # every module import is one of the inlined modules (the page maps them to blob URLs)
            for m in STATIC_IMPORT.finditer(text):
                assert (m.group(1) or m.group(2)) in inlined, m.group(0)[-120:]
        assert not DYNAMIC_LOAD.search(text), DYNAMIC_LOAD.search(text).group(0)
        assert "src" not in attrs


def _chromium(*args: str, cwd: Path) -> subprocess.CompletedProcess:
    flags = ["--headless", "--disable-gpu-sandbox", "--enable-unsafe-swiftshader",
             "--virtual-time-budget=5000", "--window-size=1200,900", "--hide-scrollbars"]
    if hasattr(os, "geteuid") and os.geteuid() == 0:
        flags.append("--no-sandbox")
    return subprocess.run([str(CHROMIUM), *flags, *args], capture_output=True, text=True, cwd=cwd, timeout=120,
                          env={**os.environ, "HOME": str(cwd)})


@pytest.mark.skipif(not CHROMIUM.exists() and not os.environ.get("CI"),
                    reason="Debian's chromium is not installed (`make setup` installs it as root)")
def test_html_draws_the_model_in_chromium(sample_html):
    from PIL import Image

    work = sample_html.parent
    shot = work / "shot.png"
    res = _chromium("--dump-dom", f"--screenshot={shot}", sample_html.as_uri(), cwd=work)
    state = re.search(r'<div id="viewer" data-state="(\w+)"(?: data-meshes="(\d+)")?', res.stdout)
    assert state is not None and state.group(1) == "ready", res.stdout[-2000:] + res.stderr[-2000:]
    assert int(state.group(2)) > 100
    assert shot.exists(), res.stderr[-2000:]
    rgb = np.asarray(Image.open(io.BytesIO(shot.read_bytes())).convert("RGB")).astype(int)
    assert len(np.unique(rgb.reshape(-1, 3), axis=0)) > 500, "a blank page"
    r, g, b = rgb[..., 0], rgb[..., 1], rgb[..., 2]
    greenish = (g > r + 40) & (g > b + 40)
    reddish = (r > g + 80) & (r > b + 80)
    # far more than the legend's swatches: the model itself, coloured on the traffic-light gradient
    assert greenish.sum() > 3000 and reddish.sum() > 3000, (greenish.sum(), reddish.sum())


# --------------------------------------------------------------------------- the command line
def run_cli(*args: str):
    from typer.testing import CliRunner

    from sightplan.cli.main import app

    return CliRunner().invoke(app, list(args), env={"COLUMNS": "400"})


def test_cli_writes_html_and_gltf(tmp_path):
    out = tmp_path / "out"
    res = run_cli("evaluate", "sample", "--ring-frames", "4", "--scale", "0.05", "--no-picture", "--out", str(out),
                  "--html", str(out / "report.html"), "--gltf", str(out / "model.glb"), "--colour-by", "vr",
                  "--bounds", "1,4")
    assert res.exit_code == 0, res.output
    assert str(out / "report.html") in res.stdout and str(out / "model.glb") in res.stdout
    gltf, _ = read_glb((out / "model.glb").read_bytes())
    assert gltf["scenes"][0]["extras"]["sightplan"]["colour_by"] == "vr"
    assert gltf["scenes"][0]["extras"]["sightplan"]["bounds"] == [1.0, 4.0]
    page = parse_page(out / "report.html")
    assert json.loads(next(t for a, t in page.scripts if a.get("id") == "sightplan-data"))["colour_by"] == "vr"


@pytest.mark.parametrize("args, words", [
    (["--gltf", "m.glb", "--colour-by", "height"], ["unknown metric", "visibility, vr, ssd, orientation"]),
    (["--gltf", "m.glb", "--colour-by", "ssd", "--bounds", "0.01,0.002"], ["LO < HI"]),
    (["--gltf", "m.glb", "--colour-by", "vr", "--bounds", "3"], ["LO,HI"]),
    (["--html", "{blocker}/report.html"], ["cannot write", "not a folder"]),
])
def test_cli_bad_report_options(tmp_path, args, words):
    (tmp_path / "blocker").write_text("")
    args = [a.replace("{blocker}", str(tmp_path / "blocker")) for a in args]
    res = run_cli("evaluate", "sample", "--ring-frames", "2", "--scale", "0.05", "--no-picture",
                  "--out", str(tmp_path / "out"), *args)
    assert res.exit_code == 2, res.output
    assert res.exception is None or isinstance(res.exception, SystemExit)
    err = res.stderr.strip()
    assert err.startswith("error:") and err.count("error:") == 1 and len(err.splitlines()) == 1, err
    for w in words:
        assert w in err, err
    assert "casting" not in res.stdout, "bad options are refused before any frame is cast"
    assert not (tmp_path / "out").exists()


def test_three_missing_is_one_clear_line(tmp_path, monkeypatch):
    import sightplan.report.html as report_html

    monkeypatch.setattr(report_html, "THREE_DIR", tmp_path / "web" / "node_modules" / "three")
    with pytest.raises(ReportError, match=r"three\.js is not installed .*make setup"):
        report_html.find_three()


def test_three_is_pinned_by_the_project():
    from sightplan.report.html import REPO_ROOT

    package = json.loads((REPO_ROOT / "web" / "package.json").read_text())
    lock = json.loads((REPO_ROOT / "web" / "package-lock.json").read_text())
    version = package["dependencies"]["three"]
    assert re.fullmatch(r"\d+\.\d+\.\d+", version), "an exact version, not a range"
    assert lock["packages"]["node_modules/three"]["version"] == version
