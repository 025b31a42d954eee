"""The command line end to end, and bad input: one clear line, a non-zero exit, no traceback."""

from __future__ import annotations

import contextlib
import csv
import json
import os
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from sightplan.model.load import sample_model_path


def run_cli(*args: str, cwd: Path) -> subprocess.CompletedProcess:
    """``sightplan ARGS`` run in ``cwd``, in this process (the command's own code, without a new interpreter's
    imports each time); its exit code, stdout and stderr as a finished process's."""
    from typer.testing import CliRunner

    from sightplan.cli.main import app

    with contextlib.chdir(cwd):
        r = CliRunner(env={"COLUMNS": "120"}).invoke(app, list(args), prog_name="sightplan")
    if r.exception is not None and not isinstance(r.exception, SystemExit):
        raise r.exception
    return subprocess.CompletedProcess(["sightplan", *args], r.exit_code, r.stdout, r.stderr)


def run_cli_process(*args: str, cwd: Path) -> subprocess.CompletedProcess:
    """``python -m sightplan ARGS`` in a process of its own."""
    env = {**os.environ, "COLUMNS": "120"}
    return subprocess.run([sys.executable, "-m", "sightplan", *args], capture_output=True, text=True, cwd=cwd, env=env,
                          timeout=600)


def assert_clean_error(res: subprocess.CompletedProcess, *words: str) -> None:
    assert res.returncode != 0, res.stdout
    assert "Traceback" not in res.stderr + res.stdout
    err = error_text(res.stderr)
    assert err.startswith("error:"), res.stderr
    for w in words:
        assert w.lower() in err.lower(), err


def error_text(stderr: str) -> str:
    """The one error of a failed command: from its ``error:`` line to the end (a cold load's progress lines may come
    before it on standard error, nothing after it)."""
    lines = stderr.strip().splitlines()
    first = next((i for i, line in enumerate(lines) if line.startswith("error:")), 0)
    return "\n".join(lines[first:])


@pytest.fixture(scope="module")
def sample_run(tmp_path_factory) -> Path:
    """One evaluation of the bundled sample with a small camera, its outputs kept for the tests below."""
    out = tmp_path_factory.mktemp("sample")
    res = run_cli("evaluate", "sample", "--camera", "p4p", "--ring-frames", "8", "--scale", "0.1",
                  "--save-plan", str(out / "ring.json"), "--out", str(out / "result"), cwd=out)
    assert res.returncode == 0, res.stderr
    return out


def test_evaluate_writes_report_and_tables(sample_run):
    report = json.loads((sample_run / "result" / "report.json").read_text())
    m = report["metrics"]
    assert m["frames"] == 8 and m["z"] > 100
    assert 0 < m["VC_pct"] <= 100 and m["VC_bar_pct"] >= m["VC_pct"]
    assert report["parameters"]["omega"] == 625 and report["parameters"]["scale"] == 0.1
    elements = (sample_run / "result" / "elements.csv").read_text().splitlines()
    assert elements[0].startswith("index,global_id,name,ifc_class,discipline,storey,visibility,VR_i")
    assert len(elements) - 1 == m["z"]
    visible = sum(1 for line in elements[1:] if ",visible," in line)
    assert visible == m["visible"]
    frames = (sample_run / "result" / "frames.csv").read_text().splitlines()
    assert len(frames) == 1 + 8


def test_saved_plan_re_evaluates_identically(sample_run):
    res = run_cli("evaluate", "sample", str(sample_run / "ring.json"), "--scale", "0.1", "--out",
                  str(sample_run / "again"), cwd=sample_run)
    assert res.returncode == 0, res.stderr
    a = json.loads((sample_run / "result" / "report.json").read_text())["metrics"]
    b = json.loads((sample_run / "again" / "report.json").read_text())["metrics"]
    assert a == b


def test_info_summarises_the_sample(tmp_path):
    res = run_cli("info", "sample", "--json", cwd=tmp_path)
    assert res.returncode == 0, res.stderr
    s = json.loads(res.stdout)
    assert s["triangles"] > 10000


def test_truncated_ifc(tmp_path):
    bad = tmp_path / "broken.ifc"
    bad.write_bytes(sample_model_path().read_bytes()[:20000])
    assert_clean_error(run_cli("evaluate", str(bad), "--no-cache", cwd=tmp_path), "broken.ifc")


