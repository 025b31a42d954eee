"""sightplan JSON plan format v1: exact round trip, orientation inputs, clear errors."""

from __future__ import annotations

import copy
import json

import numpy as np
import pytest
from scipy.spatial.transform import Rotation

from sightplan.camera import EquirectangularCamera, PinholeCamera
from sightplan.errors import FormatVersionError, PlanError
from sightplan.plan import Mission, Plan, plan_from_dict, plan_to_dict, read_plan, write_plan


def _plan() -> Plan:
    rng = np.random.default_rng(7)
    n = 7
    cams = {"drone": PinholeCamera(5472, 3648, 3648.0, 3648.0, 2736.0, 1824.0, "P4P"),
            "360": EquirectangularCamera(6720, 3360, "Z1")}
    return Plan.build(
        cams,
        Rotation.random(n, random_state=3).as_matrix(),
        rng.normal(scale=30.0, size=(n, 3)),
        frame_camera=["drone"] * 4 + ["360"] * 3,
        frame_names=[f"DJI_{i:04d}.JPG" for i in range(n)],
        capture_time=np.array([1.7e9 + 0.1 * i if i != 2 else np.nan for i in range(n)]),
        missions=(Mission("north", 0, 4), Mission("indoor", 4, 7)),
        waypoints=rng.normal(size=(5, 3)),
        parameters={"template": "facade", "overlap": 0.8,
                    "georeference": {"reference_lla": {"latitude": 52.5, "longitude": 13.4, "altitude": 30.0}}},
    )


def _frame(**fields) -> dict:
    return {"format": "sightplan-plan", "version": 1, "cameras": {"c": PinholeCamera(100, 100, 80.0, 80.0, 50.0, 50.0).to_dict()},
            "frames": [{"name": "f0", "camera": "c", "position": [0.0, 0.0, 10.0], **fields}]}


def test_round_trip_is_exact(tmp_path):
    plan = _plan()
    path = tmp_path / "plan.json"
    write_plan(plan, path)
    back = read_plan(path)
    assert back.cameras == plan.cameras
    assert np.array_equal(back.C_world, plan.C_world)
    assert np.array_equal(back.R_world_camera, plan.R_world_camera)
    assert np.array_equal(back.capture_time, plan.capture_time, equal_nan=True)
    assert back.frame_names.tolist() == plan.frame_names.tolist()
    assert back.frame_camera.tolist() == plan.frame_camera.tolist()
    assert back.missions == plan.missions
    assert np.array_equal(back.waypoints, plan.waypoints)
    assert back.parameters == plan.parameters
    assert back.frame_keys() == plan.frame_keys()


def test_file_layout(tmp_path):
    path = tmp_path / "plan.json"
    write_plan(_plan(), path)
    d = json.loads(path.read_text())
    assert (d["format"], d["version"], d["units"]) == ("sightplan-plan", 1, "m")
    assert "R_world_camera" in d["frame_convention"]
    assert d["georeference"]["reference_lla"]["latitude"] == 52.5
    assert "georeference" not in d["parameters"]
    assert d["missions"][1] == {"name": "indoor", "frames": [4, 7]}
    assert "time" not in d["frames"][2]  # NaN time is omitted
    assert set(d["frames"][0]) == {"name", "camera", "position", "rotation", "time"}


@pytest.mark.parametrize("angles, forward", [
    ({"heading_deg": 90.0, "pitch_deg": 0.0, "roll_deg": 0.0}, [1, 0, 0]),  # east
    ({"heading_deg": 0.0, "pitch_deg": 0.0}, [0, 1, 0]),  # north, roll defaults to 0
    ({"heading_deg": 180.0, "pitch_deg": 0.0}, [0, -1, 0]),
    ({"heading_deg": 37.0, "pitch_deg": -90.0, "roll_deg": 0.0}, [0, 0, -1]),  # nadir
])
def test_gimbal_angles_give_look_direction(angles, forward):
    plan = plan_from_dict(_frame(**angles))
    np.testing.assert_allclose(plan.R_world_camera[0][:, 2], forward, atol=1e-12)


def test_gimbal_level_camera_has_image_right_east_and_down_down():
    R = plan_from_dict(_frame(heading_deg=0.0, pitch_deg=0.0)).R_world_camera[0]
    np.testing.assert_allclose(R[:, 0], [1, 0, 0], atol=1e-12)  # image right: east
    np.testing.assert_allclose(R[:, 1], [0, 0, -1], atol=1e-12)  # image down: world down


def test_quaternion_input():
    # 90° about world +Z, (w, x, y, z): camera +X axis turns to world +Y
    q = [np.cos(np.pi / 4), 0.0, 0.0, np.sin(np.pi / 4)]
    R = plan_from_dict(_frame(quaternion_wxyz=q)).R_world_camera[0]
    np.testing.assert_allclose(R[:, 0], [0, 1, 0], atol=1e-12)
    np.testing.assert_allclose(R, Rotation.from_quat([0, 0, q[3], q[0]]).as_matrix(), atol=1e-12)


def test_single_camera_frame_may_omit_camera():
    d = _frame(rotation=np.eye(3).tolist())
    del d["frames"][0]["camera"]
    assert plan_from_dict(d).frame_camera.tolist() == ["c"]


ROT = np.eye(3).tolist()


