"""Imports of flown captures: CSV, COLMAP (text and binary, classic and 3.12 rigs/frames), OpenSfM; load_plan
dispatch; DJI area templates."""

from __future__ import annotations

import json
import zipfile
from pathlib import Path

import numpy as np
import pytest
from scipy.spatial.transform import Rotation

from sightplan.camera import EquirectangularCamera, PinholeCamera, get_camera
from sightplan.errors import PlanError
from sightplan.formats.colmap import read_colmap
from sightplan.formats.csv import read_csv_plan
from sightplan.formats.opensfm import read_opensfm
from sightplan.plan.load import apply_similarity, detect_format, load_plan

EXAMPLE = Path(__file__).resolve().parents[2] / "shared" / "data" / "poses" / "reconstruction_example.json"


# -- CSV ---------------------------------------------------------------------------------------


def test_csv_gimbal_angles_camera_column_and_time(tmp_path):
    path = tmp_path / "poses.csv"
    path.write_text(
        "name,x,y,z,yaw,pitch,roll,camera,time\n"
        "a.jpg,1,2,30,90,0,0,p4p,2024-05-01T10:00:00\n"
        "b.jpg,4,5,30,0,-90,0,,1714557601.5\n"
        "\n"
        "c.jpg,-1,0,2,180,0,0,Ricoh Theta Z1,\n"
    )
    plan = read_csv_plan(path, camera="m3e")
    assert plan.frame_names.tolist() == ["a.jpg", "b.jpg", "c.jpg"]
    np.testing.assert_array_equal(plan.C_world, [[1, 2, 30], [4, 5, 30], [-1, 0, 2]])
    np.testing.assert_allclose(plan.R_world_camera[:, :, 2], [[1, 0, 0], [0, 0, -1], [0, -1, 0]], atol=1e-12)
    assert plan.cameras["p4p"] == get_camera("p4p")
    assert plan.camera_of(1) == get_camera("m3e")  # empty cell: the caller's camera
    assert isinstance(plan.camera_of(2), EquirectangularCamera)
    assert plan.capture_time[0] == 1714557600.0  # 2024-05-01T10:00:00 UTC
    assert plan.capture_time[1] == 1714557601.5
    assert np.isnan(plan.capture_time[2])


def test_csv_quaternions_semicolons_and_default_camera(tmp_path):
    path = tmp_path / "poses.csv"
    q = Rotation.from_euler("xyz", [10, -20, 30], degrees=True)
    x, y, z, w = q.as_quat().tolist()
    path.write_text(f"Name;X;Y;Z;qw;qx;qy;qz\nimg1;0;0;1;{w!r};{x!r};{y!r};{z!r}\n")
    cam = PinholeCamera(640, 480, 500.0, 500.0, 320.0, 240.0, "cal")
    plan = read_csv_plan(path, camera=cam)
    np.testing.assert_allclose(plan.R_world_camera[0], q.as_matrix(), atol=1e-12)
    assert plan.cameras == {"cal": cam}


@pytest.mark.parametrize("text, message", [
    ("name,x,y,z,heading_deg,pitch_deg\na,1,2,3,0,0\nb,1,oops,3,0,0\n", r"poses.csv, line 3, column 'y': 'oops' is not a number"),
    ("name,x,y,heading_deg,pitch_deg\na,1,2,0,0\n", "missing column"),
    ("name,x,y,z,heading_deg\na,1,2,3,0\n", "incomplete orientation"),
    ("name,x,y,z\na,1,2,3\n", "no orientation columns"),
    ("name,x,y,z,heading_deg,pitch_deg,qw,qx,qy,qz\na,1,2,3,0,0,1,0,0,0\n", "not both"),
    ("name,x,y,z,qw,qx,qy,qz\na,1,2,3,1,0,0,0\nb,1,2,3,2,0,0,0\n", r"line 3: quaternion .* is not a unit quaternion"),
    ("name,x,y,z,heading_deg,pitch_deg,camera\na,1,2,3,0,0,phantom 4 prp\n", r"line 2, column 'camera': unknown camera .*p4p"),
    ("name,x,y,z,heading_deg,pitch_deg\na,1,2,nan,0,0\n", "line 2: position or orientation is not finite"),
    ("name,x,y,z,heading_deg,pitch_deg,time\na,1,2,3,0,0,yesterday\n", "line 2: time 'yesterday'"),
    ("name,x,y,z,heading_deg,pitch_deg\n", "no frames"),
])
def test_csv_errors_name_line_and_column(tmp_path, text, message):
    path = tmp_path / "poses.csv"
    path.write_text(text)
    with pytest.raises(PlanError, match=message):
        read_csv_plan(path, camera="p4p")


