"""What makes a synthetic frame behave like a photograph: the sun, the lens and the sensor.

The renders (:mod:`.render`) climb a ladder of presets, each adding to the one before (:data:`PRESETS`):

- ``flat``: one uniform colour per material (:mod:`.materials`), shaded by the angle to the view; no texture;
- ``textured``: each material's texture statistics (plaster, concrete, brick, glass, …);
- ``shaded``: a sun from the date, the time and the site's latitude, Lambert shading with shadows cast through the
  visibility engine, sky light, a sky and a textured ground;
- ``full``: the camera too: exposure and white balance varying per frame, sensor noise (shot and read), motion blur
  along the image motion, vignetting and the lens's radial/tangential distortion (OpenCV's k1, k2, p1, p2).

Below the ladder, ``noise`` (the command line's default) draws every element in its own saturated colour under a
rich procedural noise texture, unlit: far more texture than real plaster or glass, so structure from motion holds
wherever two views overlap. It is the upper bound of what a plan allows; the ladder shows what each property of real
photographs takes away (``docs/closed-loop.md`` has the measured numbers).

Every random choice comes from :class:`PhotoOptions`'s ``seed`` and the frame's index, so the same inputs give the
same images, byte for byte.
"""

from __future__ import annotations

import datetime as _dt
import math
from dataclasses import asdict, dataclass, field, replace

import numpy as np
from numpy.typing import NDArray

from ..errors import SightplanError

PRESETS = ("flat", "textured", "shaded", "full")
NOISE = "noise"  # the procedural element noise, below the ladder
DEFAULT_PRESET = NOISE
DEFAULT_LATITUDE_DEG = 48.0  # a mid-European site, when the model has no georeference
DEFAULT_DATE = "2025-06-15"
DEFAULT_SOLAR_TIME_H = 9.5  # morning: a sun high enough to light two sides, low enough for long shadows
#: A camera of the kind drones fly: mild barrel distortion, a little decentring (OpenCV k1, k2, p1, p2).
DEFAULT_DISTORTION = (-0.06, 0.015, 0.0008, -0.0005)


@dataclass(frozen=True)
class PhotoOptions:
    """How photograph-like the renders are; :func:`photo_options` fills it from a preset.

    texture: draw each material's texture (else its flat colour). sun: sun, shadows, sky light, ground. camera:
    exposure, white balance, noise, blur, vignetting, distortion (each also off with its own amount at 0).

    date, solar_time_h: the day (ISO) and the local solar time in hours (12 = the sun due south in the north).
    latitude_deg: the site's latitude (None: the model's georeference, else :data:`DEFAULT_LATITUDE_DEG`).
    sun_elevation_deg, sun_azimuth_deg: a sun set by hand instead (azimuth clockwise from the model's +Y when the
    model has no georeference, else from true north). exposure_ev_sd: the spread (EV) of the per-frame exposure
    about the auto exposure. white_balance_sd: the spread of the per-frame red and blue gains. full_well_e,
    read_noise_e: the sensor's electrons at white and its read noise (electrons). speed_m_s, shutter_s: the drone's
    speed along its path and the exposure time, from which the motion blur follows. vignetting: the darkening at
    the image's corners (share). distortion: OpenCV's (k1, k2, p1, p2) of every camera, pixels rendered through it.
    """

    preset: str = "full"  # the flags below default to every factor on: build presets with photo_options()
    seed: int = 0
    texture: bool = True
    sun: bool = True
    camera: bool = True
    date: str = DEFAULT_DATE
    solar_time_h: float = DEFAULT_SOLAR_TIME_H
    latitude_deg: float | None = None
    sun_elevation_deg: float | None = None
    sun_azimuth_deg: float | None = None
    exposure_ev_sd: float = 0.3
    white_balance_sd: float = 0.04
    full_well_e: float = 4000.0
    read_noise_e: float = 6.0
    speed_m_s: float = 4.0
    shutter_s: float = 1 / 500
    vignetting: float = 0.25
    distortion: tuple[float, float, float, float] = field(default=DEFAULT_DISTORTION)

    def __post_init__(self) -> None:
        if self.preset not in PRESETS:
            raise SightplanError(f"unknown photo-realism preset {self.preset!r}; choose one of {', '.join(PRESETS)}")
        if len(self.distortion) != 4 or not all(math.isfinite(float(x)) for x in self.distortion):
            raise SightplanError(f"the distortion must be four finite numbers k1, k2, p1, p2, got {self.distortion}")
        for name in ("exposure_ev_sd", "white_balance_sd", "read_noise_e", "speed_m_s", "shutter_s", "vignetting"):
            if not (float(getattr(self, name)) >= 0):
                raise SightplanError(f"{name} must be zero or more, got {getattr(self, name)}")
        if not self.full_well_e > 0:
            raise SightplanError(f"full_well_e must be positive, got {self.full_well_e}")

    @property
    def lens(self) -> tuple[float, float, float, float] | None:
        """The distortion the renders are drawn through, None when there is none."""
        d = tuple(float(x) for x in self.distortion)
        return d if self.camera and any(d) else None  # type: ignore[return-value]

    def to_dict(self) -> dict:
        d = asdict(self)
        d["distortion"] = list(self.distortion)
        return d


