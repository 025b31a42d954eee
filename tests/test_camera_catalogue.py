"""Camera catalogue: published specs, name matching, sensor tables, camera specs."""

from __future__ import annotations

import json
from importlib import resources
from pathlib import Path

import pytest

from sightplan.camera import (
    EquirectangularCamera,
    PinholeCamera,
    get_camera,
    list_cameras,
    lookup_sensor,
    parse_camera_spec,
)
from sightplan.errors import CameraError

SHARED_CAMERAS = Path(__file__).resolve().parents[2] / "shared" / "data" / "cameras"


def test_phantom_4_pro_focal_in_pixels():
    cam = get_camera("p4p")
    # 8.8 mm lens on a 13.2 mm wide sensor imaged over 5472 px: 8.8 / 13.2 * 5472 = 3648 px
    assert isinstance(cam, PinholeCamera)
    assert (cam.width, cam.height) == (5472, 3648)
    assert cam.fx == pytest.approx(3648.0, abs=1e-9)
    assert cam.fy == pytest.approx(3648.0, abs=1e-9)
    assert (cam.cx, cam.cy) == (2736.0, 1824.0)


@pytest.mark.parametrize("name", ["p4p", "phantom4pro", "DJI Phantom 4 Pro", "  dji phantom-4 PRO ", "FC6310", "DJI FC6310"])
def test_lookup_by_id_and_aliases(name):
    assert get_camera(name) == get_camera("p4p")


def test_zenmuse_p1_and_lens_override():
    cam = get_camera("Zenmuse P1")
    assert (cam.width, cam.height) == (8192, 5460)
    assert cam.fx == pytest.approx(35.0 / 35.9 * 8192)
    assert get_camera("p1", focal_mm=24).fx == pytest.approx(24.0 / 35.9 * 8192)


@pytest.mark.parametrize("name, size", [("Ricoh Theta Z1", (6720, 3360)), ("Insta360 X3", (5760, 2880)),
                                        ("insta360 one rs 1-inch 360", (6528, 3264)), ("GoPro MAX", (5760, 2880))])
def test_360_cameras_are_equirectangular(name, size):
    cam = get_camera(name)
    assert isinstance(cam, EquirectangularCamera)
    assert (cam.width, cam.height) == size


def test_360_camera_rejects_focal():
    with pytest.raises(CameraError, match="360"):
        get_camera("theta-z1", focal_mm=3)


def test_unknown_camera_lists_close_matches():
    with pytest.raises(CameraError, match="unknown camera 'phantom 4 prp'") as info:
        get_camera("phantom 4 prp")
    assert "did you mean" in str(info.value)
    assert "'p4p'" in str(info.value)


def test_unknown_camera_without_matches():
    with pytest.raises(CameraError, match="unknown camera 'zzzzqqqq'"):
        get_camera("zzzzqqqq")


def test_opensfm_sensor_table():
    info = lookup_sensor("DJI FC6310")
    assert info is not None and info.sensor_width_mm == 13.2
    assert lookup_sensor("dji   fc6310") == info
    assert lookup_sensor("no such camera 123") is None


def test_sensor_table_camera_needs_focal():
    with pytest.raises(CameraError, match="focal_mm"):
        get_camera("DJI FC6540")
    info = lookup_sensor("DJI FC6540")
    assert info.width and info.height  # the detailed table knows its resolution
    cam = get_camera("DJI FC6540", focal_mm=16)
    assert (cam.width, cam.height) == (info.width, info.height)
    assert cam.fx == pytest.approx(16 / info.sensor_width_mm * info.width)


def test_sensor_table_camera_without_resolution_needs_size():
    assert lookup_sensor("DJI FC300S").width is None  # only in the short table
    with pytest.raises(CameraError, match="width= and height="):
        get_camera("DJI FC300S", focal_mm=3.6)
    cam = get_camera("DJI FC300S", focal_mm=3.6, width=4000, height=3000)
    assert cam.fx == pytest.approx(3.6 / 6.16 * 4000)


def test_list_cameras_builds_every_entry():
    entries = list_cameras()
    ids = {e.id for e in entries}
    assert {"p4p", "m3e", "p1-35", "h20-wide", "one-rs-1inch", "theta-z1", "x3", "gopro-max"} <= ids
    for e in entries:
        cam = e.camera()
        assert (cam.width, cam.height) == (e.width, e.height)
        assert e.source


def test_parse_camera_spec_forms():
    assert parse_camera_spec("p4p") == get_camera("p4p")
    cam = PinholeCamera(100, 80, 90.0, 91.0, 50.0, 40.0, "c")
    assert parse_camera_spec(cam) is cam
    assert parse_camera_spec(cam.to_dict()) == cam
    assert parse_camera_spec({"model": "equirectangular", "width": 200, "height": 100}) == EquirectangularCamera(200, 100)
    s = parse_camera_spec({"sensor_width_mm": 13.2, "focal_mm": 8.8, "width": 5472, "height": 3648})
    assert s.fx == pytest.approx(3648.0)
    o = parse_camera_spec({"fx": 500, "fy": 501, "cx": 319.5, "cy": 239.5, "width": 640, "height": 480, "convention": "opencv"})
    assert (o.cx, o.cy) == (320.0, 240.0)
    p = parse_camera_spec({"fx": 500, "fy": 501, "cx": 320, "cy": 240, "width": 640, "height": 480, "convention": "sightplan"})
    assert (p.fx, p.fy, p.cx, p.cy) == (500.0, 501.0, 320.0, 240.0)
    assert parse_camera_spec({"catalogue": "p1", "focal_mm": 50}).fx == pytest.approx(50 / 35.9 * 8192)


@pytest.mark.parametrize("spec, message", [
    ({"fx": 500, "fy": 500, "cx": 320, "cy": 240, "width": 640, "height": 480}, "convention"),
    ({"focal": 3}, "matches no known form"),
    ({"sensor_width_mm": "13", "focal_mm": 8.8, "width": 100, "height": 100}, "must be a number"),
    ({"sensor_width_mm": 13.2, "focal_mm": 8.8, "width": 100.5, "height": 100}, "whole pixels"),
    (42, "name or an object"),
])
def test_parse_camera_spec_errors(spec, message):
    with pytest.raises(CameraError, match=message):
        parse_camera_spec(spec)


def test_packaged_sensor_tables_match_opensfm_copies():
    data = resources.files("sightplan").joinpath("data")
    assert "BSD" in data.joinpath("LICENSE-OpenSfM-sensors.txt").read_text(encoding="utf-8")
    if not SHARED_CAMERAS.is_dir():
        pytest.skip("shared OpenSfM sensor tables absent")
    for name in ("sensor_data.json", "sensor_data_detailed.json"):
        packaged = json.loads(data.joinpath(name).read_text(encoding="utf-8"))
        assert packaged == json.loads((SHARED_CAMERAS / name).read_text(encoding="utf-8"))
