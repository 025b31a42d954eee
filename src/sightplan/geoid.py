"""Heights above sea level ↔ WGS84 ellipsoidal heights, with the EGM96 geoid.

A model's heights (IfcSite RefElevation, IfcMapConversion OrthogonalHeight, ``--origin``'s
height) are above sea level: orthometric heights H in a national vertical datum. GNSS receivers,
GeoJSON (RFC 7946 §4) and DJI's ``takeOffRefPoint`` and ``WGS84`` heights are ellipsoidal heights h
above the WGS84 ellipsoid. The two differ by the geoid undulation N at that place, h = H + N, with
N between about −107 m and +86 m over the Earth (+47.9 m at Karlsruhe, −29.9 m in New York).

N comes from NGA's EGM96 model on its 15′ grid, as the PROJ-data project distributes it
(``us_nga_egm96_15.tif``), read by pyproj's ``vgridshift`` with bilinear interpolation: within a
few centimetres of the spherical-harmonic model. Debian's ``proj-data`` package installs the grid
in ``/usr/share/proj`` (``apt-get install proj-data``); it is looked for there, in pyproj's own
data folder, in ``$PROJ_DATA``/``$PROJ_LIB`` and in pyproj's user data folder, or taken from
``$SIGHTPLAN_GEOID_GRID`` (a file path). Nothing is downloaded.

A national datum (NAP, DHHN2016, NAVD88…) differs from EGM96's zero by up to about a metre; so
an ellipsoidal height from it is good to about a metre, which is the accuracy of a GNSS
take-off reference anyway.
"""

from __future__ import annotations

import os
from functools import lru_cache
from pathlib import Path

import numpy as np
from numpy.typing import ArrayLike, NDArray

from .errors import SightplanError

GRID_NAMES = ("us_nga_egm96_15.tif", "egm96_15.gtx")
SYSTEM_DIRS = ("/usr/share/proj", "/usr/local/share/proj")
INSTALL_HINT = ("install Debian's proj-data package (apt-get install proj-data), which puts the EGM96 grid "
                f"{GRID_NAMES[0]} in /usr/share/proj, or set SIGHTPLAN_GEOID_GRID to that file")


class GeoidError(SightplanError):
    """The geoid grid is missing, or a point lies outside it."""


def _search_dirs() -> list[Path]:
    import pyproj.datadir

    dirs: list[str] = []
    for text in (pyproj.datadir.get_data_dir(), os.environ.get("PROJ_DATA"), os.environ.get("PROJ_LIB")):
        if text:
            dirs += text.split(os.pathsep)
    try:
        dirs.append(pyproj.datadir.get_user_data_dir())
    except Exception:  # noqa: BLE001  (an unwritable home: no user folder to look in)
        pass
    dirs += SYSTEM_DIRS
    return [Path(d) for d in dict.fromkeys(dirs) if d]


def grid_path() -> Path | None:
    """The EGM96 grid file found (see the module docstring), or None."""
    return _find_grid(os.environ.get("SIGHTPLAN_GEOID_GRID"))


@lru_cache(maxsize=4)
def _find_grid(explicit: str | None) -> Path | None:
    """The folders are searched once per process (every exported frame asks)."""
    if explicit:
        return Path(explicit) if Path(explicit).is_file() else None
    for d in _search_dirs():
        for name in GRID_NAMES:
            if (d / name).is_file():
                return d / name
    return None


def available() -> bool:
    """Whether the geoid grid is installed."""
    return grid_path() is not None


@lru_cache(maxsize=4)
def _transformer(path: str):
    from pyproj import Transformer
    from pyproj.exceptions import ProjError

    if any(c.isspace() for c in path):
        raise GeoidError(f"the geoid grid's path {path!r} has a space, which PROJ cannot read: move it or link it")
    try:
        return Transformer.from_pipeline(
            "+proj=pipeline +step +proj=unitconvert +xy_in=deg +xy_out=rad "
            f"+step +proj=vgridshift +grids={path} +multiplier=1 "
            "+step +proj=unitconvert +xy_in=rad +xy_out=deg")
    except ProjError as exc:
        raise GeoidError(f"cannot read the geoid grid {path}: {exc}") from None


def undulation(latitude_deg: ArrayLike, longitude_deg: ArrayLike) -> NDArray[np.float64]:
    """EGM96 geoid undulation N (metres, the geoid above the WGS84 ellipsoid) at each point; raises
    :class:`GeoidError` naming what to install when the grid is missing."""
    path = grid_path()
    if path is None:
        raise GeoidError(f"WGS84 ellipsoidal heights need the EGM96 geoid and it is not installed: {INSTALL_HINT}")
    lat = np.atleast_1d(np.asarray(latitude_deg, float))
    lon = np.atleast_1d(np.asarray(longitude_deg, float))
    if not (np.isfinite(lat).all() and np.isfinite(lon).all()) or (np.abs(lat) > 90).any():
        raise GeoidError("a latitude or longitude for the geoid is not a finite number in range")
    lon = (lon + 180.0) % 360.0 - 180.0
    _, _, z = _transformer(str(path)).transform(lon, lat, np.zeros_like(lat))
    n = np.asarray(z, float)
    if not np.isfinite(n).all() or (np.abs(n) > 200).any():
        raise GeoidError(f"the geoid grid {path} gives no undulation at latitude {float(lat[0]):.6f}, "
                         f"longitude {float(lon[0]):.6f}")
    return n


def to_ellipsoidal(latitude_deg: ArrayLike, longitude_deg: ArrayLike, height_m: ArrayLike) -> NDArray[np.float64]:
    """Heights above sea level (EGM96, or a national datum close to it) → WGS84 ellipsoidal heights: h = H + N."""
    return np.atleast_1d(np.asarray(height_m, float)) + undulation(latitude_deg, longitude_deg)


def to_orthometric(latitude_deg: ArrayLike, longitude_deg: ArrayLike, height_m: ArrayLike) -> NDArray[np.float64]:
    """WGS84 ellipsoidal heights → heights above sea level (EGM96): H = h − N."""
    return np.atleast_1d(np.asarray(height_m, float)) - undulation(latitude_deg, longitude_deg)


__all__ = ["GRID_NAMES", "GeoidError", "available", "grid_path", "to_ellipsoidal", "to_orthometric",
           "undulation"]
