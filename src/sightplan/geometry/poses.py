"""Pose conventions and conversions — the one place where they live.

- World frame: the model's local frame, metres, +Z up. "North" is +Y, "east" is +X
  unless a georeference says otherwise.
- ``R_world_camera`` (3, 3): columns are the camera's +X (right), +Y (down), +Z
  (forward) axes expressed in world coordinates (OpenCV camera axes). A world point
  ``X`` is at ``R_world_cameraᵀ (X − C)`` in camera coordinates, ``C`` the centre.
- Gimbal angles, as drone apps state them: ``heading_deg`` clockwise from north (+Y)
  seen from above, ``pitch_deg`` up from the horizon (−90 = nadir), ``roll_deg`` about
  the optical axis, clockwise as seen from behind the camera. Heading 0, pitch 0,
  roll 0 looks north with the image's right toward east.
- Quaternions are ``(w, x, y, z)``, Hamilton convention, of ``R_world_camera``.
"""

from __future__ import annotations

import numpy as np
from numpy.typing import NDArray

from ..errors import PlanError

ORTHONORMAL_TOL = 1e-5


def R_from_gimbal(heading_deg: NDArray, pitch_deg: NDArray, roll_deg: NDArray | float = 0.0) -> NDArray[np.float64]:
    """(n, 3, 3) R_world_camera from (n,) heading, pitch and roll in degrees."""
    h, p, r = np.broadcast_arrays(*(np.radians(np.asarray(a, float)) for a in (heading_deg, pitch_deg, roll_deg)))
    h, p, r = (np.atleast_1d(a) for a in (h, p, r))
    # forward direction from heading (clockwise from +Y) and pitch (up from horizon)
    fwd = np.stack([np.sin(h) * np.cos(p), np.cos(h) * np.cos(p), np.sin(p)], axis=-1)
    right0 = np.stack([np.cos(h), -np.sin(h), np.zeros_like(h)], axis=-1)
    down0 = np.cross(fwd, right0)
    # roll: rotate right/down about forward, clockwise seen from behind the camera
    cr, sr = np.cos(r)[:, None], np.sin(r)[:, None]
    right = cr * right0 + sr * down0
    down = -sr * right0 + cr * down0
    return np.stack([right, down, fwd], axis=-1)


def gimbal_from_R(R_world_camera: NDArray) -> tuple[NDArray, NDArray, NDArray]:
    """Inverse of :func:`R_from_gimbal`: (n,) heading, pitch, roll in degrees.

    At pitch ±90° heading is taken from the image's up direction and roll is 0.
    """
    R = np.asarray(R_world_camera, float).reshape(-1, 3, 3)
    fwd, right = R[:, :, 2], R[:, :, 0]
    pitch = np.degrees(np.arcsin(np.clip(fwd[:, 2], -1, 1)))
    horiz = np.hypot(fwd[:, 0], fwd[:, 1])
    up_img = -R[:, :, 1]
    # near nadir/zenith use the image "up" (or "down") direction for heading
    ref = np.where((horiz > 1e-6)[:, None], fwd, np.where((fwd[:, 2] < 0)[:, None], up_img, -up_img))
    heading = np.degrees(np.arctan2(ref[:, 0], ref[:, 1])) % 360.0
    R0 = R_from_gimbal(heading, pitch, 0.0)
    right0, down0 = R0[:, :, 0], R0[:, :, 1]
    roll = np.degrees(np.arctan2(np.einsum("ij,ij->i", right, down0), np.einsum("ij,ij->i", right, right0)))
    return heading, pitch, roll


def R_from_quaternion(q_wxyz: NDArray) -> NDArray[np.float64]:
    """(n, 3, 3) rotation matrices from (n, 4) unit quaternions (w, x, y, z)."""
    q = np.asarray(q_wxyz, float).reshape(-1, 4)
    norm = np.linalg.norm(q, axis=1)
    if not np.all(np.isfinite(q)) or np.any(np.abs(norm - 1) > 1e-3):
        bad = int(np.flatnonzero(~np.isfinite(norm) | (np.abs(norm - 1) > 1e-3))[0])
        raise PlanError(f"quaternion of frame {bad} is not a unit quaternion (norm {norm[bad]:.6g})")
    w, x, y, z = (q / norm[:, None]).T
    return np.stack([
        np.stack([1 - 2 * (y * y + z * z), 2 * (x * y - w * z), 2 * (x * z + w * y)], -1),
        np.stack([2 * (x * y + w * z), 1 - 2 * (x * x + z * z), 2 * (y * z - w * x)], -1),
        np.stack([2 * (x * z - w * y), 2 * (y * z + w * x), 1 - 2 * (x * x + y * y)], -1),
    ], axis=1)


def quaternion_from_R(R: NDArray) -> NDArray[np.float64]:
    """(n, 4) unit quaternions (w, x, y, z), w ≥ 0, of (n, 3, 3) rotations."""
    R = np.asarray(R, float).reshape(-1, 3, 3)
    from scipy.spatial.transform import Rotation

    xyzw = Rotation.from_matrix(R).as_quat()
    q = np.concatenate([xyzw[:, 3:], xyzw[:, :3]], axis=1)
    return q * np.where(q[:, :1] < 0, -1.0, 1.0)


def R_from_rotvec(rotvec: NDArray) -> NDArray[np.float64]:
    """(n, 3, 3) from (n, 3) axis-angle vectors in radians."""
    from scipy.spatial.transform import Rotation

    return Rotation.from_rotvec(np.asarray(rotvec, float).reshape(-1, 3)).as_matrix()


def check_rotations(R: NDArray, what: str = "frame") -> NDArray[np.float64]:
    """Validate (n, 3, 3) proper rotations; raise :class:`PlanError` naming the first bad one."""
    R = np.asarray(R, float)
    if R.ndim != 3 or R.shape[1:] != (3, 3):
        raise PlanError(f"rotations must be (n, 3, 3), got {R.shape}")
    finite = np.isfinite(R).all(axis=(1, 2))
    if not finite.all():
        raise PlanError(f"{what} {int(np.flatnonzero(~finite)[0])} has a NaN or infinite rotation")
    err = np.abs(np.einsum("nji,njk->nik", R, R) - np.eye(3)).max(axis=(1, 2))
    det = np.linalg.det(R)
    bad = (err > ORTHONORMAL_TOL) | (det < 0)
    if bad.any():
        i = int(np.flatnonzero(bad)[0])
        why = f"a reflection (determinant {det[i]:.3g})" if det[i] < 0 else f"not orthonormal (‖RᵀR − I‖ = {err[i]:.2g})"
        raise PlanError(f"{what} {i} has a rotation that is {why}")
    return R


def aim_angles(C: NDArray, target: NDArray) -> tuple[NDArray, NDArray]:
    """(n,) heading (clockwise from north, −180…180) and pitch (up positive) in degrees that aim from each of the
    (n, 3) points C at the matching target (or at one (3,) target)."""
    v = np.asarray(target, float) - np.asarray(C, float)
    return np.degrees(np.arctan2(v[:, 0], v[:, 1])), np.degrees(np.arctan2(v[:, 2], np.hypot(v[:, 0], v[:, 1])))