def test_not_an_ifc(tmp_path):
    bad = tmp_path / "notes.ifc"
    bad.write_text("this is not a model\n")
    assert_clean_error(run_cli("info", str(bad), "--no-cache", cwd=tmp_path), "notes.ifc")


def test_missing_file(tmp_path):
    assert_clean_error(run_cli("info", str(tmp_path / "nope.ifc"), cwd=tmp_path), "nope.ifc")


def test_unknown_camera(tmp_path):
    assert_clean_error(run_cli("evaluate", "sample", "--camera", "phantom 9 ultra", cwd=tmp_path), "camera")


def _plan_json(sample_run: Path) -> dict:
    return json.loads((sample_run / "ring.json").read_text())


def test_plan_with_nan_position(sample_run, tmp_path):
    d = _plan_json(sample_run)
    d["frames"][3]["position"][1] = float("nan")
    p = tmp_path / "nan.json"
    p.write_text(json.dumps(d))  # json writes NaN, as some tools do
    assert_clean_error(run_cli("evaluate", "sample", str(p), cwd=tmp_path), "frame 3")


def test_plan_with_non_orthonormal_rotation(sample_run, tmp_path):
    d = _plan_json(sample_run)
    d["frames"][2]["rotation"][0][0] += 0.2
    p = tmp_path / "skew.json"
    p.write_text(json.dumps(d))
    assert_clean_error(run_cli("evaluate", "sample", str(p), cwd=tmp_path), "frame 2", "orthonormal")


def test_plan_from_a_newer_format_version(sample_run, tmp_path):
    d = _plan_json(sample_run)
    d["version"] = 7
    p = tmp_path / "future.json"
    p.write_text(json.dumps(d))
    assert_clean_error(run_cli("evaluate", "sample", str(p), cwd=tmp_path), "newer")


def test_empty_model(tmp_path):
    import trimesh

    empty = tmp_path / "empty.obj"
    trimesh.Trimesh(np.zeros((0, 3)), np.zeros((0, 3), int)).export(empty)
    if empty.stat().st_size == 0:
        empty.write_text("# no geometry\n")
    assert_clean_error(run_cli("evaluate", str(empty), "--no-cache", cwd=tmp_path), "empty.obj")


def test_date_before_anything_is_built(tmp_path):
    from sightplan.model.load import load_model

    scene, _ = load_model("sample")
    csv = tmp_path / "schedule.csv"
    rows = [f"{gid},2025-03-01,2025-06-30" for gid in scene.elements.global_id[:20]]
    csv.write_text("global_id,start,finish\n" + "\n".join(rows) + "\n")
    res = run_cli("evaluate", "sample", "--schedule", str(csv), "--date", "2024-01-01", "--scale", "0.05",
                  "--ring-frames", "2", cwd=tmp_path)
    # unscheduled elements exist at every date by default, so this evaluates; only the 20 are missing
    assert res.returncode == 0, res.stderr
    res = run_cli("evaluate", "sample", "--schedule", str(csv), "--date", "2024-01-01", "--unscheduled", "absent",
                  cwd=tmp_path)
    assert_clean_error(res, "no element", "2024-01-01", "2025-06-30")


def test_schedule_that_links_nothing(tmp_path):
    schedule = tmp_path / "schedule.csv"
    schedule.write_text("global_id,start,finish\n0000000000000000000000,2025-01-01,2025-02-01\n")
    assert_clean_error(run_cli("evaluate", "sample", "--schedule", str(schedule), cwd=tmp_path), "none is in this model",
                       "rules file")


def test_impossible_camera_in_plan(sample_run, tmp_path):
    d = _plan_json(sample_run)
    cam = next(iter(d["cameras"]))
    d["cameras"][cam]["fx"] = -10
    p = tmp_path / "cam.json"
    p.write_text(json.dumps(d))
    assert_clean_error(run_cli("evaluate", "sample", str(p), cwd=tmp_path), "focal")


def test_python_m_entry_point_has_help(tmp_path):
    res = run_cli("--help", cwd=tmp_path)
    assert res.returncode == 0 and "evaluate" in res.stdout