def photo_options(preset: str = DEFAULT_PRESET, seed: int = 0, **overrides) -> PhotoOptions | None:
    """The options of a preset (``flat``, ``textured``, ``shaded``, ``full``), with ``overrides`` set on top; None
    for ``noise`` (the procedural element noise, which has no options)."""
    if preset == NOISE and not overrides:
        return None
    if preset not in PRESETS:
        raise SightplanError(f"unknown photo-realism preset {preset!r}; choose one of {NOISE}, {', '.join(PRESETS)}")
    level = PRESETS.index(preset)
    base = PhotoOptions(preset=preset, seed=int(seed), texture=level >= 1, sun=level >= 2, camera=level >= 3)
    return replace(base, **overrides) if overrides else base


def frame_rng(seed: int, frame: int, purpose: int) -> np.random.Generator:
    """The random numbers of one frame for one purpose (1: exposure and white balance, 2: sensor noise)."""
    return np.random.default_rng([int(seed) & 0xFFFFFFFF, int(frame), int(purpose)])


# =========================================================================== the sun
def sun_enu(day: str, solar_time_h: float, latitude_deg: float) -> NDArray[np.float64]:
    """(3,) unit vector towards the sun in east-north-up axes, from the declination of the day (Cooper's formula)
    and the hour angle of the local solar time."""
    try:
        n = _dt.date.fromisoformat(str(day)[:10]).timetuple().tm_yday
    except ValueError:
        raise SightplanError(f"the sun's date must be YYYY-MM-DD, got {day!r}") from None
    decl = math.radians(23.44) * math.sin(2 * math.pi * (284 + n) / 365.0)
    hour = math.radians(15.0 * (float(solar_time_h) - 12.0))
    lat = math.radians(float(latitude_deg))
    east = -math.cos(decl) * math.sin(hour)
    north = math.sin(decl) * math.cos(lat) - math.cos(decl) * math.cos(hour) * math.sin(lat)
    up = math.sin(decl) * math.sin(lat) + math.cos(decl) * math.cos(hour) * math.cos(lat)
    v = np.array([east, north, up])
    return v / np.linalg.norm(v)


def site_frame(metadata: dict, centre: NDArray) -> tuple[float | None, NDArray[np.float64]]:
    """(latitude° of the model's centre or None, (2,) unit model-xy vector of true north) from the model's
    georeference; (None, +Y) without one."""
    try:
        from ..geo import Georeference

        geo = Georeference.from_scene_metadata(metadata or {})
        if geo is None:
            return None, np.array([0.0, 1.0])
        lat, lon, h = geo.to_geodetic(np.asarray(centre, float).reshape(1, 3))
        north = geo.from_geodetic(lat + 1e-4, lon, h)[0] - np.asarray(centre, float)
        v = north[:2] / np.linalg.norm(north[:2])
        return float(lat[0]), v
    except Exception:  # a georeference that cannot be evaluated here (no CRS database): the defaults
        return None, np.array([0.0, 1.0])


def sun_direction(options: PhotoOptions, metadata: dict | None = None, centre: NDArray | None = None
                  ) -> tuple[NDArray[np.float64], dict]:
    """(3,) unit model-frame vector towards the sun and a record of how it was placed (latitude, elevation,
    azimuth, source)."""
    lat, north = site_frame(metadata or {}, np.zeros(3) if centre is None else centre)
    east = np.array([north[1], -north[0]])  # north turned 90° clockwise, seen from above
    if options.sun_elevation_deg is not None:
        el = math.radians(float(options.sun_elevation_deg))
        az = math.radians(float(options.sun_azimuth_deg or 0.0))
        enu = np.array([math.sin(az) * math.cos(el), math.cos(az) * math.cos(el), math.sin(el)])
        source = "set by hand"
    else:
        lat_used = options.latitude_deg if options.latitude_deg is not None else lat
        source = ("latitude given" if options.latitude_deg is not None else
                  "the model's georeference" if lat is not None else f"default latitude {DEFAULT_LATITUDE_DEG}°")
        lat = DEFAULT_LATITUDE_DEG if lat_used is None else float(lat_used)
        enu = sun_enu(options.date, options.solar_time_h, lat)
    xy = enu[0] * east + enu[1] * north
    v = np.array([xy[0], xy[1], enu[2]])
    v /= np.linalg.norm(v)
    record = {"direction": v.round(6).tolist(), "elevation_deg": round(math.degrees(math.asin(enu[2])), 3),
              "azimuth_deg": round(math.degrees(math.atan2(enu[0], enu[1])) % 360, 3), "source": source,
              "latitude_deg": None if options.sun_elevation_deg is not None else lat}
    return v, record


