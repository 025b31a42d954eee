"""Pose conventions: gimbal angles, quaternions, rotation validation."""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from sightplan.errors import PlanError
from sightplan.geometry.poses import R_from_gimbal, R_from_quaternion, check_rotations, gimbal_from_R, quaternion_from_R


@pytest.mark.parametrize(
    ("heading", "pitch", "forward", "right"),
    [
        (0, 0, (0, 1, 0), (1, 0, 0)),  # north, right is east
        (90, 0, (1, 0, 0), (0, -1, 0)),  # east, right is south
        (180, 0, (0, -1, 0), (-1, 0, 0)),
        (0, -90, (0, 0, -1), (1, 0, 0)),  # nadir, image top toward north
        (0, 45, (0, np.sqrt(0.5), np.sqrt(0.5)), (1, 0, 0)),
    ],
)
def test_gimbal_axes(heading, pitch, forward, right):
    R = R_from_gimbal(heading, pitch, 0)[0]
    np.testing.assert_allclose(R[:, 2], forward, atol=1e-12)
    np.testing.assert_allclose(R[:, 0], right, atol=1e-12)
    np.testing.assert_allclose(R[:, 1], np.cross(R[:, 2], R[:, 0]), atol=1e-12)  # right-handed: down = fwd × right


def test_roll_turns_right_axis_down():
    """Roll +90° (clockwise seen from behind) turns the image's right toward the world's down."""
    R = R_from_gimbal(0, 0, 90)[0]
    np.testing.assert_allclose(R[:, 0], (0, 0, -1), atol=1e-12)
    np.testing.assert_allclose(R[:, 2], (0, 1, 0), atol=1e-12)


@settings(max_examples=60, deadline=None)
@given(st.floats(0, 359.9), st.floats(-89, 89), st.floats(-179, 179))
def test_gimbal_round_trip(h, p, r):
    R = R_from_gimbal(h, p, r)
    h2, p2, r2 = gimbal_from_R(R)
    np.testing.assert_allclose(R_from_gimbal(h2, p2, r2), R, atol=1e-9)


@settings(max_examples=40, deadline=None)
@given(st.lists(st.floats(-1, 1), min_size=4, max_size=4).filter(lambda q: np.linalg.norm(q) > 0.1))
def test_quaternion_round_trip(q):
    q = np.asarray(q) / np.linalg.norm(q)
    R = R_from_quaternion(q)
    np.testing.assert_allclose(R_from_quaternion(quaternion_from_R(R)), R, atol=1e-9)
    np.testing.assert_allclose(np.linalg.det(R), 1.0, atol=1e-9)


def test_check_rotations_names_the_bad_frame():
    R = R_from_gimbal([0, 10, 20], [0, 0, 0])
    R[1, 0, 0] = 1.5
    with pytest.raises(PlanError, match="frame 1 .*not orthonormal"):
        check_rotations(R)
    R = R_from_gimbal([0, 10], [0, 0])
    R[0, 2, 2] = np.nan
    with pytest.raises(PlanError, match="frame 0 has a NaN"):
        check_rotations(R)
    with pytest.raises(PlanError, match="reflection"):
        check_rotations(np.diag([1.0, 1.0, -1.0])[None])