def test_cameras_lists_the_catalogue(tmp_path):
    res = run_cli("cameras", cwd=tmp_path)
    assert res.returncode == 0, res.stderr
    # the Phantom 4 Pro: 8.8 mm on a 13.2 mm wide sensor at 5472 px → fx = 3648 px
    line = next(x for x in res.stdout.splitlines() if "p4p" in x)
    assert "5472×3648" in line and "3648" in line
    assert "equirectangular" in res.stdout


def test_a_plan_keeps_its_own_camera(tmp_path):
    """A saved plan is evaluated with the camera it names, not the CLI's default camera."""
    saved = tmp_path / "m3e.json"
    res = run_cli("evaluate", "sample", "--camera", "m3e", "--ring-frames", "3", "--scale", "0.05",
                  "--save-plan", str(saved), "--out", str(tmp_path / "a"), cwd=tmp_path)
    assert res.returncode == 0, res.stderr
    res = run_cli("evaluate", "sample", str(saved), "--scale", "0.05", "--out", str(tmp_path / "b"), cwd=tmp_path)
    assert res.returncode == 0, res.stderr
    report = json.loads((tmp_path / "b" / "report.json").read_text())
    (cam,) = report["plan"]["cameras"].values()
    assert cam["width"] == 5280 and cam["height"] == 3956  # the Mavic 3 Enterprise, not the Phantom 4 Pro
    a = json.loads((tmp_path / "a" / "report.json").read_text())["metrics"]
    assert report["metrics"] == a


@pytest.mark.bench  # make bench; the steel structure's load and its schedule stay in make test
def test_schependomlaan_steel_evaluates_end_to_end(tmp_path):
    from conftest import shared_file

    steel = shared_file("schependomlaan", "BERNTS-Staalconstructie.ifc")
    res = run_cli("evaluate", str(steel), "--ring-frames", "6", "--scale", "0.1", "--out", str(tmp_path / "r"),
                  cwd=tmp_path)
    assert res.returncode == 0, res.stderr
    report = json.loads((tmp_path / "r" / "report.json").read_text())
    assert report["model"]["targets"] == 965  # 742 beams, 56 columns and the other steel members
    assert report["metrics"]["observed"] > 300
    assert 0 < report["metrics"]["VC_pct"] < 100


@pytest.mark.bench  # make bench; the feature cache's own tests stay in make test
def test_saved_features_give_the_same_result(tmp_path):
    """A feature set saved by one run and given to another reproduces T exactly."""
    feats = tmp_path / "features.npz"
    common = ("--ring-frames", "6", "--scale", "0.05", "--no-picture", "--no-cache")
    res = run_cli("evaluate", "sample", *common, "--save-features", str(feats), "--out", str(tmp_path / "a"), cwd=tmp_path)
    assert res.returncode == 0, res.stderr
    res = run_cli("evaluate", "sample", *common, "--features", str(feats), "--seed", "99", "--out", str(tmp_path / "b"),
                  cwd=tmp_path)
    assert res.returncode == 0, res.stderr
    a, b = (json.loads((tmp_path / d / "report.json").read_text())["metrics"] for d in "ab")
    assert a["T"] == b["T"] > 0 and a["features"] == b["features"] > 1000


def test_info_prints_readable_tables(tmp_path):
    res = run_cli("info", "sample", cwd=tmp_path)
    assert res.returncode == 0, res.stderr
    walls = next(line for line in res.stdout.splitlines() if "IfcWallStandardCase" in line)
    assert [c for c in walls.replace("│", " ").split()][1:] == ["56", "56", "0"]  # 56 walls, all targets
    assert "IfcOpeningElement" in res.stdout and "Level 1" in res.stdout


def test_transform_moves_a_flown_capture_into_the_model_frame(sample_run, tmp_path):
    """Poses shifted by +100 m in x and given with the inverse shift evaluate like the originals."""
    d = _plan_json(sample_run)
    for f in d["frames"]:
        f["position"][0] += 100.0
    shifted = tmp_path / "shifted.json"
    shifted.write_text(json.dumps(d))
    T = tmp_path / "T.json"
    T.write_text(json.dumps({"scale": 1.0, "rotation": np.eye(3).tolist(), "translation": [-100.0, 0, 0]}))
    res = run_cli("evaluate", "sample", str(shifted), "--transform", str(T), "--scale", "0.1", "--no-picture",
                  "--out", str(tmp_path / "t"), cwd=tmp_path)
    assert res.returncode == 0, res.stderr
    a = json.loads((sample_run / "result" / "report.json").read_text())["metrics"]
    b = json.loads((tmp_path / "t" / "report.json").read_text())["metrics"]
    assert b == a and b["visible"] > 10
    T.write_text("[[1, 0], [0, 1]]")
    assert_clean_error(run_cli("evaluate", "sample", str(shifted), "--transform", str(T), cwd=tmp_path), "transform")


