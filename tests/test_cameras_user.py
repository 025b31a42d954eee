"""Cameras users bring: a camera JSON file, a sensor-table camera with --focal-mm, and the camera search.

The acceptance test evaluates one ring of frames four times on the bundled sample: with the
intrinsics written in the plan, and with the plan's camera replaced by the same camera given
as a JSON file in px, as a JSON file in mm, and as a sensor-table name with a focal length.
The metrics must be identical, bit for bit.
"""

from __future__ import annotations

import json
import math

import numpy as np
import pytest

from sightplan.camera import (
    EquirectangularCamera,
    PinholeCamera,
    camera_from_json,
    camera_from_option,
    get_camera,
    lookup_sensor,
    parse_camera_spec,
    read_camera_file,
    search_cameras,
)
from sightplan.camera.catalogue import list_cameras
from sightplan.cli.camera_opts import cli_camera
from sightplan.errors import CameraError
from sightplan.evaluate import EvaluationSettings, evaluate
from sightplan.model.load import load_model
from sightplan.plan import Plan
from sightplan.plan.format import write_plan
from sightplan.plan.load import load_plan
from sightplan.plan.ring import ring_plan
from test_cli import run_cli

# Sony Alpha 7R in OpenSfM's detailed table: 35.9 × 24 mm, 7389 × 4926 px; with a 35 mm lens
SONY, FOCAL_MM = "Sony Alpha 7R", 35.0
SONY_W, SONY_H, SONY_SENSOR_MM = 7389, 4926, 35.9


@pytest.fixture(scope="module")
def sample():
    scene, _ = load_model("sample")
    return scene


def _same_metrics(a, b) -> None:
    assert a.metrics.plan.to_dict() == b.metrics.plan.to_dict()
    for part in ("elements", "frames"):
        ma, mb = getattr(a.metrics, part), getattr(b.metrics, part)
        for name in ma.__dataclass_fields__:
            np.testing.assert_array_equal(getattr(ma, name), getattr(mb, name), err_msg=f"{part}.{name}")


def test_camera_file_and_sensor_table_evaluate_like_the_plan_intrinsics(sample, tmp_path):
    fx = FOCAL_MM / SONY_SENSOR_MM * SONY_W
    in_plan = PinholeCamera(SONY_W, SONY_H, fx, fx, SONY_W / 2, SONY_H / 2, "A7R in the plan")
    ring = ring_plan(sample, in_plan, n_frames=8, distance_m=15.0)
    write_plan(ring, tmp_path / "intrinsics.json")
    # the same poses with another camera: --camera must replace it
    write_plan(Plan.build(get_camera("p4p"), ring.R_world_camera, ring.C_world), tmp_path / "p4p.json")
    (tmp_path / "a7r_px.json").write_text(json.dumps(
        {"model": "pinhole", "name": "A7R file", "width": SONY_W, "height": SONY_H, "fx": fx, "fy": fx,
         "cx": SONY_W / 2, "cy": SONY_H / 2}))
    (tmp_path / "a7r_mm.json").write_text(json.dumps(
        {"model": "pinhole", "width": SONY_W, "height": SONY_H, "sensor_width_mm": SONY_SENSOR_MM,
         "focal_mm": FOCAL_MM}))

    given = {
        "file in px": cli_camera(str(tmp_path / "a7r_px.json")),
        "file in mm": cli_camera(str(tmp_path / "a7r_mm.json")),
        "sensor table": cli_camera(SONY, FOCAL_MM),
    }
    for label, cam in given.items():
        assert isinstance(cam, PinholeCamera), label
        assert (cam.width, cam.height, cam.fx, cam.fy, cam.cx, cam.cy) == (SONY_W, SONY_H, fx, fx, SONY_W / 2,
                                                                           SONY_H / 2), label
    assert given["file in mm"].name == "a7r_mm"  # a file without a name is named after itself

    settings = EvaluationSettings(engine="embree", scale=0.1)
    reference = evaluate(sample, load_plan(tmp_path / "intrinsics.json"), settings, cache_dir=False)
    assert reference.metrics.plan.n_visible > 0
    for label, cam in given.items():
        plan = load_plan(tmp_path / "p4p.json", camera=cam)
        assert plan.camera_of(0) == cam, label
        _same_metrics(evaluate(sample, plan, settings, cache_dir=False), reference)


