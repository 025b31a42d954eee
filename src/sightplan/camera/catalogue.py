"""The camera catalogue: named drone and 360° cameras, and OpenSfM's sensor tables.

- Built-in entries (``data/cameras.json``) carry the manufacturers' published specs.
  Pinhole entries become :class:`PinholeCamera` with square pixels
  (``fx = fy = focal_mm / sensor_width_mm · width`` px), the principal point at the image
  centre and no distortion.
- Names match case-, space- and punctuation-insensitively against each entry's id, name
  and aliases: ``"p4p"``, ``"phantom4pro"`` and ``"DJI Phantom 4 Pro"`` are one camera.
- A name the catalogue lacks is looked up as EXIF ``"Make Model"`` (``"DJI FC6540"``) in
  OpenSfM's sensor tables (``data/sensor_data*.json``, BSD-2, see the licence note there),
  which give the sensor width in mm and often the resolution; the lens focal length must
  then be given (``focal_mm=``; ``--focal-mm`` on the command line).
- :func:`search_cameras` finds cameras in both by words in any order (``"sony 7r"``).
- Cameras described by the user (a camera JSON file) are read by :mod:`.files`.
"""

from __future__ import annotations

import difflib
import json
import math
import re
from dataclasses import dataclass
from functools import lru_cache
from importlib import resources
from typing import Any, Literal

from ..errors import CameraError
from .models import Camera, CameraKind, EquirectangularCamera, PinholeCamera


@dataclass(frozen=True)
class CatalogueEntry:
    """One built-in camera.

    width, height: image size in px. focal_mm, sensor_width_mm, sensor_height_mm: lens and
    sensor in mm, None for equirectangular cameras. source: where the numbers come from.
    """

    id: str
    name: str
    kind: CameraKind
    width: int
    height: int
    focal_mm: float | None
    sensor_width_mm: float | None
    sensor_height_mm: float | None
    aliases: tuple[str, ...]
    source: str

    def camera(self, focal_mm: float | None = None) -> Camera:
        """The camera model; ``focal_mm`` replaces the lens of a pinhole entry (e.g. P1 with 24 mm)."""
        if self.kind == "equirectangular":
            if focal_mm is not None:
                raise CameraError(f"{self.name} is a 360° camera: it takes no focal_mm")
            return EquirectangularCamera(self.width, self.height, self.name)
        f = self.focal_mm if focal_mm is None else float(focal_mm)
        name = self.name if focal_mm is None else f"{self.name} ({f:g} mm)"
        return PinholeCamera.from_sensor(self.sensor_width_mm, f, self.width, self.height, name=name)


@dataclass(frozen=True)
class SensorInfo:
    """A row of OpenSfM's sensor tables.

    key: the table's ``"Make Model"``. sensor_width_mm, sensor_height_mm: sensor size in mm
    (height None where only the short table knows the camera). width, height: the
    sensor's resolution in px, None where unknown.
    """

    key: str
    sensor_width_mm: float
    sensor_height_mm: float | None
    width: int | None
    height: int | None


def _normalise(name: str) -> str:
    return re.sub(r"[^a-z0-9]", "", str(name).lower())


def _read_data(filename: str) -> Any:
    return json.loads(resources.files("sightplan").joinpath("data", filename).read_text(encoding="utf-8"))


@lru_cache(maxsize=1)
def _catalogue() -> tuple[tuple[CatalogueEntry, ...], dict[str, CatalogueEntry]]:
    entries = []
    for e in _read_data("cameras.json")["cameras"]:
        entries.append(CatalogueEntry(
            id=e["id"], name=e["name"], kind=e["model"], width=int(e["width"]), height=int(e["height"]),
            focal_mm=e.get("focal_mm"), sensor_width_mm=e.get("sensor_width_mm"),
            sensor_height_mm=e.get("sensor_height_mm"), aliases=tuple(e.get("aliases", ())), source=e.get("source", ""),
        ))
    index: dict[str, CatalogueEntry] = {}
    for entry in entries:
        for key in (entry.id, entry.name, *entry.aliases):
            index.setdefault(_normalise(key), entry)
    return tuple(entries), index


@lru_cache(maxsize=1)
def _sensor_tables() -> dict[str, SensorInfo]:
    """Normalised "Make Model" → SensorInfo, the detailed table winning over the short one."""
    table: dict[str, SensorInfo] = {}
    for key, width_mm in _read_data("sensor_data.json").items():
        table[_normalise(key)] = SensorInfo(key, float(width_mm), None, None, None)
    for key, row in _read_data("sensor_data_detailed.json").items():
        res_w, res_h = row.get("Sensor res. (width)"), row.get("Sensor res. (height)")
        table[_normalise(key)] = SensorInfo(
            key, float(row["Sensor width (mm)"]), row.get("Sensor height (mm)"),
            int(res_w) if res_w else None, int(res_h) if res_h else None,
        )
    return table


def list_cameras() -> list[CatalogueEntry]:
    """The built-in cameras, in catalogue order."""
    return list(_catalogue()[0])


def lookup_sensor(make_model: str) -> SensorInfo | None:
    """OpenSfM's sensor-table row for an EXIF ``"Make Model"`` such as ``"DJI FC6310"``, or None."""
    return _sensor_tables().get(_normalise(make_model))