# =========================================================================== the lens
def distort(x: NDArray, y: NDArray, k: tuple[float, float, float, float]) -> tuple[NDArray, NDArray]:
    """OpenCV's (and COLMAP's ``OPENCV``) radial-tangential model on normalised image coordinates."""
    k1, k2, p1, p2 = k
    r2 = x * x + y * y
    radial = 1 + k1 * r2 + k2 * r2 * r2
    return (x * radial + 2 * p1 * x * y + p2 * (r2 + 2 * x * x),
            y * radial + p1 * (r2 + 2 * y * y) + 2 * p2 * x * y)


def undistort(xd: NDArray, yd: NDArray, k: tuple[float, float, float, float], iterations: int = 40
              ) -> tuple[NDArray, NDArray]:
    """The normalised coordinates that :func:`distort` takes to (xd, yd): Newton's method on the 2×2 Jacobian,
    from the distorted point (converges to 1e-12 for the distortions of real lenses within the image)."""
    k1, k2, p1, p2 = k
    x, y = np.array(xd, float), np.array(yd, float)
    for _ in range(iterations):
        fx, fy = distort(x, y, k)
        ex, ey = fx - xd, fy - yd
        r2 = x * x + y * y
        radial = 1 + k1 * r2 + k2 * r2 * r2
        d_radial = 2 * k1 + 4 * k2 * r2  # d(radial)/d(r2) · 2
        a = radial + x * d_radial * x + 2 * p1 * y + 6 * p2 * x
        b = x * d_radial * y + 2 * p1 * x + 2 * p2 * y
        c = y * d_radial * x + 2 * p1 * x + 2 * p2 * y
        d = radial + y * d_radial * y + 6 * p1 * y + 2 * p2 * x
        det = a * d - b * c
        det = np.where(np.abs(det) < 1e-12, 1e-12, det)
        x = x - (d * ex - b * ey) / det
        y = y - (-c * ex + a * ey) / det
        if max(float(np.abs(ex).max(initial=0)), float(np.abs(ey).max(initial=0))) < 1e-13:
            break
    return x, y


def lens_directions(cam, R: NDArray, k: tuple[float, float, float, float] | None) -> NDArray[np.float32]:
    """(H·W, 3) unit world directions of the pixel centres of pinhole ``cam`` (world-from-camera ``R``) seen
    through the distortion ``k``: the ray of pixel (u, v) is the undistorted point of (u + ½, v + ½)."""
    u = (np.arange(cam.width) + 0.5 - cam.cx) / cam.fx
    v = (np.arange(cam.height) + 0.5 - cam.cy) / cam.fy
    xd, yd = np.meshgrid(u, v)
    if k is not None:
        xd, yd = undistort(xd.ravel(), yd.ravel(), k)
    d = np.stack([np.ravel(xd), np.ravel(yd), np.ones(xd.size)], axis=1)
    d /= np.linalg.norm(d, axis=1, keepdims=True)
    return np.ascontiguousarray(d @ np.asarray(R, float).T, np.float32)


def project(cam, R: NDArray, C: NDArray, points: NDArray, k: tuple[float, float, float, float] | None
            ) -> NDArray[np.float64]:
    """(n, 2) pixel positions (pixel centres at +½) of world ``points`` in pinhole ``cam`` through distortion ``k``."""
    x = (np.asarray(points, float) - np.asarray(C, float)) @ np.asarray(R, float)
    xn, yn = x[:, 0] / x[:, 2], x[:, 1] / x[:, 2]
    if k is not None:
        xn, yn = distort(xn, yn, k)
    return np.stack([cam.fx * xn + cam.cx, cam.fy * yn + cam.cy], axis=1)


# =========================================================================== the sensor
def to_srgb(linear: NDArray) -> NDArray:
    """Linear light in 0..1 → sRGB-encoded 0..1."""
    x = np.clip(linear, 0.0, 1.0)
    return np.where(x <= 0.0031308, 12.92 * x, 1.055 * np.power(x, 1 / 2.4) - 0.055)


def to_linear(srgb: NDArray) -> NDArray:
    """sRGB-encoded 0..1 → linear light."""
    x = np.clip(np.asarray(srgb, float), 0.0, 1.0)
    return np.where(x <= 0.04045, x / 12.92, np.power((x + 0.055) / 1.055, 2.4))