def test_csv_without_any_camera(tmp_path):
    path = tmp_path / "poses.csv"
    path.write_text("name,x,y,z,heading_deg,pitch_deg\na,1,2,3,0,0\n")
    with pytest.raises(PlanError, match="line 2: no camera"):
        read_csv_plan(path)


# -- COLMAP ------------------------------------------------------------------------------------


def _known_poses(n: int = 4):
    """(n, 3, 3) R_world_camera and (n, 3) centres, names out of natural order, shuffled ids."""
    R = Rotation.random(n, random_state=11).as_matrix()
    C = np.random.default_rng(5).uniform(-20, 20, size=(n, 3))
    names = [f"img_{k}.jpg" for k in (10, 2, 1, 33)][:n]
    ids = [7, 3, 12, 1][:n]
    return R, C, names, ids


def _colmap_cameras():
    # (id, model, width, height, params)
    return [(1, "PINHOLE", 640, 480, [500.0, 510.0, 320.5, 240.25]),
            (2, "SIMPLE_RADIAL", 800, 600, [700.0, 400.0, 300.0, 0.01]),
            (5, "OPENCV", 1000, 750, [900.0, 901.0, 501.0, 374.0, 0.1, -0.01, 0.001, 0.0])]


def _check_colmap_plan(plan, R, C, names):
    order = np.argsort([int(n[4:-4]) for n in names])  # natural name order: img_1, img_2, img_10, img_33
    assert plan.frame_names.tolist() == [names[i] for i in order]
    np.testing.assert_allclose(plan.C_world, C[order], atol=1e-9)
    np.testing.assert_allclose(plan.R_world_camera, R[order], atol=1e-12)
    cams = plan.cameras
    assert (cams["1"].fx, cams["1"].fy, cams["1"].cx, cams["1"].cy) == (500.0, 510.0, 320.5, 240.25)  # no ½-px shift
    assert (cams["2"].fx, cams["2"].fy, cams["2"].cx, cams["2"].cy) == (700.0, 700.0, 400.0, 300.0)
    assert (cams["5"].width, cams["5"].height, cams["5"].fx, cams["5"].fy) == (1000, 750, 900.0, 901.0)
    warnings = plan.parameters["warnings"]
    assert any("SIMPLE_RADIAL" in w and "distortion" in w for w in warnings)
    assert any("OPENCV" in w and "distortion" in w for w in warnings)
    assert not any("PINHOLE)" in w for w in warnings)


@pytest.mark.parametrize("binary", [False, True])
def test_colmap_written_by_pycolmap(tmp_path, binary):
    pycolmap = pytest.importorskip("pycolmap")
    R, C, names, ids = _known_poses()
    rec = pycolmap.Reconstruction()
    for cid, model, w, h, params in _colmap_cameras():
        rec.add_camera_with_trivial_rig(pycolmap.Camera(model=model, width=w, height=h, params=params, camera_id=cid))
    for k, (name, iid) in enumerate(zip(names, ids)):
        R_cw = R[k].T
        pose = pycolmap.Rigid3d(pycolmap.Rotation3d(Rotation.from_matrix(R_cw).as_quat()), -R_cw @ C[k])
        rec.add_image_with_trivial_frame(pycolmap.Image(name=name, camera_id=[1, 2, 5, 1][k], image_id=iid), pose)
    out = tmp_path / "sparse" / "0"
    out.mkdir(parents=True)
    (rec.write_binary if binary else rec.write_text)(str(out))
    plan = load_plan(tmp_path)  # finds sparse/0
    _check_colmap_plan(plan, R, C, names)
    assert plan.frame_camera.tolist() == ["5", "2", "1", "1"]  # img_1, img_2, img_10, img_33
    by_id = read_colmap(out, order="id")
    assert by_id.frame_names.tolist() == ["img_33.jpg", "img_2.jpg", "img_10.jpg", "img_1.jpg"]


def _write_colmap_text_by_hand(folder: Path, R, C, names, ids):
    folder.mkdir(parents=True, exist_ok=True)
    lines = ["# Camera list with one line of data per camera:"]
    lines += [f"{cid} {model} {w} {h} " + " ".join(map(repr, params)) for cid, model, w, h, params in _colmap_cameras()]
    (folder / "cameras.txt").write_text("\n".join(lines) + "\n")
    lines = ["# Image list with two lines of data per image:", "# Number of images: 4"]
    for k, (name, iid) in enumerate(zip(names, ids)):
        R_cw = R[k].T
        x, y, z, w = Rotation.from_matrix(R_cw).as_quat()
        t = -R_cw @ C[k]
        cid = [1, 2, 5, 1][k]
        lines.append(" ".join(map(repr, [iid, *map(float, (w, x, y, z)), *t.tolist(), cid])) + f" {name}")
        lines.append("" if k % 2 else "10.5 20.5 -1 30.5 40.5 17")  # POINTS2D line, empty or not
    (folder / "images.txt").write_text("\n".join(lines) + "\n")