def test_cli_evaluate_takes_a_sensor_table_camera_with_focal_mm(tmp_path):
    res = run_cli("evaluate", "sample", "--camera", SONY, "--focal-mm", "35", "--ring-frames", "3", "--scale", "0.02",
                  "--engine", "embree", "--no-picture", "--save-plan", "ring.json", "--out", "out", cwd=tmp_path)
    assert res.returncode == 0, res.stderr
    (cam,) = json.loads((tmp_path / "ring.json").read_text())["cameras"].values()
    assert cam["fx"] == FOCAL_MM / SONY_SENSOR_MM * SONY_W and (cam["width"], cam["height"]) == (SONY_W, SONY_H)

    res = run_cli("evaluate", "sample", "--camera", SONY, "--ring-frames", "3", cwd=tmp_path)
    assert res.returncode == 2 and "Traceback" not in res.stderr
    assert res.stderr.startswith("error:") and "--focal-mm" in res.stderr


def test_cli_cameras_searches_the_sensor_tables(tmp_path):
    res = run_cli("cameras", "sony", cwd=tmp_path)
    assert res.returncode == 0, res.stderr
    out = res.stdout
    assert out.lower().count("sony") >= 20
    assert "Canon" not in out and "Nikon" not in out
    assert "--focal-mm" in out

    res = run_cli("cameras", "7R SONY", cwd=tmp_path)  # words in any order and case
    assert res.returncode == 0, res.stderr
    line = next(x for x in res.stdout.splitlines() if SONY in x)
    assert "35.9 × 24" in line and f"{SONY_W}×{SONY_H}" in line and "--focal-mm" in line

    res = run_cli("cameras", "zzqq nothing", cwd=tmp_path)
    assert res.returncode == 2 and res.stderr.startswith("error:") and "no camera matches" in res.stderr


def test_search_cameras():
    found = search_cameras("sony 7r")
    keys = [m.key for m in found]
    assert SONY in keys and all("7r" in k.lower().replace(" ", "") for k in keys)
    a7r = next(m for m in found if m.key == SONY)
    assert (a7r.source, a7r.sensor_width_mm, a7r.sensor_height_mm, a7r.width, a7r.height) == (
        "sensor table", SONY_SENSOR_MM, 24.0, SONY_W, SONY_H)
    assert a7r.needs == "--focal-mm"
    assert SONY in [m.key for m in search_cameras("SONY a7r")]  # Sony's own short name
    assert [m.key for m in search_cameras("phantom 4")] == ["p4p"]  # the catalogue covers its sensor-table rows
    everything = search_cameras("")  # no words: the whole catalogue, in its order, and no sensor-table row
    assert [m.key for m in everything] == [e.id for e in list_cameras()] and len(everything) >= 5
    assert {m.source for m in everything} == {"catalogue"}
    short = next(m for m in search_cameras("dji fc300s") if m.source == "sensor table")
    assert short.width is None and "image size" in short.needs  # only the short table knows it


def test_sensor_table_camera_needs_focal_mm_and_accepts_it():
    with pytest.raises(CameraError, match="--focal-mm"):
        camera_from_option(SONY)
    info = lookup_sensor(SONY)
    cam = camera_from_option("sony  alpha-7r", 50)
    assert cam.fx == pytest.approx(50 / info.sensor_width_mm * info.width)
    assert camera_from_option("p1", 24) == get_camera("p1", focal_mm=24)  # replaces a catalogue lens
    for bad in (0.0, -3.0, math.nan):
        with pytest.raises(CameraError, match="positive number of millimetres"):
            camera_from_option(SONY, bad)
    with pytest.raises(CameraError, match=r"Sony Alpha 7R with 1e\+06 mm: impossible camera: a field of view of"):
        camera_from_option(SONY, 1e6)
    with pytest.raises(CameraError, match="--focal-mm needs --camera"):
        cli_camera(None, 35.0)
    assert cli_camera(None) is None