def test_mesh_elements_are_picked_by_the_user(tmp_path):
    import trimesh

    a = trimesh.creation.box((4000, 4000, 3000), trimesh.transformations.translation_matrix((0, 0, 1500)))
    b = trimesh.creation.box((2000, 2000, 2000), trimesh.transformations.translation_matrix((8000, 0, 1000)))
    glb = tmp_path / "site.glb"
    trimesh.Scene({"house": a, "shed": b}).export(glb)
    counts = {}
    for grouping in ("objects", "components", "faces"):
        res = run_cli("info", str(glb), "--json", "--mesh-elements", grouping, "--mesh-scale", "0.001", "--no-cache",
                      cwd=tmp_path)
        assert res.returncode == 0, res.stderr
        counts[grouping] = json.loads(res.stdout)["targets"]
    assert counts == {"objects": 2, "components": 2, "faces": 24}  # two boxes of 12 triangles
    res = run_cli("evaluate", str(glb), "--mesh-elements", "objects", "--mesh-scale", "0.001", "--ring-frames", "8",
                  "--scale", "0.1", "--no-picture", "--out", str(tmp_path / "r"), cwd=tmp_path)
    assert res.returncode == 0, res.stderr
    report = json.loads((tmp_path / "r" / "report.json").read_text())
    assert report["metrics"]["VC_pct"] == 100.0  # a ring around two boxes sees both


def test_plan_facade_then_evaluate(tmp_path):
    import math

    from sightplan.model.load import load_model

    out = tmp_path / "facade.json"
    res = run_cli("plan", "facade", "sample", "-o", str(out), "--safety-distance", "8", "--overlap", "0.8", cwd=tmp_path)
    assert res.returncode == 0, res.stderr
    d = json.loads(out.read_text())
    lo, hi = load_model("sample")[0].bounds()
    sx, sy, sz = hi - lo
    # frames at 8 m + the GNSS position error's reach √(1.5² + 0.5²) + 1 cm, so that they pass the checks at it
    g = 8 + math.hypot(1.5, 0.5) + 0.01
    s_h, s_v = 2 * g * 0.75 * 0.2, 2 * g * 0.5 * 0.2  # eq. 11 with the Phantom 4 Pro: 2.88 m and 1.92 m
    # layers from 2 m + 0.5 m (the vertical error) + 1 cm above the ground (the door sills at z = 0), plus the top row
    per_col = math.ceil((hi[2] - 2.51) / s_v) + 1 + 1
    cols = [math.ceil(sx / s_h) + 1, math.ceil(sy / s_h) + 1] * 2
    assert [m["frames"][1] - m["frames"][0] for m in d["missions"]] == [c * per_col for c in cols]
    res = run_cli("evaluate", "sample", str(out), "--scale", "0.05", "--no-picture", "--out", str(tmp_path / "r"),
                  cwd=tmp_path)
    assert res.returncode == 0, res.stderr
    assert json.loads((tmp_path / "r" / "report.json").read_text())["metrics"]["frames"] == len(d["frames"])
    assert_clean_error(run_cli("plan", "orbit", "sample", "--radius", "30", "--height", "0", "-o", str(out), cwd=tmp_path),
                       "minimum height")
    assert_clean_error(run_cli("plan", "facade", "sample", "--overlap", "1.0", cwd=tmp_path), "overlap")


def test_plan_route_and_lawnmower(tmp_path):
    out = tmp_path / "route.json"
    res = run_cli("plan", "route", "sample", "--camera", "theta-z1", "--point", "1,-20,0.5", "--point", "1,3,0.5",
                  "--step", "1", "-o", str(out), cwd=tmp_path)
    assert res.returncode == 0, res.stderr
    assert len(json.loads(out.read_text())["frames"]) == 24  # 23 m walked, a frame every metre, both ends
    assert_clean_error(run_cli("plan", "route", "sample", "--point", "1,2", "--point", "3,4,5", "--step", "1",
                               cwd=tmp_path), "'1,2'", "x,y,z")
    res = run_cli("plan", "lawnmower", "sample", "--gsd", "0.005", "-o", str(tmp_path / "lm.json"), cwd=tmp_path)
    assert res.returncode == 0, res.stderr
    assert "gsd on top 0.005 m" in res.stdout