def test_colmap_text_written_by_hand(tmp_path):
    R, C, names, ids = _known_poses()
    _write_colmap_text_by_hand(tmp_path, R, C, names, ids)
    _check_colmap_plan(load_plan(tmp_path / "images.txt"), R, C, names)


def test_colmap_equirectangular_camera(tmp_path):
    (tmp_path / "cameras.txt").write_text("1 EQUIRECTANGULAR 2000 1000 2000 1000\n")
    (tmp_path / "images.txt").write_text("1 1 0 0 0 0 0 0 1 pano.jpg\n\n")
    plan = read_colmap(tmp_path)
    assert plan.cameras["1"] == EquirectangularCamera(2000, 1000, "COLMAP camera 1 (EQUIRECTANGULAR)")


@pytest.mark.parametrize("cameras, images, message", [
    ("1 PINHOLE 640 480 500 500 320\n", "1 1 0 0 0 0 0 0 1 a.jpg\n\n", r"has 3 parameters, expected 4"),
    ("1 PINHOLE 640 480 500 500 320 240\n", "1 1 0 0 0 0 0 0 9 a.jpg\n\n", r"camera\(s\) \[9\]"),
    ("1 PINHOLE 640 480 500 500 320 240\n", "1 1 0 0 0 0 0\n\n", r"images.txt, line 1: expected IMAGE_ID"),
    ("1 PINHOLE 640 480 500 500 320 240\n", "1 2 0 0 0 0 0 0 1 a.jpg\n\n", r"COLMAP image 'a.jpg': quaternion"),
    ("1 WEIRD 640 480 1\n", "1 1 0 0 0 0 0 0 1 a.jpg\n\n", "unknown model 'WEIRD'"),
])
def test_colmap_errors(tmp_path, cameras, images, message):
    (tmp_path / "cameras.txt").write_text(cameras)
    (tmp_path / "images.txt").write_text(images)
    with pytest.raises(PlanError, match=message):
        read_colmap(tmp_path)


def test_colmap_missing_and_truncated(tmp_path):
    with pytest.raises(PlanError, match="no COLMAP model"):
        load_plan(tmp_path)
    (tmp_path / "cameras.bin").write_bytes(b"\x01\x00")
    (tmp_path / "images.bin").write_bytes(b"")
    with pytest.raises(PlanError, match="truncated"):
        read_colmap(tmp_path)


def test_similarity_transform():
    R, C, names, ids = _known_poses()
    cam = PinholeCamera(640, 480, 500.0, 500.0, 320.0, 240.0, "c")
    from sightplan.plan import Plan

    plan = Plan.build(cam, R, C, parameters={"georeference": {"x": 1}})
    R_s = Rotation.from_euler("z", 90, degrees=True).as_matrix()
    T = np.eye(4)
    T[:3, :3], T[:3, 3] = 2.0 * R_s, [10.0, -5.0, 1.0]
    moved = apply_similarity(plan, T)
    np.testing.assert_allclose(moved.C_world, 2.0 * C @ R_s.T + [10.0, -5.0, 1.0], atol=1e-12)
    np.testing.assert_allclose(moved.R_world_camera, R_s @ R, atol=1e-12)
    assert moved.parameters["transform"]["scale"] == pytest.approx(2.0)
    assert "source_georeference" in moved.parameters and "georeference" not in moved.parameters
    shear = np.eye(4)
    shear[0, 1] = 0.5
    with pytest.raises(PlanError, match="not a uniform scale"):
        apply_similarity(plan, shear)
    with pytest.raises(PlanError, match="reflection"):
        apply_similarity(plan, np.diag([-1.0, 1, 1, 1]))


def test_load_plan_with_transform_on_colmap(tmp_path):
    R, C, names, ids = _known_poses()
    _write_colmap_text_by_hand(tmp_path, R, C, names, ids)
    T = np.eye(4)
    T[:3, 3] = [1.0, 2.0, 3.0]
    plan = load_plan(tmp_path, transform=T)
    np.testing.assert_allclose(plan.C_world, load_plan(tmp_path).C_world + [1.0, 2.0, 3.0], atol=1e-12)
    np.testing.assert_allclose(plan.R_world_camera, load_plan(tmp_path).R_world_camera, atol=1e-15)


# -- OpenSfM -----------------------------------------------------------------------------------


