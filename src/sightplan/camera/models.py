"""Camera models.

Conventions, stated once:

- Camera axes are OpenCV's: +X right, +Y down, +Z forward (the optical axis).
- Pixel ``(u, v)`` (column, row; row 0 at the top) has its centre at ``(u + ½, v + ½)``,
  so the image spans ``0 ≤ x < W``, ``0 ≤ y < H``. Intrinsics in OpenCV's convention
  (pixel centres at integers) are shifted by +½ px on import (:meth:`PinholeCamera.from_opencv`).
- Equirectangular: column ``u`` maps to longitude ``λ = 2π(u+½)/W − π`` (0 straight
  ahead along +Z, positive toward +X), row ``v`` to latitude ``φ = π/2 − π(v+½)/H``
  (positive up, i.e. toward −Y). Direction ``(cos φ sin λ, −sin φ, cos φ cos λ)``.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, replace
from typing import Literal, Union

from ..errors import CameraError

CameraKind = Literal["pinhole", "equirectangular"]


def _check_size(width: int, height: int) -> None:
    if not (isinstance(width, int) and isinstance(height, int)):
        raise CameraError(f"image size must be whole pixels, got {width!r} x {height!r}")
    if width < 1 or height < 1 or width * height > 400_000_000:
        raise CameraError(f"impossible image size {width} x {height} px")


@dataclass(frozen=True)
class PinholeCamera:
    """A perspective camera without distortion.

    width, height: image size in pixels. fx, fy: focal lengths in pixels.
    cx, cy: principal point in pixels, in sightplan's convention (pixel centres at +½).
    """

    width: int
    height: int
    fx: float
    fy: float
    cx: float
    cy: float
    name: str = ""
    kind: Literal["pinhole"] = "pinhole"

    def __post_init__(self) -> None:
        _check_size(self.width, self.height)
        for label, value in (("fx", self.fx), ("fy", self.fy), ("cx", self.cx), ("cy", self.cy)):
            if not math.isfinite(value):
                raise CameraError(f"camera {self.name or ''} {label} is not a finite number".replace("  ", " "))
        if self.fx <= 0 or self.fy <= 0:
            raise CameraError(f"focal lengths must be positive, got fx={self.fx}, fy={self.fy}")
        if self.fx < 0.05 * self.width or self.fy < 0.05 * self.height:
            raise CameraError(
                f"focal length fx={self.fx:g} px for a {self.width} px wide image means a field of view over 170°; "
                "a pinhole model cannot represent it (check the units: focal in mm needs a sensor width)"
            )

    @classmethod
    def from_sensor(
        cls,
        sensor_width_mm: float,
        focal_mm: float,
        width: int,
        height: int,
        sensor_height_mm: float | None = None,
        name: str = "",
    ) -> PinholeCamera:
        """From the physical sensor: square pixels unless a sensor height says otherwise."""
        if not (sensor_width_mm > 0 and focal_mm > 0):
            raise CameraError(f"sensor width and focal length must be positive, got {sensor_width_mm} mm and {focal_mm} mm")
        fx = focal_mm / sensor_width_mm * width
        fy = fx if sensor_height_mm is None else focal_mm / sensor_height_mm * height
        return cls(int(width), int(height), fx, fy, width / 2, height / 2, name)

    @classmethod
    def from_opencv(cls, fx: float, fy: float, cx: float, cy: float, width: int, height: int, name: str = "") -> PinholeCamera:
        """From calibrated intrinsics in OpenCV's convention (pixel centres at integers)."""
        return cls(int(width), int(height), float(fx), float(fy), float(cx) + 0.5, float(cy) + 0.5, name)

    @property
    def sampling_focal_px(self) -> float:
        """Pixels per radian used for the surface sampling distance: √(fx·fy)."""
        return math.sqrt(self.fx * self.fy)

    @property
    def hfov_deg(self) -> float:
        return math.degrees(2 * math.atan(self.width / (2 * self.fx)))

    @property
    def vfov_deg(self) -> float:
        return math.degrees(2 * math.atan(self.height / (2 * self.fy)))

    def scaled(self, s: float) -> PinholeCamera:
        """The same camera at resolution scale ``s`` (fewer pixels, same field of view)."""
        w = max(1, round(self.width * s))
        h = max(1, round(self.height * s))
        kx, ky = w / self.width, h / self.height
        return replace(self, width=w, height=h, fx=self.fx * kx, fy=self.fy * ky, cx=self.cx * kx, cy=self.cy * ky)

    def to_dict(self) -> dict:
        return {"model": "pinhole", "name": self.name, "width": self.width, "height": self.height,
                "fx": self.fx, "fy": self.fy, "cx": self.cx, "cy": self.cy}


@dataclass(frozen=True)
class EquirectangularCamera:
    """A 360° camera stored as an equirectangular image, width = 2 × height."""

    width: int
    height: int
    name: str = ""
    kind: Literal["equirectangular"] = "equirectangular"

    def __post_init__(self) -> None:
        _check_size(self.width, self.height)
        if self.width != 2 * self.height:
            raise CameraError(f"an equirectangular image must be twice as wide as high, got {self.width} x {self.height}")

    @property
    def sampling_focal_px(self) -> float:
        """Pixels per radian at the equator: W / 2π."""
        return self.width / (2 * math.pi)

    def scaled(self, s: float) -> EquirectangularCamera:
        h = max(1, round(self.height * s))
        return replace(self, width=2 * h, height=h)

    def to_dict(self) -> dict:
        return {"model": "equirectangular", "name": self.name, "width": self.width, "height": self.height}


Camera = Union[PinholeCamera, EquirectangularCamera]


def camera_from_dict(d: dict) -> Camera:
    """Inverse of ``to_dict``; raises :class:`CameraError` naming what is wrong."""
    if not isinstance(d, dict):
        raise CameraError(f"a camera must be an object, got {type(d).__name__}")
    model = d.get("model")
    for key in ("width", "height"):
        value = d.get(key)
        if isinstance(value, bool) or (isinstance(value, float) and not value.is_integer()):
            raise CameraError(f"{model} camera field {key!r} must be a whole number of pixels, got {value!r}")
    try:
        if model == "pinhole":
            return PinholeCamera(int(d["width"]), int(d["height"]), float(d["fx"]), float(d["fy"]),
                                 float(d["cx"]), float(d["cy"]), str(d.get("name", "")))
        if model == "equirectangular":
            return EquirectangularCamera(int(d["width"]), int(d["height"]), str(d.get("name", "")))
    except KeyError as exc:
        raise CameraError(f"{model} camera lacks the field {exc.args[0]!r}") from None
    except (TypeError, ValueError) as exc:
        raise CameraError(f"{model} camera has a malformed field: {exc}") from None
    raise CameraError(f"unknown camera model {model!r}; expected 'pinhole' or 'equirectangular'")