def test_plan_prints_missions_and_check_fails_on_a_violation(tmp_path):
    out = tmp_path / "facade.json"
    res = run_cli("plan", "facade", "sample", "-o", str(out), "--safety-distance", "8", "--aircraft", "m3e", cwd=tmp_path)
    assert res.returncode == 0, res.stderr
    assert "no violations" in res.stdout and "missions" in res.stdout
    d = json.loads(out.read_text())
    assert d["georeference"]["kind"] == "topocentric"  # the Duplex's IfcSite latitude/longitude (Chicago)
    assert all(len(m["ground_station"]) == 3 for m in d["missions"])
    # the same plan checked with a 30 m line-of-sight radius: the far ends of the long sides are out of sight
    report = tmp_path / "check.json"
    res = run_cli("check", str(out), "sample", "--vlos-radius", "30", "--json", str(report), cwd=tmp_path)
    assert res.returncode == 1, res.stdout + res.stderr
    r = json.loads(report.read_text())
    far = [w["frame"] for w in r["waypoints"] if not w["in_sight"]]
    assert far and all(w["station_distance_m"] > 30 for w in r["waypoints"] if w["frame"] in far)
    assert all(w["station_distance_m"] <= 30 for w in r["waypoints"] if w["frame"] not in far)
    # split for that radius: every mission keeps line of sight, written back as a plan
    split = tmp_path / "split.json"
    res = run_cli("check", str(out), "sample", "--vlos-radius", "30", "--split", "--ground-station", "-10,-32,0",
                  "--ground-station", "19,14,0", "--ground-station", "19,-32,0", "--ground-station", "-10,14,0",
                  "-o", str(split), cwd=tmp_path)
    assert res.returncode == 0, res.stdout + res.stderr
    assert len(json.loads(split.read_text())["missions"]) > len(d["missions"])


def test_check_refuses_impossible_settings(tmp_path):
    out = tmp_path / "facade.json"
    assert run_cli("plan", "facade", "sample", "-o", str(out), cwd=tmp_path).returncode == 0
    assert_clean_error(run_cli("check", str(out), "sample", "--safety-distance", "600", cwd=tmp_path), "VLOS radius")
    assert_clean_error(run_cli("check", str(out), "sample", "--aircraft", "zeppelin", cwd=tmp_path), "unknown aircraft")
    assert_clean_error(run_cli("check", str(out), "sample", "--ground-station", "1,2,3,4", cwd=tmp_path), "x,y,z")


def test_plan_options_match_the_library(tmp_path):
    from sightplan.camera.catalogue import get_camera
    from sightplan.model.load import load_model
    from sightplan.plan.checks.safety import PLACEMENT_MARGIN_M, POSITION_ERROR, placement_distance
    from sightplan.plan.templates import facade_grid, lawnmower

    scene = load_model("sample")[0]
    cam = get_camera("p4p")
    out = tmp_path / "outline.json"
    res = run_cli("plan", "facade", "sample", "--footprint", "outline", "--no-split", "-o", str(out), cwd=tmp_path)
    assert res.returncode == 0, res.stderr
    # the CLI places the grid so that it passes its checks at a GNSS drone's position error (±1.5 m, ±0.5 m)
    g, low = placement_distance(10.0, POSITION_ERROR["gnss"]), 2.0 + 0.5 + PLACEMENT_MARGIN_M
    assert len(json.loads(out.read_text())["frames"]) == len(facade_grid(scene, cam, g, 0.8, footprint="outline",
                                                                         min_height_m=low))
    res = run_cli("plan", "lawnmower", "sample", "--gsd", "0.005", "--oblique-pitch", "-60", "--no-split", "-o", str(out),
                  cwd=tmp_path)
    assert res.returncode == 0, res.stderr
    assert len(json.loads(out.read_text())["frames"]) == len(lawnmower(scene, cam, gsd_m=0.005, oblique_pitch_deg=-60))
    assert_clean_error(run_cli("plan", "facade", "sample", "--footprint", "hull", cwd=tmp_path), "--footprint")
    assert_clean_error(run_cli("plan", "bridge", "sample", "--point", "0,0", cwd=tmp_path), "axis")