@pytest.mark.skipif(not EXAMPLE.is_file(), reason="shared OpenSfM example absent")
def test_opensfm_real_example():
    plan = load_plan(EXAMPLE)
    assert len(plan) == 3
    assert np.isfinite(plan.C_world).all()
    assert plan.frame_names.tolist() == ["01.jpg", "02.jpg", "03.jpg"]  # by capture_time
    assert np.all(np.diff(plan.capture_time) > 0)
    shot = json.loads(EXAMPLE.read_text())[0]["shots"]["02.jpg"]
    R_cw = Rotation.from_rotvec(shot["rotation"]).as_matrix()
    np.testing.assert_allclose(plan.C_world[1], -R_cw.T @ np.array(shot["translation"]), atol=1e-12)
    np.testing.assert_allclose(plan.R_world_camera[1], R_cw.T, atol=1e-12)
    georef = plan.parameters["georeference"]
    assert georef["reference_lla"]["latitude"] == pytest.approx(52.51896296296295)
    assert "ENU" in georef["frame"]
    cam = plan.camera_of(0)
    assert (cam.width, cam.height) == (3264, 2448)
    assert cam.fx == pytest.approx(0.8696658484855359 * 3264)
    assert any("distortion" in w for w in plan.parameters["warnings"])


def _synthetic_opensfm(tmp_path) -> Path:
    recs = [{
        "cameras": {
            "pano": {"projection_type": "spherical", "width": 4000, "height": 2000},
            "brown": {"projection_type": "brown", "width": 400, "height": 300, "focal_x": 0.9, "focal_y": 0.91,
                      "c_x": 0.01, "c_y": -0.02, "k1": 0.0, "k2": 0.0, "k3": 0.0, "p1": 0.0, "p2": 0.0},
        },
        "shots": {
            "b.jpg": {"camera": "pano", "rotation": [0.1, 0.2, 0.3], "translation": [1.0, 2.0, 3.0], "capture_time": 20.0},
            "a.jpg": {"camera": "brown", "rotation": [0.0, 0.0, 0.0], "translation": [0.0, 0.0, -5.0], "capture_time": 10.0},
            "c.jpg": {"camera": "pano", "rotation": [0.0, 0.5, 0.0], "translation": [0.0, 0.0, 0.0]},
        },
    }, {"cameras": {}, "shots": {"z.jpg": {}}}]
    path = tmp_path / "reconstruction.json"
    path.write_text(json.dumps(recs))
    return path


def test_opensfm_synthetic_spherical_and_brown(tmp_path):
    plan = load_plan(_synthetic_opensfm(tmp_path))
    assert plan.frame_names.tolist() == ["a.jpg", "b.jpg", "c.jpg"]  # by capture_time, untimed last
    assert isinstance(plan.cameras["pano"], EquirectangularCamera)
    assert (plan.cameras["pano"].width, plan.cameras["pano"].height) == (4000, 2000)
    brown = plan.cameras["brown"]
    assert (brown.fx, brown.fy) == pytest.approx((0.9 * 400, 0.91 * 400))
    assert (brown.cx, brown.cy) == pytest.approx((200 + 0.01 * 400, 150 - 0.02 * 400))
    np.testing.assert_allclose(plan.C_world[0], [0, 0, 5], atol=1e-12)
    R_cw = Rotation.from_rotvec([0.1, 0.2, 0.3]).as_matrix()
    np.testing.assert_allclose(plan.C_world[1], -R_cw.T @ [1.0, 2.0, 3.0], atol=1e-12)
    assert "georeference" not in plan.parameters
    assert any("other reconstruction" in w for w in plan.parameters["warnings"])
    assert not any("distortion" in w for w in plan.parameters["warnings"])  # all coefficients zero


def test_opensfm_errors(tmp_path):
    path = tmp_path / "r.json"
    path.write_text(json.dumps([{"cameras": {"c": {"projection_type": "perspective", "width": 10, "height": 10,
                                                   "focal": 1.0}},
                                 "shots": {"s": {"camera": "c", "rotation": [0, 0], "translation": [0, 0, 0]}}}]))
    with pytest.raises(PlanError, match="shot 's': field 'rotation' must be 3 numbers"):
        read_opensfm(path)
    path.write_text(json.dumps([{"cameras": {}, "shots": {"s": {"camera": "c"}}}]))
    with pytest.raises(PlanError, match=r"camera\(s\) \['c'\]"):
        read_opensfm(path)
    with pytest.raises(PlanError, match="reconstruction 3 asked for"):
        read_opensfm(path, reconstruction=3)


# -- load_plan dispatch ------------------------------------------------------------------------


