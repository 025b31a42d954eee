"""A project's own map background: a drone orthomosaic (GeoTIFF) or raster tiles (MBTiles) uploaded to the project,
drawn under the site on the page's map instead of the server's basemap.

- A GeoTIFF is read with tifffile: its georeference from the GeoTIFF tags (tie point and pixel scale, or the model
  transformation; the CRS by its EPSG code), its pixels reduced to at most :data:`MAX_SIDE_PX` a side (the overview
  of a cloud-optimised file when it has one, else every n-th pixel) and written as one PNG, which the map stretches
  over the image's four corners in latitude/longitude.
- An MBTiles file (SQLite) is served tile by tile as it is: PNG, JPEG or WebP raster tiles; its ``bounds`` place it.
"""

from __future__ import annotations

import json
import math
import sqlite3
from pathlib import Path
from typing import Any

import numpy as np

from ..errors import SightplanError

MAX_SIDE_PX = 4096
SUFFIXES = (".tif", ".tiff", ".mbtiles")
TILE_MEDIA = {"png": "image/png", "jpg": "image/jpeg", "jpeg": "image/jpeg", "webp": "image/webp"}


class BasemapError(SightplanError):
    """An uploaded map background that cannot be used, with the reason."""


def _corners_geotiff(tif, width: int, height: int) -> list[list[float]]:
    """[lon, lat] of the image's top-left, top-right, bottom-right and bottom-left corners."""
    from pyproj import CRS, Transformer
    from pyproj.exceptions import CRSError

    geo = tif.geotiff_metadata or {}
    if "ModelTransformation" in geo:
        M = np.asarray(geo["ModelTransformation"], float).reshape(4, 4)
        to_map = lambda i, j: (M[0, 0] * i + M[0, 1] * j + M[0, 3], M[1, 0] * i + M[1, 1] * j + M[1, 3])  # noqa: E731
    elif "ModelPixelScale" in geo and "ModelTiepoint" in geo:
        sx, sy = np.asarray(geo["ModelPixelScale"], float)[:2]
        ti, tj, _, tx, ty = np.asarray(geo["ModelTiepoint"], float)[:5]
        to_map = lambda i, j: (tx + (i - ti) * sx, ty - (j - tj) * sy)  # noqa: E731
    else:
        raise BasemapError("the GeoTIFF has no georeference (no tie point and pixel scale, no model transformation): "
                           "export the orthomosaic as a GeoTIFF with its coordinate system")
    code = geo.get("ProjectedCSTypeGeoKey") or geo.get("GeographicTypeGeoKey")
    code = getattr(code, "value", code)
    if not isinstance(code, int) or code in (0, 32767):
        raise BasemapError("the GeoTIFF's coordinate system has no EPSG code (a user-defined one): export it in a "
                           "registered CRS such as its UTM zone")
    try:
        transformer = Transformer.from_crs(CRS.from_epsg(code), "EPSG:4326", always_xy=True)
    except CRSError as exc:
        raise BasemapError(f"the GeoTIFF's EPSG:{code} is unknown: {exc}") from None
    out = []
    for i, j in ((0, 0), (width, 0), (width, height), (0, height)):
        lon, lat = transformer.transform(*to_map(i, j))
        if not (math.isfinite(lon) and math.isfinite(lat) and -90 <= lat <= 90):
            raise BasemapError(f"the GeoTIFF's corner ({i}, {j}) px lies off the earth in EPSG:{code}")
        out.append([float(lon), float(lat)])
    return out


def _pixels(tif) -> tuple[np.ndarray, int, int]:
    """The image at most MAX_SIDE_PX a side as uint8 RGB(A), and the full size (width, height)."""
    series = tif.series[0]
    height, width = series.shape[0], series.shape[1]
    if series.ndim == 3 and series.shape[0] <= 4 < series.shape[2]:  # planar: bands first
        height, width = series.shape[1], series.shape[2]
    level = next((lv for lv in series.levels if max(lv.shape[:2]) <= MAX_SIDE_PX), None)
    data = level.asarray() if level is not None else series.asarray(out="memmap")
    if data.ndim == 3 and data.shape[0] <= 4 < data.shape[2]:
        data = np.moveaxis(data, 0, -1)
    step = max(1, math.ceil(max(data.shape[:2]) / MAX_SIDE_PX))
    data = np.asarray(data[::step, ::step])
    if data.ndim == 2:
        data = data[..., None]
    if data.shape[2] not in (1, 3, 4):
        data = data[..., :3]
    if data.dtype != np.uint8:  # 16-bit or float bands: stretched to the 2nd–98th percentile
        lo, hi = np.nanpercentile(data[..., :3], [2, 98])
        data = np.clip((data.astype(float) - lo) / max(hi - lo, 1e-9) * 255, 0, 255).astype(np.uint8)
    if data.shape[2] == 1:
        data = np.repeat(data, 3, axis=2)
    return data, int(width), int(height)