def test_camera_file_forms(tmp_path):
    path = tmp_path / "pano.json"
    path.write_text(json.dumps({"model": "equirectangular", "width": 4000, "height": 2000, "name": "pano"}))
    assert read_camera_file(path) == EquirectangularCamera(4000, 2000, "pano")
    assert parse_camera_spec(str(path)) == read_camera_file(path)  # load_plan(camera="pano.json") too
    cv = camera_from_json({"model": "pinhole", "width": 640, "height": 480, "fx": 500, "fy": 500, "cx": 319.5,
                           "cy": 239.5, "convention": "opencv"})
    assert (cv.cx, cv.cy) == (320.0, 240.0)
    tall = camera_from_json({"model": "pinhole", "width": 600, "height": 400, "sensor_width_mm": 6.0,
                             "sensor_height_mm": 4.0, "focal_mm": 5.0})
    assert tall.fx == pytest.approx(500.0) and tall.fy == pytest.approx(500.0)
    assert camera_from_json({"catalogue": "p1", "focal_mm": 24}) == get_camera("p1", focal_mm=24)
    with pytest.raises(CameraError, match="not a camera file"):
        camera_from_option(str(path), 35.0)
    with pytest.raises(CameraError, match="no camera file"):
        camera_from_option(str(tmp_path / "missing.json"))
    (tmp_path / "broken.json").write_text("{fx: 3")
    with pytest.raises(CameraError, match="broken.json is not a JSON camera"):
        read_camera_file(tmp_path / "broken.json")


PINHOLE = {"model": "pinhole", "width": 640, "height": 480, "fx": 500.0, "fy": 500.0, "cx": 320.0, "cy": 240.0}


@pytest.mark.parametrize("change, message", [
    ({"width": 0}, "width must be positive"),
    ({"height": -480}, "height must be positive"),
    ({"width": 640.5}, "whole number of pixels"),
    ({"width": "640"}, "width must be a number"),
    ({"fx": float("nan")}, "fx is nan, not a finite number"),
    ({"fy": float("inf")}, "fy is inf, not a finite number"),
    ({"fx": -500.0}, "fx must be positive"),
    ({"cx": 700.0}, r"principal point \(cx, cy\) = \(700, 240\) px lies outside the 640 × 480 px image"),
    ({"cy": -1.0}, "principal point"),
    ({"fx": 5.0, "fy": 5.0}, "field of view over 170°"),
    ({"fx": 1e7, "fy": 1e7}, "field of view of"),
    ({"fy": 5000.0}, r"fy / fx = 10"),
    ({"focal": 3}, "has no field"),
    ({"fx": None}, "fx must be a number"),
    ({"model": "fisheye"}, "unknown camera model 'fisheye'"),
])
def test_impossible_camera_gets_one_clear_error(change, message):
    spec = {**PINHOLE, **change}
    with pytest.raises(CameraError, match=message) as info:
        camera_from_json(spec, "cam.json")
    assert str(info.value).startswith("cam.json: ")
    assert "\n" not in str(info.value)


@pytest.mark.parametrize("spec, message", [
    ({"model": "equirectangular", "width": 4000, "height": 1000}, "twice as wide"),
    ({"model": "pinhole", "width": 640, "height": 480, "sensor_width_mm": 0, "focal_mm": 8}, "sensor_width_mm must be"),
    ({"model": "pinhole", "width": 640, "height": 480, "focal_mm": 8}, "needs sensor_width_mm and focal_mm"),
    ({"model": "pinhole", "width": 640, "height": 480, "fx": 500}, r"missing cx, cy, fy"),
    ({"model": "pinhole", "width": 640, "height": 480, "fx": 500, "fy": 500, "cx": 1, "cy": 1, "focal_mm": 8,
      "sensor_width_mm": 6}, "not both"),
    ({"model": "pinhole", "height": 480, "fx": 500, "fy": 500, "cx": 1, "cy": 1}, "needs 'width'"),
    ([1, 2], "JSON object"),
])
def test_impossible_camera_forms(spec, message):
    with pytest.raises(CameraError, match=message):
        camera_from_json(spec, "cam.json")