def test_load_plan_dispatch_and_errors(tmp_path):
    other = tmp_path / "other.json"
    other.write_text(json.dumps({"hello": 1}))
    with pytest.raises(PlanError, match="neither a sightplan plan"):
        load_plan(other)
    with pytest.raises(PlanError, match="unknown plan format 'kml'"):
        load_plan(other, fmt="kml")
    with pytest.raises(PlanError, match="no such file"):
        load_plan(tmp_path / "missing.csv")
    weird = tmp_path / "plan.xyz"
    weird.write_text("")
    with pytest.raises(PlanError, match="cannot tell the format"):
        load_plan(weird)


def test_load_plan_camera_override(tmp_path):
    plan = load_plan(_synthetic_opensfm(tmp_path), camera="p4p")
    assert set(plan.cameras) == {"DJI Phantom 4 Pro (FC6310)"}
    assert any("replaces the file's camera" in w for w in plan.parameters["warnings"])


def _write_colmap_binary_by_hand(folder: Path, R, C, names, ids):
    """cameras.bin / images.bin following COLMAP's documented little-endian layout."""
    import struct

    model_ids = {"PINHOLE": 1, "SIMPLE_RADIAL": 2, "OPENCV": 4}
    cams = _colmap_cameras()
    blob = struct.pack("<Q", len(cams))
    for cid, model, w, h, params in cams:
        blob += struct.pack(f"<IiQQ{len(params)}d", cid, model_ids[model], w, h, *params)
    (folder / "cameras.bin").write_bytes(blob)
    blob = struct.pack("<Q", len(names))
    for k, (name, iid) in enumerate(zip(names, ids)):
        R_cw = R[k].T
        x, y, z, w = Rotation.from_matrix(R_cw).as_quat().tolist()
        blob += struct.pack("<I7dI", iid, w, x, y, z, *(-R_cw @ C[k]).tolist(), [1, 2, 5, 1][k])
        blob += name.encode() + b"\0" + struct.pack("<Q", 2) + struct.pack("<ddqddq", 1.5, 2.5, -1, 3.5, 4.5, 9)
    (folder / "images.bin").write_bytes(blob)


def test_colmap_binary_written_by_hand(tmp_path):
    R, C, names, ids = _known_poses()
    _write_colmap_binary_by_hand(tmp_path, R, C, names, ids)
    _write_colmap_text_by_hand(tmp_path / "text", R, C, names, ids)
    _check_colmap_plan(load_plan(tmp_path / "images.bin"), R, C, names)
    text = load_plan(tmp_path / "text")
    assert np.array_equal(load_plan(tmp_path).C_world, text.C_world)  # repr() text is lossless


def test_csv_with_times_out_of_order_is_sorted_by_capture_time(tmp_path):
    from sightplan.plan.load import load_plan

    csv = tmp_path / "poses.csv"
    csv.write_text("name,x,y,z,heading_deg,pitch_deg,time\n"
                   "b,1,0,10,0,-90,2024-05-01T10:00:05\n"
                   "a,0,0,10,0,-90,2024-05-01T10:00:00\n"
                   "c,2,0,10,0,-90,2024-05-01T10:00:09\n")
    plan = load_plan(csv, camera="p4p")
    assert list(plan.frame_names) == ["a", "b", "c"]
    np.testing.assert_allclose(plan.C_world[:, 0], [0, 1, 2])
    assert any("capture-time order" in w for w in plan.parameters["warnings"])



# -- COLMAP 3.12: rigs and frames --------------------------------------------------------------