def test_export_then_read_back_and_georeference_errors(tmp_path):
    import xml.etree.ElementTree as ET
    import zipfile

    import trimesh

    plan = tmp_path / "facade.json"
    assert run_cli("plan", "facade", "sample", "--safety-distance", "8", "-o", str(plan), cwd=tmp_path).returncode == 0
    d = json.loads(plan.read_text())
    # the plan's Phantom 4 Pro flies on no aircraft DJI Pilot 2 takes: refused, naming the choices
    assert_clean_error(run_cli("export", str(plan), "--format", "wpml", cwd=tmp_path), "--aircraft")
    res = run_cli("export", str(plan), "--format", "wpml", "-o", str(tmp_path / "f.kmz"), "--aircraft", "m3e",
                  cwd=tmp_path)
    assert res.returncode == 0, res.stderr
    out = " ".join(res.stdout.split())
    assert "IfcSite" in out  # placed with the Duplex's site latitude/longitude, recorded in the plan
    # the facade grid's bottom row stands 2 m above the model's base, where the take-off point is: nothing to point out
    assert "less than 2 m above the take-off point" not in out
    assert "(DJI WPML for DJI Mavic 3 Enterprise)" in out and "lowest waypoint" in out
    ns = {"kml": "http://www.opengis.net/kml/2.2", "wpml": "http://www.dji.com/wpmz/1.0.2"}
    photos = 0
    for k in range(1, len(d["missions"]) + 1):  # a .kmz per mission, each from its own ground station
        with zipfile.ZipFile(tmp_path / f"f_m{k:02d}.kmz") as z:
            root = ET.fromstring(z.read("wpmz/waylines.wpml"))
        assert len(root.findall(".//kml:Folder", ns)) == 1
        photos += len(root.findall(".//wpml:actionActuatorFunc[.='takePhoto']", ns))
    assert photos == len(d["frames"])
    res = run_cli("export", str(plan), "--format", "litchi", "-o", str(tmp_path / "f.csv"), "--mission", "1",
                  cwd=tmp_path)
    assert res.returncode == 0, res.stderr
    assert "Heading Mode = Custom" in " ".join(res.stdout.split())
    res = run_cli("export", str(plan), "--format", "qgc", "-o", str(tmp_path / "f.plan"), "--mission", "2", cwd=tmp_path)
    assert res.returncode == 0, res.stderr
    assert "(QGroundControl plan for PX4)" in " ".join(res.stdout.split())  # the default for a .plan
    assert json.loads((tmp_path / "f.plan").read_text())["mission"]["firmwareType"] == 12
    res = run_cli("export", str(plan), "--format", "wpl", "-o", str(tmp_path / "f.waypoints"), "--mission", "2",
                  "--autopilot", "px4", cwd=tmp_path)
    assert res.returncode == 0, res.stderr
    assert "(QGC WPL 110 waypoints for PX4)" in " ".join(res.stdout.split())
    assert "\t115\t" not in (tmp_path / "f.waypoints").read_text()  # PX4 refuses CONDITION_YAW
    res = run_cli("export", str(plan), "--format", "qgc", "-o", str(tmp_path / "ap.plan"), "--mission", "2",
                  "--autopilot", "ardupilot", cwd=tmp_path)
    assert res.returncode == 0, res.stderr
    assert "(QGroundControl plan for ArduPilot)" in " ".join(res.stdout.split())
    res = run_cli("export", str(plan), "--format", "qgc", "--autopilot", "apm", cwd=tmp_path)
    assert res.returncode != 0 and "Traceback" not in res.stderr and "--autopilot" in res.stderr
    m2 = d["missions"][1]
    res = run_cli("evaluate", "sample", str(tmp_path / "f.plan"), "--scale", "0.05", "--no-picture",
                  "--out", str(tmp_path / "r"), cwd=tmp_path)
    assert res.returncode == 0, res.stderr
    assert json.loads((tmp_path / "r" / "report.json").read_text())["metrics"]["frames"] == m2["frames"][1] - m2["frames"][0]
    # a mesh has no georeference: a geographic export says what to set, and --origin fixes it
    box = tmp_path / "box.obj"
    trimesh.creation.box((20.0, 10.0, 8.0)).export(box)
    res = run_cli("plan", "orbit", str(box), "--radius", "30", "--height", "10", "-o", str(tmp_path / "o.json"), cwd=tmp_path)
    assert res.returncode == 0, res.stderr
    assert_clean_error(run_cli("export", str(tmp_path / "o.json"), "--format", "kml", cwd=tmp_path), "--origin")
    res = run_cli("export", str(tmp_path / "o.json"), "--format", "kml", "--origin", "52.0,5.0,10", "--north", "15",
                  cwd=tmp_path)
    assert res.returncode == 0, res.stderr
    assert (tmp_path / "o.kml").exists()
    assert_clean_error(run_cli("export", str(plan), "--format", "litchi", "--mission", "9", cwd=tmp_path), "--mission 9")


