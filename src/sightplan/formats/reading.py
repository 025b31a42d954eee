"""What the readers of flight-app missions (QGroundControl, QGC WPL, DJI WPML) share."""

from __future__ import annotations

import math

from numpy.typing import NDArray

from ..camera.files import parse_camera_spec
from ..camera.models import Camera
from ..errors import CameraError, PlanError

#: The gimbal pitch of a photo taken before the mission sets one: nadir.
DEFAULT_PITCH_DEG = -90.0
#: The flight speed of a mission that gives none (photos on a timer are that far apart per second).
DEFAULT_SPEED_M_S = 5.0


def differs(camera: Camera | str | dict | None, cam: Camera) -> bool:
    """Whether a camera argument was given and names another camera than ``cam``."""
    if camera is None:
        return False
    try:
        return parse_camera_spec(camera) != cam
    except CameraError:
        return True


def given_camera(camera: Camera | str | dict, where: str) -> Camera:
    """The camera given for a mission whose file names none the catalogue knows; a PlanError starting with ``where``
    when it is not a camera."""
    try:
        return parse_camera_spec(camera)
    except CameraError as exc:
        raise PlanError(f"{where}: {exc}") from None


def bearing(a: NDArray, b: NDArray) -> float | None:
    """Model heading (clockwise from +Y, [0, 360)) from point ``a`` toward ``b``; None when they are
    less than a micrometre apart horizontally."""
    d = b[:2] - a[:2]
    if math.hypot(*d) < 1e-6:
        return None
    return math.degrees(math.atan2(d[0], d[1])) % 360.0