def _rig_reconstruction(pycolmap, n_frames: int = 3):
    """A two-camera rig in n frames, written as COLMAP ≥ 3.12 does, and each image's expected
    (R_world_camera, C) worked out here from the rig and frame poses."""
    rec = pycolmap.Reconstruction()
    cams = [pycolmap.Camera(model="PINHOLE", width=640, height=480, params=[500.0, 510.0, 320.0, 240.0], camera_id=1),
            pycolmap.Camera(model="SIMPLE_PINHOLE", width=800, height=600, params=[600.0, 400.0, 300.0], camera_id=2)]
    for cam in cams:
        rec.add_camera(cam)
    # the second camera: 0.2 m to the right of the first, turned 30° about its y axis
    R_sr = Rotation.from_euler("y", 30, degrees=True).as_matrix()
    t_sr = np.array([-0.2, 0.0, 0.05])
    rig = pycolmap.Rig(rig_id=1)
    rig.add_ref_sensor(cams[0].sensor_id)
    rig.add_sensor(cams[1].sensor_id, pycolmap.Rigid3d(pycolmap.Rotation3d(Rotation.from_matrix(R_sr).as_quat()), t_sr))
    rec.add_rig(rig)
    R_wr = Rotation.random(n_frames, random_state=7).as_matrix()
    C_r = np.random.default_rng(2).uniform(-10, 10, size=(n_frames, 3))
    expected = {}
    for f in range(n_frames):
        R_rw, fid = R_wr[f].T, f + 1
        t_rw = -R_rw @ C_r[f]
        frame = pycolmap.Frame(frame_id=fid, rig_id=1)
        frame.rig_from_world = pycolmap.Rigid3d(pycolmap.Rotation3d(Rotation.from_matrix(R_rw).as_quat()), t_rw)
        images = []
        for k, cam in enumerate(cams):
            image = pycolmap.Image(name=f"cam{cam.camera_id}/img_{f}.jpg", camera_id=cam.camera_id,
                                   image_id=10 * fid + k, frame_id=fid)
            frame.add_data_id(image.data_id)
            images.append(image)
            R_cw, t_cw = (R_rw, t_rw) if k == 0 else (R_sr @ R_rw, R_sr @ t_rw + t_sr)
            expected[image.name] = (R_cw.T, -R_cw.T @ t_cw, str(cam.camera_id), fid)
        rec.add_frame(frame)
        for image in images:
            rec.add_image(image)
        rec.register_frame(fid)
    return rec, expected


@pytest.mark.parametrize("binary", [False, True])
def test_colmap_312_rig_and_frames_written_by_pycolmap(tmp_path, binary):
    pycolmap = pytest.importorskip("pycolmap")
    rec, expected = _rig_reconstruction(pycolmap)
    out = tmp_path / "sparse" / "0"
    out.mkdir(parents=True)
    (rec.write_binary if binary else rec.write_text)(str(out))
    ext = ".bin" if binary else ".txt"
    assert {f"{p}{ext}" for p in ("cameras", "images", "rigs", "frames")} <= {f.name for f in out.iterdir()}
    plan = load_plan(tmp_path)
    assert sorted(plan.frame_names.tolist()) == sorted(expected)  # every image of every frame
    for i, name in enumerate(plan.frame_names):
        R_wc, C, cid, _ = expected[name]
        np.testing.assert_allclose(plan.R_world_camera[i], R_wc, atol=1e-12)
        np.testing.assert_allclose(plan.C_world[i], C, atol=1e-9)
        assert plan.frame_camera[i] == cid
        # pycolmap's own pose of the image agrees
        image = rec.find_image_with_name(name)
        np.testing.assert_allclose(plan.C_world[i], image.projection_center(), atol=1e-9)
    source = plan.parameters["source"]
    assert (source["rigs"], source["frames"]) == (1, 3) and "3.12" in source["layout"]
    assert plan.parameters["colmap_frames"] == {name: e[3] for name, e in expected.items()}
    assert plan.parameters["warnings"] == []


def test_colmap_312_frames_are_checked(tmp_path):
    pycolmap = pytest.importorskip("pycolmap")
    rec, expected = _rig_reconstruction(pycolmap, n_frames=2)
    rec.write_text(str(tmp_path))
    frames = (tmp_path / "frames.txt").read_text().splitlines()
    data = [i for i, line in enumerate(frames) if line and not line.startswith("#")]
    # move the first frame by 1 m: its images' own poses (images.txt) no longer agree with it
    parts = frames[data[0]].split()
    parts[6] = repr(float(parts[6]) + 1.0)
    frames[data[0]] = " ".join(parts)
    (tmp_path / "frames.txt").write_text("\n".join(frames) + "\n")
    plan = load_plan(tmp_path)
    assert len(plan) == len(expected)
    (warning,) = plan.parameters["warnings"]
    assert "2 COLMAP image(s) have a pose in images.txt that differs" in warning and "1 m" in warning
    # a frame of an unknown rig
    parts[1] = "9"
    frames[data[0]] = " ".join(parts)
    (tmp_path / "frames.txt").write_text("\n".join(frames) + "\n")
    with pytest.raises(PlanError, match=r"COLMAP frame \d+ \(frames.txt\) belongs to rig 9, which rigs.txt lacks"):
        load_plan(tmp_path)
    (tmp_path / "frames.txt").write_text("1 1 1 0 0 0 0 0\n")
    with pytest.raises(PlanError, match="frames.txt, line 1: expected FRAME_ID RIG_ID"):
        load_plan(tmp_path)


def test_colmap_312_model_without_images_names_what_is_missing(tmp_path):
    pycolmap = pytest.importorskip("pycolmap")
    rec, _ = _rig_reconstruction(pycolmap, n_frames=1)
    out = tmp_path / "sparse" / "0"
    out.mkdir(parents=True)
    rec.write_binary(str(out))
    (out / "images.bin").unlink()
    with pytest.raises(PlanError, match=r"incomplete COLMAP model .*sparse/0 has cameras.bin, rigs.bin, "
                                        r"frames.bin but no images.bin"):
        load_plan(tmp_path)


