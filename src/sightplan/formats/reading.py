"""What the readers of flight-app missions (QGroundControl, QGC WPL, DJI WPML, Litchi) share: defaults, the camera,
bearings, and the take-off point their heights above take-off start from (:func:`place_takeoff`)."""

from __future__ import annotations

import math
from dataclasses import dataclass

from numpy.typing import NDArray

from ..camera.files import parse_camera_spec
from ..camera.models import Camera
from ..errors import CameraError, PlanError
from ..geo import Georeference

#: The gimbal pitch of a photo taken before the mission sets one: nadir.
DEFAULT_PITCH_DEG = -90.0
#: The flight speed of a mission that gives none (photos on a timer are that far apart per second).
DEFAULT_SPEED_M_S = 5.0


def number_cell(text: str | None, name: str, where: str, default: float | None = None) -> float | None:
    """A number a mission file gives as text (a CSV cell, an XML element's text): ``default`` when empty, else a
    finite float, or one PlanError naming ``where`` and ``name``."""
    text = (text or "").strip()
    if not text:
        return default
    try:
        v = float(text)
    except ValueError:
        raise PlanError(f"{where}: {name} {text!r} is not a number") from None
    if not math.isfinite(v):
        raise PlanError(f"{where}: {name} {text!r} is not a finite number")
    return v


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


# ---- the take-off point a mission's heights above take-off start from --------------------------

#: A file's take-off reference further than this (m, horizontally) from the model's origin is not on the model's site.
REFERENCE_FAR_M = 5000.0
#: A file's take-off reference further than this (m) above or below the model's ground is not in the model's
#: vertical datum (an app's terrain altitude against a model at a nominal elevation, a home altitude of 0).
REFERENCE_OFF_M = 100.0
#: A file's take-off reference this far (m) from the model's ground is used, with a warning.
REFERENCE_NOTE_M = 10.0


@dataclass(frozen=True)
class Takeoff:
    """Where a mission's heights above take-off start: latitude, longitude, height in the georeference's datum, its
    model-frame point, and where its height came from: ``file`` (the file's reference), ``ground`` (the model's ground,
    ``ground_z``), ``given`` (``takeoff_z``) or ``zero`` (neither: the model's height 0)."""

    latitude_deg: float
    longitude_deg: float
    height_m: float
    xyz: NDArray
    source: str

    def to_dict(self) -> dict:
        return {"latitude_deg": self.latitude_deg, "longitude_deg": self.longitude_deg, "height_m": self.height_m,
                "from": self.source}


def place_takeoff(georef: Georeference, latitude_deg: float, longitude_deg: float, height_m: float | None, *,
                  model: bool, ground_z: float | None, takeoff_z: float | None, what: str,
                  warnings: list[str]) -> Takeoff:
    """The take-off point of a mission whose file gives its reference at ``latitude_deg``, ``longitude_deg`` and
    ``height_m`` (the georeference's datum; None when the file has no usable height).

    model: ``georef`` places the model (the caller's, or one sightplan recorded in the file), not a frame made at the
    file's own reference. The file's height is used as it is, unless ``takeoff_z`` (a model-frame height the user
    gives) replaces it, or it is unusable: missing, the frame is not the model's, or it lies more than
    :data:`REFERENCE_OFF_M` above or below the model's ground ``ground_z``, or its point more than
    :data:`REFERENCE_FAR_M` from the model's origin (a warning says which). Then the take-off is on the model's ground
    ``ground_z`` (else at the model's height 0). ``what`` names the reference in the warnings."""
    lat, lon = float(latitude_deg), float(longitude_deg)
    near = 0.0 if height_m is None else float(height_m)
    h = None if height_m is None else float(height_m)

    def at(z: float) -> float:
        return georef.height_at(lat, lon, float(z), near)

    source = "file"
    if takeoff_z is not None:
        if h is not None and abs(at(takeoff_z) - h) > 0.01:
            warnings.append(f"the take-off height given (z {takeoff_z:.2f} m) replaces the {what}'s, "
                            f"{at(takeoff_z) - h:+.2f} m from it")
        h, source = at(takeoff_z), "given"
    elif h is not None and not model:
        if ground_z is not None:  # a frame of the file's own: the model's ground is the only height that relates
            h, source = at(ground_z), "ground"
    elif h is not None:
        x, y, z = georef.from_geodetic(lat, lon, h)[0]
        origin = georef.origin_m[:2] if georef.kind == "topocentric" else (0.0, 0.0)
        far = math.hypot(x - origin[0], y - origin[1])
        off = None if ground_z is None else z - float(ground_z)
        if far > REFERENCE_FAR_M:
            if ground_z is None:
                warnings.append(f"the {what} lies {far / 1000:.1f} km from the model's origin: check the file and the "
                                "model's georeference")
            else:
                warnings.append(f"the {what} lies {far / 1000:.1f} km from the model's origin: not the site's take-off "
                                "point; heights above take-off start from the model's ground")
                h, source = at(ground_z), "ground"
        elif off is not None and abs(off) > REFERENCE_OFF_M:
            warnings.append(f"the {what}'s height {h:.2f} m lies {abs(off):.1f} m {'above' if off > 0 else 'below'} the "
                            f"model's ground (z {ground_z:.2f} m): not in the model's vertical datum; heights above "
                            "take-off start from the model's ground")
            h, source = at(ground_z), "ground"
        elif off is not None and abs(off) > REFERENCE_NOTE_M:
            warnings.append(f"the {what} lies {abs(off):.1f} m {'above' if off > 0 else 'below'} the model's ground "
                            f"(z {ground_z:.2f} m): used as the file gives it; check that its height is in the model's "
                            "datum")
    if h is None:
        h, source = (at(ground_z), "ground") if ground_z is not None else (at(0.0), "zero")
    return Takeoff(lat, lon, float(h), georef.from_geodetic(lat, lon, h)[0], source)