def test_plan_routes_file_and_orbit_aim(tmp_path):
    routes = tmp_path / "walk.json"
    routes.write_text(json.dumps({"ground": [[1, -20, 0.5], [1, 3, 0.5]], "first": [[1, -20, 3.5], [1, -10, 3.5]]}))
    out = tmp_path / "walk_plan.json"
    res = run_cli("plan", "route", "sample", "--camera", "theta-z1", "--routes", str(routes), "--step", "1",
                  "-o", str(out), cwd=tmp_path)
    assert res.returncode == 0, res.stderr
    d = json.loads(out.read_text())
    assert [(m["name"], m["frames"][1] - m["frames"][0]) for m in d["missions"]] == [("ground", 24), ("first", 11)]
    res = run_cli("plan", "orbit", "sample", "--radius", "30", "--height", "5", "--aim", "surface", "-o", str(out),
                  cwd=tmp_path)
    assert res.returncode == 0, res.stderr
    assert json.loads(out.read_text())["parameters"]["aim"] == "surface"


@pytest.mark.slow
@pytest.mark.bench  # make bench; the steel structure's load and schedule stay in make test
def test_progress_over_the_schependomlaan_steel_schedule(tmp_path):
    from conftest import shared_file

    ifc = shared_file("schependomlaan", "BERNTS-Staalconstructie.ifc")
    xml = shared_file("schependomlaan", "Uitvoering Schependomlaan 18-02-2015.xml")
    rules = Path(__file__).parents[1] / "examples" / "schependomlaan_steel_rules.toml"
    orbit = tmp_path / "orbit.json"
    res = run_cli("plan", "orbit", str(ifc), "--radius", "30", "--height", "8", "--step", "30", "--no-split", "-o",
                  str(orbit), cwd=tmp_path)
    assert res.returncode == 0, res.stderr
    res = run_cli("progress", str(ifc), str(orbit), "--schedule", str(xml), "--rules", str(rules),
                  "--date", "2015-04-01", "--date", "2015-05-01", "--date", "2015-06-01", "--date", "2015-08-01",
                  "--scale", "0.25", "--feature-density", "0.2", "--out", str(tmp_path / "p"), cwd=tmp_path)
    assert res.returncode == 0, res.stdout + res.stderr
    assert "linked 965 of 965" in res.stdout
    rows = {r["date"]: r for r in csv.DictReader((tmp_path / "p" / "progress.csv").open())}
    # nothing stands before the columns; the 56 columns from 20 April; everything after the roof steel in July
    assert [rows[d]["built"] for d in ("2015-04-01", "2015-05-01", "2015-06-01", "2015-08-01")] == ["0", "56", "56", "965"]
    assert rows["2015-04-01"]["VC"] == ""
    assert rows["2015-06-01"]["same_as"] == "2015-05-01"  # no task finished in between: not cast again
    # in August more elements are seen in all, but the 900 slender roof members are mostly too small at 30 m for
    # Ω: a plan that covered the columns covers the finished structure far less
    seen_may = round(float(rows["2015-05-01"]["VC"]) / 100 * 56)
    seen_aug = round(float(rows["2015-08-01"]["VC"]) / 100 * 965)
    assert 0 < seen_may <= 56 and seen_aug > seen_may
    assert float(rows["2015-08-01"]["VC"]) < float(rows["2015-05-01"]["VC"]) / 2
    assert (tmp_path / "p" / "progress.png").stat().st_size > 10_000