# -- DJI area templates (mapping2d, mapping3d, mappingStrip) ------------------------------------


WPML_NS = "http://www.dji.com/wpmz/1.0.2"


def _area_template(kind: str | None, geometry: str = "polygon") -> str:
    ring = "8.0,47.0,0 8.0003,47.0,0 8.0003,47.0003,0 8.0,47.0003,0 8.0,47.0,0"
    shape = (f"<Polygon><outerBoundaryIs><LinearRing><coordinates>{ring}</coordinates></LinearRing></outerBoundaryIs>"
             "</Polygon>" if geometry == "polygon" else f"<LineString><coordinates>{ring}</coordinates></LineString>")
    type_el = f"<wpml:templateType>{kind}</wpml:templateType>" if kind else ""
    return (f"<kml xmlns='http://www.opengis.net/kml/2.2' xmlns:wpml='{WPML_NS}'><Document><wpml:missionConfig>"
            "<wpml:takeOffRefPoint>47.0,8.0,500</wpml:takeOffRefPoint></wpml:missionConfig><Folder>"
            f"{type_el}<wpml:templateId>0</wpml:templateId><wpml:autoFlightSpeed>5</wpml:autoFlightSpeed>"
            f"<Placemark>{shape}<wpml:shootType>distance</wpml:shootType><wpml:direction>0</wpml:direction>"
            "<wpml:margin>0</wpml:margin><wpml:height>50</wpml:height><wpml:ellipsoidHeight>50</wpml:ellipsoidHeight>"
            "<wpml:inclinedGimbalPitch>-45</wpml:inclinedGimbalPitch></Placemark></Folder></Document></kml>")


@pytest.mark.parametrize("kind, geometry, message", [
    ("mapping3d", "polygon", r"a DJI mapping3d \(area\) template: .*export the waylines from DJI Pilot 2.*"
                             r"`sightplan plan lawnmower` \(--oblique-pitch"),
    ("mapping2d", "polygon", r"a DJI mapping2d \(area\) template: .*export the waylines.*`sightplan plan lawnmower`"),
    ("mappingStrip", "line", r"a DJI mappingStrip \(strip\) template: .*export the waylines from DJI Pilot 2"),
    (None, "polygon", r"a DJI area template \(a Polygon instead of waypoints\)"),
])
def test_dji_area_template_alone_is_refused_by_name(tmp_path, kind, geometry, message):
    path = tmp_path / "survey.kmz"
    with zipfile.ZipFile(path, "w") as z:
        z.writestr("wpmz/template.kml", _area_template(kind, geometry))
    with pytest.raises(PlanError, match=message) as info:
        load_plan(path, camera="m3e")
    assert "no Point coordinates" not in str(info.value)
    assert str(info.value).startswith("survey.kmz, wpmz/template.kml: ")


@pytest.mark.parametrize("kind, geometry, message", [
    ("mapping3d", "polygon", r"a DJI mapping3d \(area\) template: .*export the waylines from DJI Pilot 2.*"
                             r"`sightplan plan lawnmower` \(--oblique-pitch"),
    ("mapping2d", "polygon", r"a DJI mapping2d \(area\) template: .*`sightplan plan lawnmower`"),
    ("mapping", "polygon", r"a DJI mapping \(area\) template: "),
    ("mappingStrip", "line", r"a DJI mappingStrip \(strip\) template: .*export the waylines from DJI Pilot 2"),
    (None, "polygon", r"a DJI area template \(a Polygon instead of waypoints\)"),
])
@pytest.mark.parametrize("name", ["template.kml", "survey.kml"])
def test_dji_area_template_bare_is_refused_by_name_too(tmp_path, kind, geometry, message, name):
    """A template.kml not zipped in a .kmz (or any .kml with DJI's elements) is told by its content and refused with
    the message the zipped one gets, never "cannot tell the format"."""
    path = tmp_path / name
    path.write_text(_area_template(kind, geometry))
    assert detect_format(path) == "wpml"
    with pytest.raises(PlanError, match=message) as info:
        load_plan(path, camera="m3e")
    assert str(info.value).startswith(f"{name}: ") and "\n" not in str(info.value)