def prepare_geotiff(source: Path, folder: Path) -> dict[str, Any]:
    """``folder/image.png`` and the description of a GeoTIFF orthomosaic."""
    import tifffile
    from PIL import Image

    try:
        with tifffile.TiffFile(source) as tif:
            if not tif.is_geotiff:
                raise BasemapError("the TIFF has no GeoTIFF tags: export the orthomosaic as a GeoTIFF")
            pixels, width, height = _pixels(tif)
            corners = _corners_geotiff(tif, width, height)
    except (tifffile.TiffFileError, ValueError, OSError) as exc:
        raise BasemapError(f"the file is not a readable TIFF: {exc}") from None
    Image.fromarray(pixels).save(folder / "image.png", optimize=False)
    return {"kind": "image", "corners": corners, "width_px": width, "height_px": height,
            "shown_px": [int(pixels.shape[1]), int(pixels.shape[0])]}


def prepare_mbtiles(source: Path) -> dict[str, Any]:
    """The description of an MBTiles file of raster tiles (refused: vector tiles, no tiles, not SQLite)."""
    try:
        with sqlite3.connect(f"file:{source}?mode=ro", uri=True) as db:
            meta = dict(db.execute("SELECT name, value FROM metadata").fetchall())
            zooms = db.execute("SELECT MIN(zoom_level), MAX(zoom_level), COUNT(*) FROM tiles").fetchone()
    except sqlite3.DatabaseError as exc:
        raise BasemapError(f"the file is not an MBTiles database (SQLite with 'metadata' and 'tiles'): {exc}") from None
    fmt = str(meta.get("format", "png")).lower()
    if fmt not in TILE_MEDIA:
        raise BasemapError(f"the MBTiles holds {fmt!r} tiles; the map draws raster tiles: png, jpg or webp")
    if not zooms or not zooms[2]:
        raise BasemapError("the MBTiles holds no tiles")
    bounds = None
    try:
        bounds = [float(v) for v in str(meta["bounds"]).split(",")]
        if len(bounds) != 4 or not all(math.isfinite(v) for v in bounds):
            bounds = None
    except (KeyError, ValueError):
        bounds = None
    return {"kind": "tiles", "format": fmt, "min_zoom": int(zooms[0]), "max_zoom": int(zooms[1]), "bounds": bounds,
            "attribution": str(meta.get("attribution", ""))[:300], "name": str(meta.get("name", ""))[:200]}


def prepare(source: Path, folder: Path, original_name: str) -> dict[str, Any]:
    """Prepare an uploaded map background in ``folder`` (which then holds it and ``basemap.json``)."""
    folder.mkdir(parents=True, exist_ok=True)
    if source.suffix.lower() == ".mbtiles":
        target = folder / "tiles.mbtiles"
        source.replace(target)
        info = prepare_mbtiles(target)
    else:
        info = prepare_geotiff(source, folder)
        source.unlink(missing_ok=True)
    info["name"] = info.get("name") or original_name
    (folder / "basemap.json").write_text(json.dumps(info), encoding="utf-8")
    return info


def read_info(folder: Path) -> dict[str, Any] | None:
    path = folder / "basemap.json"
    return json.loads(path.read_text(encoding="utf-8")) if path.is_file() else None


def read_tile(folder: Path, z: int, x: int, y: int) -> bytes | None:
    """One tile of the project's MBTiles (XYZ numbering; the file's rows count from the south), or None."""
    path = folder / "tiles.mbtiles"
    if not path.is_file() or not (0 <= z <= 30 and 0 <= x < 2**z and 0 <= y < 2**z):
        return None
    with sqlite3.connect(f"file:{path}?mode=ro", uri=True) as db:
        row = db.execute("SELECT tile_data FROM tiles WHERE zoom_level=? AND tile_column=? AND tile_row=?",
                         (z, x, 2**z - 1 - y)).fetchone()
    return bytes(row[0]) if row else None
