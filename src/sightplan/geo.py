"""Georeferencing: the model's local metric frame ↔ WGS84 latitude, longitude and height.

Two kinds, both exact to the millimetre over a building site:

- ``projected``: an IfcMapConversion (or IFC2X3's ``ePSet_MapConversion``) into a projected
  CRS such as EPSG:28992 or a UTM zone. Model metres (x, y, z) go to map coordinates
  E = E0 + s·(a·x − b·y), N = N0 + s·(b·x + a·y), H = H0 + z, where (a, b) is the unit
  direction of the model's +X in the map grid (XAxisAbscissa, XAxisOrdinate) and s the
  scale; pyproj then takes (E, N) to latitude and longitude. H is the height in the map's
  vertical datum (above mean sea level for a national datum).
- ``topocentric``: a local east-north-up plane at a known latitude, longitude and height
  (IfcSite's RefLatitude/RefLongitude/RefElevation and the context's TrueNorth, an OpenSfM
  ``reference_lla``, or an origin the user gives). The model point ``origin_m`` sits at that
  latitude and longitude, and model +Y points ``north_deg`` clockwise from true north.

Headings: a model heading (clockwise from model +Y) becomes a true heading (clockwise from
true north) by adding :meth:`Georeference.north_offset_deg` at that point, which includes a
projected CRS's grid convergence.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from functools import cached_property
from typing import Any, Literal

import numpy as np
from numpy.typing import ArrayLike, NDArray

from .errors import SightplanError

Kind = Literal["projected", "topocentric"]


class GeoreferenceError(SightplanError):
    """A georeference is missing, incomplete or names an unknown coordinate reference system."""


def _finite(name: str, value: Any) -> float:
    try:
        v = float(value)
    except (TypeError, ValueError):
        raise GeoreferenceError(f"georeference {name} must be a number, got {value!r}") from None
    if not math.isfinite(v):
        raise GeoreferenceError(f"georeference {name} must be finite, got {value!r}")
    return v


@dataclass(frozen=True, eq=False)
class Georeference:
    """Where the model's local frame lies on the Earth; see the module docstring.

    projected: ``crs`` (anything pyproj reads: 'EPSG:28992', WKT), ``eastings_m``,
    ``northings_m``, ``height_m`` (H0), ``x_axis`` (abscissa, ordinate), ``scale``.
    topocentric: ``latitude_deg``, ``longitude_deg``, ``height_m``, ``north_deg``, ``origin_m``.
    ``source`` says where it came from (shown to the user).
    """

    kind: Kind
    source: str
    height_m: float = 0.0
    crs: str | None = None
    eastings_m: float = 0.0
    northings_m: float = 0.0
    x_axis: tuple[float, float] = (1.0, 0.0)
    scale: float = 1.0
    latitude_deg: float = 0.0
    longitude_deg: float = 0.0
    north_deg: float = 0.0
    origin_m: tuple[float, float, float] = (0.0, 0.0, 0.0)

    def __post_init__(self) -> None:
        if self.kind == "projected":
            if not self.crs:
                raise GeoreferenceError("a map conversion without a target CRS: set IfcProjectedCRS.Name (e.g. 'EPSG:28992')")
            a, b = (_finite("x axis", v) for v in self.x_axis)
            if math.hypot(a, b) == 0:
                raise GeoreferenceError("the map conversion's x axis (XAxisAbscissa, XAxisOrdinate) is a zero vector")
            if not _finite("scale", self.scale) > 0:
                raise GeoreferenceError(f"the map conversion's scale must be positive, got {self.scale}")
            for k in ("eastings_m", "northings_m", "height_m"):
                _finite(k, getattr(self, k))
            self.transformer  # noqa: B018  (an unknown CRS fails here, with its name)
        elif self.kind == "topocentric":
            lat, lon = _finite("latitude", self.latitude_deg), _finite("longitude", self.longitude_deg)
            if not (-90 <= lat <= 90 and -180 <= lon <= 360):
                raise GeoreferenceError(f"latitude {lat} / longitude {lon} out of range")
            for k in ("height_m", "north_deg"):
                _finite(k, getattr(self, k))
            if len(self.origin_m) != 3:
                raise GeoreferenceError("the georeference origin must be a point (x, y, z)")
            for v in self.origin_m:
                _finite("origin", v)
        else:
            raise GeoreferenceError(f"unknown georeference kind {self.kind!r}")

    # ---- constructors -------------------------------------------------------------------------

    @classmethod
    def from_origin(cls, latitude_deg: float, longitude_deg: float, height_m: float = 0.0, north_deg: float = 0.0,
                    origin_m: ArrayLike = (0.0, 0.0, 0.0), source: str = "user origin") -> Georeference:
        """The model point ``origin_m`` at the given latitude/longitude/height, model +Y ``north_deg`` from true north."""
        return cls("topocentric", source, height_m=float(height_m), latitude_deg=float(latitude_deg),
                   longitude_deg=float(longitude_deg), north_deg=float(north_deg) % 360.0,
                   origin_m=tuple(float(v) for v in np.asarray(origin_m, float).reshape(3)))

    @classmethod
    def from_map_conversion(cls, crs: str, eastings_m: float, northings_m: float, height_m: float = 0.0,
                            x_axis_abscissa: float = 1.0, x_axis_ordinate: float = 0.0, scale: float = 1.0,
                            source: str = "IfcMapConversion") -> Georeference:
        return cls("projected", source, height_m=float(height_m), crs=str(crs), eastings_m=float(eastings_m),
                   northings_m=float(northings_m), x_axis=(float(x_axis_abscissa), float(x_axis_ordinate)), scale=float(scale))

    @classmethod
    def from_scene_metadata(cls, metadata: dict) -> Georeference | None:
        """The georeference a loaded model carries: its map conversion, else its site's latitude/longitude, else None."""
        conv = metadata.get("georeference")
        if conv:
            if not conv.get("target_crs"):
                raise GeoreferenceError(f"the model's {conv.get('source', 'map conversion')} names no target CRS: "
                                        "set IfcProjectedCRS.Name (e.g. 'EPSG:28992'), or give --origin")
            return cls.from_map_conversion(conv["target_crs"], conv["eastings_m"], conv["northings_m"],
                                           conv.get("orthogonal_height_m") or 0.0, conv.get("x_axis_abscissa", 1.0),
                                           conv.get("x_axis_ordinate", 0.0), conv.get("scale", 1.0),
                                           source=conv.get("source", "IfcMapConversion"))
        site = metadata.get("site_location")
        if site and site.get("latitude_deg") is not None and site.get("longitude_deg") is not None:
            return cls.from_origin(site["latitude_deg"], site["longitude_deg"], site.get("elevation_m") or 0.0,
                                   site.get("true_north_deg") or 0.0, site.get("origin_m") or (0.0, 0.0, 0.0),
                                   source="IfcSite reference latitude/longitude")
        return None

    @classmethod
    def from_dict(cls, d: dict) -> Georeference:
        """Read :meth:`to_dict`'s form, or an OpenSfM ``{"reference_lla": {latitude, longitude, altitude}}``."""
        if not isinstance(d, dict):
            raise GeoreferenceError("a georeference must be an object")
        if "reference_lla" in d:
            lla = d["reference_lla"] or {}
            return cls.from_origin(lla.get("latitude"), lla.get("longitude"), lla.get("altitude") or 0.0,
                                   source="OpenSfM reference_lla")
        kind = d.get("kind")
        try:
            if kind == "projected":
                return cls.from_map_conversion(d["crs"], d["eastings_m"], d["northings_m"], d.get("height_m", 0.0),
                                               *d.get("x_axis", (1.0, 0.0)), d.get("scale", 1.0), d.get("source", "plan file"))
            if kind == "topocentric":
                return cls.from_origin(d["latitude_deg"], d["longitude_deg"], d.get("height_m", 0.0), d.get("north_deg", 0.0),
                                       d.get("origin_m", (0.0, 0.0, 0.0)), d.get("source", "plan file"))
        except KeyError as exc:
            raise GeoreferenceError(f"the {kind} georeference lacks {exc.args[0]!r}") from None
        raise GeoreferenceError(f"unknown georeference kind {kind!r} (expected 'projected' or 'topocentric')")

    def to_dict(self) -> dict:
        if self.kind == "projected":
            return {"kind": "projected", "source": self.source, "crs": self.crs, "eastings_m": self.eastings_m,
                    "northings_m": self.northings_m, "height_m": self.height_m, "x_axis": list(self.x_axis),
                    "scale": self.scale}
        return {"kind": "topocentric", "source": self.source, "latitude_deg": self.latitude_deg,
                "longitude_deg": self.longitude_deg, "height_m": self.height_m, "north_deg": self.north_deg,
                "origin_m": list(self.origin_m)}

    def describe(self) -> str:
        if self.kind == "projected":
            return f"{self.crs} E {self.eastings_m:.2f} N {self.northings_m:.2f} H {self.height_m:.2f} ({self.source})"
        return (f"{self.latitude_deg:.7f}°, {self.longitude_deg:.7f}°, {self.height_m:.2f} m, "
                f"model +Y at {self.north_deg:.2f}° from north ({self.source})")

    # ---- transforms ---------------------------------------------------------------------------

    @cached_property
    def transformer(self):
        """pyproj transformer to WGS84: projected (E, N) → (lon, lat), or topocentric (E, N, U) → (lon, lat, h)."""
        from pyproj import CRS, Transformer
        from pyproj.exceptions import CRSError, ProjError

        try:
            if self.kind == "projected":
                crs = CRS.from_user_input(self.crs)
                if crs.is_compound:  # e.g. EPSG:7415 (RD New + NAP height): the height is H0 + z already
                    crs = crs.sub_crs_list[0]
                if not crs.is_projected:
                    raise GeoreferenceError(f"the map conversion's CRS {self.crs!r} is not a projected CRS")
                return Transformer.from_crs(crs, "EPSG:4326", always_xy=True)
            return Transformer.from_pipeline(
                "+proj=pipeline +step +inv +proj=topocentric +ellps=WGS84 "
                f"+lat_0={self.latitude_deg!r} +lon_0={self.longitude_deg!r} +h_0={self.height_m!r} "
                "+step +inv +proj=cart +ellps=WGS84 +step +proj=unitconvert +xy_in=rad +xy_out=deg")
        except (CRSError, ProjError) as exc:
            raise GeoreferenceError(f"unknown coordinate reference system {self.crs!r}: {exc}") from None

    def _to_plane(self, xyz: NDArray) -> NDArray:
        """(n, 3) model metres → (n, 3) map (E, N, H) or local (east, north, up) metres."""
        if self.kind == "projected":
            a, b = np.asarray(self.x_axis) / math.hypot(*self.x_axis)
            x, y = xyz[:, 0], xyz[:, 1]
            return np.stack([self.eastings_m + self.scale * (a * x - b * y),
                             self.northings_m + self.scale * (b * x + a * y), self.height_m + xyz[:, 2]], axis=1)
        t = math.radians(self.north_deg)
        d = xyz - np.asarray(self.origin_m)
        return np.stack([d[:, 0] * math.cos(t) + d[:, 1] * math.sin(t),
                         -d[:, 0] * math.sin(t) + d[:, 1] * math.cos(t), d[:, 2]], axis=1)

    def _from_plane(self, p: NDArray) -> NDArray:
        if self.kind == "projected":
            a, b = np.asarray(self.x_axis) / math.hypot(*self.x_axis)
            e, n = (p[:, 0] - self.eastings_m) / self.scale, (p[:, 1] - self.northings_m) / self.scale
            return np.stack([a * e + b * n, -b * e + a * n, p[:, 2] - self.height_m], axis=1)
        t = math.radians(self.north_deg)
        x = p[:, 0] * math.cos(t) - p[:, 1] * math.sin(t)
        y = p[:, 0] * math.sin(t) + p[:, 1] * math.cos(t)
        return np.stack([x, y, p[:, 2]], axis=1) + np.asarray(self.origin_m)

    def to_geodetic(self, xyz: ArrayLike) -> tuple[NDArray[np.float64], NDArray[np.float64], NDArray[np.float64]]:
        """(n, 3) model metres → (latitude°, longitude°, height m), each (n,). The height is in the
        georeference's own datum: the map's vertical datum, or the reference height's."""
        P = self._to_plane(np.asarray(xyz, float).reshape(-1, 3))
        if self.kind == "projected":
            lon, lat = self.transformer.transform(P[:, 0], P[:, 1])
            h = P[:, 2]
        else:
            lon, lat, h = self.transformer.transform(P[:, 0], P[:, 1], P[:, 2])
        return np.asarray(lat, float), np.asarray(lon, float), np.asarray(h, float)

    def from_geodetic(self, lat: ArrayLike, lon: ArrayLike, height: ArrayLike) -> NDArray[np.float64]:
        """(n,) latitude°, longitude°, height m → (n, 3) model metres (the inverse of :meth:`to_geodetic`)."""
        from pyproj.enums import TransformDirection

        lat, lon, h = (np.atleast_1d(np.asarray(v, float)) for v in (lat, lon, height))
        if not (np.isfinite(lat).all() and np.isfinite(lon).all() and np.isfinite(h).all()):
            raise GeoreferenceError("a latitude, longitude or height is not a finite number")
        inverse = TransformDirection.INVERSE
        if self.kind == "projected":
            e, n = self.transformer.transform(lon, lat, direction=inverse)
            P = np.stack([e, n, h], axis=1)
        else:
            e, n, u = self.transformer.transform(lon, lat, h, direction=inverse)
            P = np.stack([e, n, u], axis=1)
        return self._from_plane(np.asarray(P, float))

    def height_at(self, latitude_deg: float, longitude_deg: float, z_m: float, near_height_m: float = 0.0) -> float:
        """The height, in the georeference's datum, of model height ``z_m`` under (or over) a latitude/longitude:
        the model (x, y) of that point at ``near_height_m``, taken to model height ``z_m``."""
        x, y, _ = self.from_geodetic(latitude_deg, longitude_deg, near_height_m)[0]
        return float(self.to_geodetic([x, y, z_m])[2][0])

    def north_offset_deg(self, xyz: ArrayLike) -> NDArray[np.float64]:
        """(n,) degrees to add to a model heading at each point to get the true heading
        (the true azimuth of model +Y there, measured on the WGS84 ellipsoid)."""
        from pyproj import Geod

        P = np.asarray(xyz, float).reshape(-1, 3)
        lat0, lon0, _ = self.to_geodetic(P)
        lat1, lon1, _ = self.to_geodetic(P + [0.0, 1.0, 0.0])
        azimuth, _, _ = Geod(ellps="WGS84").inv(lon0, lat0, lon1, lat1)
        return np.asarray(azimuth, float) % 360.0

    def linear_fit(self, xy_min: ArrayLike, xy_max: ArrayLike, z_m: float = 0.0) -> dict:
        """The affine map from model (x, y) to (latitude°, longitude°) that best fits this georeference over a
        rectangle (least squares on an 11 × 11 grid at height ``z_m``), for a map that draws points it moves itself:

        ``{"origin_xy": [x0, y0], "origin_lat_lon": [lat0, lon0], "matrix": [[dlat/dx, dlat/dy], [dlon/dx, dlon/dy]],
        "max_error_m": e}``, where e is the largest distance between the fit and the exact transform on the grid."""
        from pyproj import Geod

        lo, hi = np.asarray(xy_min, float)[:2], np.asarray(xy_max, float)[:2]
        gx, gy = np.meshgrid(np.linspace(lo[0], hi[0], 11), np.linspace(lo[1], hi[1], 11))
        xy = np.stack([gx.ravel(), gy.ravel()], axis=1)
        lat, lon, _ = self.to_geodetic(np.column_stack([xy, np.full(len(xy), float(z_m))]))
        origin = (lo + hi) / 2
        A = np.column_stack([np.ones(len(xy)), xy - origin])
        (c_lat, *m_lat), *_ = np.linalg.lstsq(A, lat, rcond=None)
        (c_lon, *m_lon), *_ = np.linalg.lstsq(A, lon, rcond=None)
        fit_lat, fit_lon = A @ np.r_[c_lat, m_lat], A @ np.r_[c_lon, m_lon]
        _, _, error = Geod(ellps="WGS84").inv(lon, lat, fit_lon, fit_lat)
        return {"origin_xy": origin.tolist(), "origin_lat_lon": [float(c_lat), float(c_lon)],
                "matrix": [[float(v) for v in m_lat], [float(v) for v in m_lon]],
                "max_error_m": float(np.max(np.abs(error)))}

    def true_heading(self, xyz: ArrayLike, model_heading_deg: ArrayLike) -> NDArray[np.float64]:
        """(n,) true headings (clockwise from true north, [0, 360)) of model headings at (n, 3) points."""
        return (np.asarray(model_heading_deg, float) + self.north_offset_deg(xyz)) % 360.0

    def model_heading(self, xyz: ArrayLike, true_heading_deg: ArrayLike) -> NDArray[np.float64]:
        """(n,) model headings of true headings at (n, 3) points (inverse of :meth:`true_heading`)."""
        return (np.asarray(true_heading_deg, float) - self.north_offset_deg(xyz)) % 360.0


def resolve_georeference(*candidates: Georeference | dict | None, what: str = "this export") -> Georeference:
    """The first georeference given (objects or their dicts), or a :class:`GeoreferenceError` saying what to set."""
    for c in candidates:
        if c is None:
            continue
        return c if isinstance(c, Georeference) else Georeference.from_dict(c)
    raise GeoreferenceError(
        f"{what} needs a georeference and none was found: the model has no IfcMapConversion and its IfcSite no "
        "RefLatitude/RefLongitude, and the plan carries none. Give one with --origin LAT,LON[,HEIGHT] "
        "(and --north DEG, the true heading of the model's +Y axis), or georeference the IFC.")