def test_dji_area_template_with_its_waylines_reads_the_generated_waypoints(tmp_path):
    from sightplan.geo import Georeference

    georef = Georeference.from_origin(47.0, 8.0, 500.0)  # the take-off point; model +Y north
    corners = [[0, 0, 0], [0, 30, 0], [20, 30, 0], [20, 0, 0]]  # a lawnmower of two lines, as Pilot 2 writes it
    lat, lon, _ = (v.tolist() for v in georef.to_geodetic(corners))
    gimbal = ("<wpml:actionGroup><wpml:actionGroupId>0</wpml:actionGroupId><wpml:actionGroupStartIndex>0"
              "</wpml:actionGroupStartIndex><wpml:actionGroupEndIndex>0</wpml:actionGroupEndIndex><wpml:actionTrigger>"
              "<wpml:actionTriggerType>reachPoint</wpml:actionTriggerType></wpml:actionTrigger><wpml:action>"
              "<wpml:actionId>0</wpml:actionId><wpml:actionActuatorFunc>gimbalRotate</wpml:actionActuatorFunc>"
              "<wpml:actionActuatorFuncParam><wpml:gimbalPitchRotateEnable>1</wpml:gimbalPitchRotateEnable>"
              "<wpml:gimbalPitchRotateAngle>-90</wpml:gimbalPitchRotateAngle></wpml:actionActuatorFuncParam>"
              "</wpml:action></wpml:actionGroup>")
    every_10m = ("<wpml:actionGroup><wpml:actionGroupId>1</wpml:actionGroupId><wpml:actionGroupStartIndex>0"
                 "</wpml:actionGroupStartIndex><wpml:actionGroupEndIndex>3</wpml:actionGroupEndIndex><wpml:actionTrigger>"
                 "<wpml:actionTriggerType>multipleDistance</wpml:actionTriggerType><wpml:actionTriggerParam>10"
                 "</wpml:actionTriggerParam></wpml:actionTrigger><wpml:action><wpml:actionId>0</wpml:actionId>"
                 "<wpml:actionActuatorFunc>takePhoto</wpml:actionActuatorFunc></wpml:action></wpml:actionGroup>")
    marks = "".join(
        f"<Placemark><Point><coordinates>{lon[k]!r},{lat[k]!r}</coordinates></Point><wpml:index>{k}</wpml:index>"
        f"<wpml:executeHeight>50</wpml:executeHeight>{gimbal + every_10m if k == 0 else ''}</Placemark>"
        for k in range(4))
    waylines = (f"<kml xmlns='http://www.opengis.net/kml/2.2' xmlns:wpml='{WPML_NS}'><Document><wpml:missionConfig>"
                "<wpml:takeOffRefPoint>47.0,8.0,500</wpml:takeOffRefPoint></wpml:missionConfig><Folder>"
                "<wpml:templateId>0</wpml:templateId><wpml:waylineId>0</wpml:waylineId>"
                "<wpml:executeHeightMode>relativeToStartPoint</wpml:executeHeightMode>"
                f"<wpml:autoFlightSpeed>5</wpml:autoFlightSpeed>{marks}</Folder></Document></kml>")
    path = tmp_path / "mapping.kmz"
    with zipfile.ZipFile(path, "w") as z:
        z.writestr("wpmz/template.kml", _area_template("mapping2d"))
        z.writestr("wpmz/waylines.wpml", waylines)
    plan = load_plan(path, camera="m3e")
    assert plan.parameters["source"]["template_type"] == "mapping2d"
    expected = [[0, 0], [0, 10], [0, 20], [0, 30], [10, 30], [20, 30], [20, 20], [20, 10], [20, 0]]
    np.testing.assert_allclose(plan.C_world[:, :2], expected, atol=0.01)
    np.testing.assert_allclose(plan.C_world[:, 2], 50.0, atol=0.01)
    np.testing.assert_allclose(plan.R_world_camera[:, :, 2], np.tile([0, 0, -1.0], (9, 1)), atol=1e-9)  # nadir
    assert not any("nadir" in w for w in plan.parameters["warnings"])


def test_a_kmz_bomb_is_refused_before_its_waylines_are_unpacked(tmp_path):
    """A 65 MB waylines.wpml of padding deflates to kilobytes: refused from its declared size, nothing unpacked."""
    path = tmp_path / "bomb.kmz"
    with zipfile.ZipFile(path, "w", zipfile.ZIP_DEFLATED) as z, z.open("wpmz/waylines.wpml", "w") as entry:
        entry.write(b'<?xml version="1.0"?><kml xmlns="http://www.opengis.net/kml/2.2"><Document>')
        for _ in range(65):
            entry.write(b" " * (1 << 20))
        entry.write(b"</Document></kml>")
    assert path.stat().st_size < 200_000
    with pytest.raises(PlanError, match=r"bomb.kmz, wpmz/waylines.wpml: 68 MB unpacked, too large for a mission file"):
        load_plan(path)