@pytest.mark.parametrize("fields, message", [
    ({"rotation": ROT, "position": [0.0, float("nan"), 1.0]}, r"frame 0 \('f0'\): field 'position' is not finite"),
    ({"rotation": [[1, 0, 0], [0, 1, 0.2], [0, 0, 1]]}, r"frame 0 \('f0'\): the rotation is not orthonormal"),
    ({"rotation": [[1, 0, 0], [0, 1, 0], [0, 0, -1]]}, r"frame 0 \('f0'\): the rotation is a reflection"),
    ({"rotation": ROT, "camera": "nope"}, r"frame 0 \('f0'\): unknown camera 'nope'; the plan defines 'c'"),
    ({}, r"frame 0 \('f0'\): missing field 'rotation'"),
    ({"heading_deg": 10.0}, r"frame 0 \('f0'\): missing field 'pitch_deg'"),
    ({"rotation": ROT, "heading_deg": 0.0, "pitch_deg": 0.0}, "give one orientation"),
    ({"rotation": [[1, 0, 0], [0, 1, 0]]}, r"field 'rotation' must be 3×3 numbers"),
    ({"rotation": ROT, "position": [1.0, 2.0]}, r"frame 0 \('f0'\): field 'position' must be 3 numbers"),
    ({"rotation": ROT, "position": ["1", 2, 3]}, r"field 'position' must be 3 numbers"),
    ({"rotation": ROT, "position": [True, 2, 3]}, r"field 'position' must be 3 numbers"),
    ({"rotation": ROT, "time": "noon"}, r"field 'time' must be a number"),
    ({"rotation": ROT, "name": 5}, r"frame 0: field 'name' must be a string"),
    ({"quaternion_wxyz": [1.0, 1.0, 0.0, 0.0]}, r"frame 0 \('f0'\): quaternion .* is not a unit quaternion"),
])
def test_bad_frames_name_frame_and_field(fields, message):
    d = _frame(**fields)
    with pytest.raises(PlanError, match=message):
        plan_from_dict(d)


def test_missing_position_named():
    d = _frame(rotation=ROT)
    del d["frames"][0]["position"]
    with pytest.raises(PlanError, match=r"frame 0 \('f0'\): missing field 'position'"):
        plan_from_dict(d)


def test_second_frame_named_in_error():
    d = _frame(rotation=ROT)
    bad = copy.deepcopy(d["frames"][0]) | {"name": "IMG_2.JPG", "rotation": [[2, 0, 0], [0, 1, 0], [0, 0, 1]]}
    d["frames"].append(bad)
    with pytest.raises(PlanError, match=r"frame 1 \('IMG_2.JPG'\): the rotation is not orthonormal"):
        plan_from_dict(d)


@pytest.mark.parametrize("change, message", [
    ({"format": "something-else"}, "not a sightplan plan"),
    ({"version": "1"}, "'version' must be a whole number"),
    ({"version": 0}, "'version' must be ≥ 1"),
    ({"units": "ft"}, "'units' must be 'm'"),
    ({"cameras": {}}, "non-empty 'cameras'"),
    ({"cameras": {"c": {"model": "fisheye", "width": 10, "height": 10}}}, "camera 'c': unknown camera model 'fisheye'"),
    ({"frames": {}}, "'frames' must be a list"),
    ({"missions": [{"name": "m", "frames": [0, 2]}]}, "missions cover 2 frames, the plan has 1"),
    ({"missions": [{"name": "m", "frames": [0, "1"]}]}, r"mission 0 \('m'\): field 'frames' must be \[start, stop\]"),
    ({"waypoints": [[0, 0]]}, "'waypoints' must be"),
    ({"parameters": []}, "'parameters' must be an object"),
])
def test_bad_plan_fields(change, message):
    d = _frame(rotation=ROT) | change
    with pytest.raises(PlanError, match=message):
        plan_from_dict(d)


def test_newer_version_is_a_format_version_error(tmp_path):
    path = tmp_path / "future.json"
    path.write_text(json.dumps(_frame(rotation=ROT) | {"version": 2}))
    with pytest.raises(FormatVersionError, match="written by a newer sightplan: format version 2, this one reads up to 1"):
        read_plan(path)


def test_not_json_is_a_plan_error(tmp_path):
    path = tmp_path / "plan.json"
    path.write_text("{'format': sightplan")
    with pytest.raises(PlanError, match="is not JSON"):
        read_plan(path)
    path.write_text("[1, 2]")
    with pytest.raises(PlanError, match="a sightplan plan is a JSON object, got a JSON list"):
        read_plan(path)


def test_nan_parameters_are_refused_on_write(tmp_path):
    plan = Plan.build(PinholeCamera(10, 10, 8.0, 8.0, 5.0, 5.0, "c"), np.eye(3), [0, 0, 0], parameters={"gsd": float("nan")})
    with pytest.raises(PlanError, match="cannot be written as JSON"):
        write_plan(plan, tmp_path / "p.json")


def test_plan_to_dict_numpy_parameters_written(tmp_path):
    plan = Plan.build(PinholeCamera(10, 10, 8.0, 8.0, 5.0, 5.0, "c"), np.eye(3), [0, 0, 0],
                      parameters={"spacing": np.float64(2.5), "grid": np.arange(3)})
    write_plan(plan, tmp_path / "p.json")
    assert read_plan(tmp_path / "p.json").parameters == {"spacing": 2.5, "grid": [0, 1, 2]}
    assert plan_to_dict(plan)["cameras"] == {"c": plan.cameras["c"].to_dict()}