def test_a_reality_model_obstructs_the_plan(tmp_path):
    import trimesh

    from sightplan.model.load import load_model

    lo, hi = load_model("sample")[0].bounds()
    # a neighbouring block 6 m east of the Duplex, 15 m tall: inside the 8 m facade grid's east side
    block = trimesh.creation.box((5, 20, 15), trimesh.transformations.translation_matrix(
        (hi[0] + 6 + 2.5, (lo[1] + hi[1]) / 2, lo[2] + 7.5)))
    block.export(tmp_path / "neighbour.ply")
    plan = tmp_path / "facade.json"
    assert run_cli("plan", "facade", "sample", "--safety-distance", "8", "-o", str(plan), cwd=tmp_path).returncode == 0
    assert run_cli("check", str(plan), "sample", "--safety-distance", "8", cwd=tmp_path).returncode == 0
    res = run_cli("check", str(plan), "sample", "--safety-distance", "8", "--reality", str(tmp_path / "neighbour.ply"),
                  "--json", str(tmp_path / "c.json"), cwd=tmp_path)
    assert res.returncode == 1 and "as occluders" in res.stdout
    missions = {m["name"]: m for m in json.loads((tmp_path / "c.json").read_text())["missions"]}
    # the east grid, 8 m out, runs into the block 6 m out; the other sides keep their distance
    assert {name: m["safety_ok"] for name, m in missions.items()} == {
        "facade south": True, "facade east": False, "facade north": True, "facade west": True}


def test_a_mission_elsewhere_on_earth_is_refused(tmp_path, monkeypatch):
    from conftest import shared_file

    survey = shared_file("plans", "qgroundcontrol_sample_with_survey.plan")  # Zurich; the Duplex stands in Chicago
    for args in (("check", str(survey), "sample"), ("evaluate", "sample", str(survey))):
        res = run_cli(*args, "--camera", "p4p", cwd=tmp_path)
        err = " ".join(res.stderr.split())
        # as the server refuses it: one error naming the first frame and how far it lies, no traceback
        assert res.returncode == 2 and "error: frame 0 (" in err and "km from the model" in err, err
        assert "farther than the 5 km" in err and "Traceback" not in err
    # the reach is a setting: with 10,000 km allowed, the same mission is checked (and fails its checks)
    monkeypatch.setenv("SIGHTPLAN_MAX_REACH_M", "1e7")
    res = run_cli("check", str(survey), "sample", "--camera", "p4p", cwd=tmp_path)
    assert res.returncode == 1 and "farther than" not in res.stderr


def test_check_takes_a_walked_route_as_a_walk(tmp_path):
    walk = tmp_path / "walk.json"
    assert run_cli("plan", "route", "sample", "--camera", "theta-z1", "--point", "-30,-40,1.5", "--point", "-30,20,1.5",
                   "--step", "2", "-o", str(walk), cwd=tmp_path).returncode == 0
    res = run_cli("check", str(walk), "sample", "--json", str(tmp_path / "c.json"), cwd=tmp_path)
    # a walk outside the house, 20 m west of it: no line of sight or altitude to keep, a walker's battery
    assert res.returncode == 0, res.stdout
    d = json.loads((tmp_path / "c.json").read_text())
    assert d["missions"][0]["line_of_sight_ok"] is None and d["missions"][0]["altitude_ok"] is None
    assert d["missions"][0]["battery_ok"] is True
    assert_clean_error(run_cli("plan", "facade", "sample", "--safety-distance", "0", cwd=tmp_path), "positive")
    assert_clean_error(run_cli("plan", "facade", "sample", "-o", str(tmp_path / "no" / "dir" / "f.json"), cwd=tmp_path),
                       "cannot write")


def test_the_installed_command_runs_in_a_process_of_its_own(tmp_path):
    """What the tests above run in this process is the same entry point `python -m sightplan` starts."""
    res = run_cli_process("plan", "facade", "sample", "--overlap", "1.0", cwd=tmp_path)
    assert_clean_error(res, "--overlap")
    assert run_cli_process("--help", cwd=tmp_path).stdout.count("optimize") >= 1