def exposure_and_balance(options: PhotoOptions, frame: int, luminance: NDArray) -> tuple[float, NDArray]:
    """(exposure gain, (3,) white-balance gains) of one frame: an auto exposure that takes the frame's mean
    luminance to 0.18, off by a seeded N(0, exposure_ev_sd) EV, and red and blue gains off by N(0,
    white_balance_sd) (green fixed)."""
    rng = frame_rng(options.seed, frame, 1)
    ev, wr, wb = rng.normal(0.0, 1.0, 3)
    mean = float(np.mean(luminance)) if luminance.size else 0.18
    gain = 0.18 / max(mean, 1e-3) * 2.0 ** (options.exposure_ev_sd * ev)
    return gain, np.array([1 + options.white_balance_sd * wr, 1.0, 1 + options.white_balance_sd * wb])


def sensor_noise(options: PhotoOptions, frame: int, linear: NDArray) -> NDArray:
    """Linear 0..1 signal with shot noise (Poisson, by its Gaussian of variance = electrons) and read noise
    (Gaussian, read_noise_e) of a sensor with full_well_e electrons at white; seeded per frame."""
    rng = frame_rng(options.seed, frame, 2)
    e = np.clip(linear, 0.0, 1.0) * options.full_well_e
    sd = np.sqrt(e + options.read_noise_e**2)
    return (e + sd * rng.standard_normal(e.shape)) / options.full_well_e


def blur_kernel(dx: float, dy: float) -> NDArray[np.float64] | None:
    """A normalised line kernel of the image motion (dx, dy) px during the exposure (a box along the segment,
    drawn with bilinear weights), or None when the motion is under a quarter pixel."""
    length = math.hypot(dx, dy)
    if length < 0.25:
        return None
    half = int(math.ceil(length / 2)) + 1
    k = np.zeros((2 * half + 1, 2 * half + 1))
    n = max(2, int(math.ceil(4 * length)) + 1)
    for s in np.linspace(-0.5, 0.5, n):
        x, y = half + s * dx, half + s * dy
        x0, y0 = int(math.floor(x)), int(math.floor(y))
        fx, fy = x - x0, y - y0
        k[y0, x0] += (1 - fx) * (1 - fy)
        k[y0, x0 + 1] += fx * (1 - fy)
        k[y0 + 1, x0] += (1 - fx) * fy
        k[y0 + 1, x0 + 1] += fx * fy
    return k / k.sum()


def motion_blur(image: NDArray, kernel: NDArray | None) -> NDArray:
    """(H, W, 3) image convolved with ``kernel`` channel by channel (edges repeated)."""
    if kernel is None:
        return image
    from scipy.ndimage import convolve

    return np.stack([convolve(image[:, :, c], kernel, mode="nearest") for c in range(image.shape[2])], axis=2)


def image_motion(cam, R: NDArray, velocity: NDArray, depth: float, shutter_s: float) -> tuple[float, float]:
    """(dx, dy) pixels a surface at ``depth`` m moves in the image while the shutter is open, for a camera moving
    at ``velocity`` m/s (world): the velocity's component across the view, times f / depth."""
    if not (math.isfinite(depth) and depth > 0):
        return 0.0, 0.0
    v = np.asarray(velocity, float) @ np.asarray(R, float)  # camera axes
    return float(-cam.fx * v[0] / depth * shutter_s), float(-cam.fy * v[1] / depth * shutter_s)


def path_velocities(C: NDArray, speed_m_s: float, max_step_m: float = 50.0) -> NDArray[np.float64]:
    """(n, 3) velocity of the camera at each frame: ``speed_m_s`` along the path through the frames (central
    differences; zero where a frame has no neighbour within ``max_step_m``, a hop between missions)."""
    C = np.asarray(C, float)
    n = len(C)
    out = np.zeros((n, 3))
    for i in range(n):
        a = C[i - 1] if i > 0 and np.linalg.norm(C[i] - C[i - 1]) < max_step_m else C[i]
        b = C[i + 1] if i + 1 < n and np.linalg.norm(C[i + 1] - C[i]) < max_step_m else C[i]
        d = b - a
        norm = np.linalg.norm(d)
        if norm > 1e-9:
            out[i] = speed_m_s * d / norm
    return out


def vignette(cam, strength: float) -> NDArray[np.float64]:
    """(H, W) gain: 1 at the principal point, 1 − strength at the image's farthest corner, quadratic in between."""
    u = np.arange(cam.width) + 0.5 - cam.cx
    v = np.arange(cam.height) + 0.5 - cam.cy
    r2 = u[None, :] ** 2 + v[:, None] ** 2
    corner = max(cam.cx, cam.width - cam.cx) ** 2 + max(cam.cy, cam.height - cam.cy) ** 2
    return 1.0 - strength * r2 / corner