@dataclass(frozen=True)
class CameraMatch:
    """A camera found by :func:`search_cameras`.

    source: ``"catalogue"`` (a built-in camera, ready to use) or ``"sensor table"`` (OpenSfM's
    tables: the sensor is known, the lens is not). key: what to give ``get_camera`` or
    ``--camera``. name: the display name. sensor_width_mm, sensor_height_mm, width, height,
    focal_mm: None where unknown. needs: what must still be given before the camera can be
    used, "" when nothing.
    """

    source: Literal["catalogue", "sensor table"]
    key: str
    name: str
    kind: CameraKind
    sensor_width_mm: float | None
    sensor_height_mm: float | None
    width: int | None
    height: int | None
    focal_mm: float | None
    aliases: tuple[str, ...] = ()
    needs: str = ""


def _query_tokens(text: str) -> list[set[str]]:
    """The search words of ``text``, each with its spellings: Sony's "a7r" is also "alpha7r" and "ilce7r"."""
    out = []
    for tok in re.split(r"[^a-z0-9]+", str(text).lower()):
        if not tok:
            continue
        variants = {tok}
        m = re.fullmatch(r"(?:a|alpha|ilce)(\d\w*)", tok)
        if m:
            variants |= {f"a{m[1]}", f"alpha{m[1]}", f"ilce{m[1]}"}
        out.append(variants)
    return out


def _matches(tokens: list[set[str]], haystack: str) -> bool:
    return all(any(v in haystack for v in variants) for variants in tokens)


def _natural(name: str) -> list:
    return [int(t) if t.isdigit() else t for t in re.split(r"(\d+)", name.lower())]


def search_cameras(text: str = "", *, sensor_tables: bool = True) -> list[CameraMatch]:
    """Cameras whose names contain every word of ``text``, in any order and case.

    The built-in catalogue (id, name and aliases) comes first, in catalogue order; then, when
    ``sensor_tables`` and ``text`` is not empty, the rows of OpenSfM's sensor tables ("Make
    Model", natural order) that the catalogue does not already cover. An empty ``text`` gives
    the catalogue alone. ``"sony 7r"`` finds "Sony Alpha 7R" and "SONY ILCE-7RM2"-like names.
    """
    tokens = _query_tokens(text)
    entries, index = _catalogue()
    found: list[CameraMatch] = []
    for e in entries:
        if tokens and not _matches(tokens, _normalise(" ".join((e.id, e.name, *e.aliases)))):
            continue
        found.append(CameraMatch("catalogue", e.id, e.name, e.kind, e.sensor_width_mm, e.sensor_height_mm,
                                 e.width, e.height, e.focal_mm, e.aliases))
    if not tokens or not sensor_tables:
        return found
    rows = [s for key, s in _sensor_tables().items() if key not in index and _matches(tokens, key)]
    for s in sorted(rows, key=lambda s: _natural(s.key)):
        needs = "--focal-mm" if s.width and s.height else "--focal-mm and the image size (a camera JSON file)"
        found.append(CameraMatch("sensor table", s.key, s.key, "pinhole", s.sensor_width_mm, s.sensor_height_mm,
                                 s.width, s.height, None, (), needs))
    return found


def similar_names(name: str) -> list[str]:
    _, index = _catalogue()
    sensors = _sensor_tables()
    display = {k: e.id for k, e in index.items()}
    display.update({k: s.key for k, s in sensors.items() if k not in display})
    close = difflib.get_close_matches(_normalise(name), list(display), n=8, cutoff=0.6)
    return list(dict.fromkeys(display[k] for k in close))[:5]


def get_camera(name: str, *, focal_mm: float | None = None, width: int | None = None, height: int | None = None) -> Camera:
    """The camera called ``name`` in the catalogue, else in OpenSfM's sensor tables.

    focal_mm: lens focal length in mm; replaces a catalogue lens, and is required for a
    sensor-table camera. width, height: image size in px for a sensor-table camera whose
    resolution the table lacks (or to override it).
    """
    entry = _catalogue()[1].get(_normalise(name))
    if entry is not None:
        if width is not None or height is not None:
            raise CameraError(f"{entry.name} has a fixed image size; use camera.scaled(s) for a lower resolution")
        return entry.camera(focal_mm)
    sensor = lookup_sensor(name)
    if sensor is None:
        hint = similar_names(name)
        also = f"; did you mean {', '.join(map(repr, hint))}?" if hint else ""
        raise CameraError(f"unknown camera {name!r}{also} (`sightplan cameras WORDS` searches the catalogue and the "
                          "sensor tables; any other camera can be given as a camera JSON file)")
    if focal_mm is None:
        raise CameraError(
            f"the sensor table knows {sensor.key!r} ({sensor.sensor_width_mm:g} mm wide sensor) but not its lens: "
            "give its focal length in mm (--focal-mm on the command line, focal_mm= in Python)"
        )
    if not (isinstance(focal_mm, (int, float)) and not isinstance(focal_mm, bool) and math.isfinite(focal_mm)
            and focal_mm > 0):
        raise CameraError(f"the focal length must be a positive number of millimetres, got {focal_mm!r}")
    w, h = width or sensor.width, height or sensor.height
    if w is None or h is None:
        raise CameraError(
            f"the sensor table does not know the resolution of {sensor.key!r}: give width= and height= in px, or on "
            "the command line a camera JSON file with sensor_width_mm, focal_mm, width and height"
        )
    return PinholeCamera.from_sensor(sensor.sensor_width_mm, float(focal_mm), int(w), int(h),
                                     name=f"{sensor.key} ({float(focal_mm):g} mm)")
