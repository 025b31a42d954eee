"""KML and GeoJSON exports: every mission in one file, for viewing in a map or GIS.

- KML 2.2 (``http://www.opengis.net/kml/2.2``): a ``Document`` with one ``Folder`` per mission holding
  the flight path (``LineString``, ``altitudeMode`` absolute; ``ExtendedData`` ``takeoff``, the mission's
  take-off point "lon,lat,height"), one ``Placemark`` per waypoint (``Point``; ``ExtendedData``
  ``mission``, ``waypoint``, ``altitude_m`` above the mission's take-off, ``height_m`` and the photos'
  ``frames``, ``heading_deg`` and ``pitch_deg``, lists joined by ";") and a ``footprints`` folder of
  ``Polygon`` placemarks, one per frame. Heights: KML's absolute altitude is above the EGM96 geoid
  (OGC KML 2.2), so the model's sea-level heights are written as they are.
- GeoJSON (RFC 7946): a ``FeatureCollection`` of a ``LineString`` per mission (``kind`` "path", with its
  ``takeoff`` position), a ``Point`` per waypoint (``kind`` "waypoint", the same properties with lists)
  and a ``Polygon`` per frame footprint (``kind`` "footprint"). Positions are [longitude, latitude,
  height] with the height above the WGS84 ellipsoid (RFC 7946 §4): the sea-level height + the EGM96
  geoid undulation (:mod:`sightplan.geoid`); ``height_m`` keeps the sea-level height.

A footprint is where the four image-corner rays meet the horizontal plane at its mission's take-off
height (:func:`~sightplan.export.common.footprint`); frames whose rays do not all reach it (or 360°
frames) have none, and their waypoint lists them in ``footprint_skipped`` with the reason in
``footprint_note``. Headings are true headings, pitches gimbal pitches (see :mod:`sightplan.export.common`).
"""

from __future__ import annotations

import json
from pathlib import Path
from xml.etree import ElementTree as ET

import numpy as np

from ..formats.kml import KML_NS
from .common import Flight, Waypoint, footprint

FOOTPRINT_NOTE = ("no footprint for these frames: an image-corner ray does not reach the take-off plane "
                  "(or the camera is a 360° camera)")


def _footprints(flight: Flight, wp: Waypoint) -> tuple[list[tuple[str, np.ndarray]], list[str]]:
    """([(frame name, (5, 3) closed lon/lat/height ring, counter-clockwise)], [frame names without one]); heights in
    the georeference's datum."""
    rings, skipped = [], []
    plane_z = flight.takeoff_of(wp.mission).position_m[2]
    for photo in wp.photos:
        corners = footprint(flight.plan, photo.frame, plane_z)
        if corners is None:
            skipped.append(photo.name)
            continue
        lat, lon, h = flight.georef.to_geodetic(corners)
        ring = np.stack([lon, lat, h], axis=1)
        x, y = ring[:, 0], ring[:, 1]
        if np.sum(x * np.roll(y, -1) - np.roll(x, -1) * y) < 0:
            ring = ring[::-1]
        rings.append((photo.name, np.vstack([ring, ring[:1]])))
    return rings, skipped


def _waypoint(flight: Flight, number: int, index: int, wp: Waypoint) -> tuple[dict, list[tuple[str, np.ndarray]]]:
    """The waypoint's properties (``kind`` "waypoint", the frames without a footprint noted) and its footprints."""
    rings, skipped = _footprints(flight, wp)
    props = {"kind": "waypoint", "mission": flight.missions[wp.mission].name, "mission_number": number, "waypoint": index,
             "altitude_m": wp.altitude_m, "height_m": wp.height_m,
             "frames": [p.name for p in wp.photos], "heading_deg": [p.heading_deg for p in wp.photos],
             "pitch_deg": [p.pitch_deg for p in wp.photos]}
    if skipped:
        props.update({"footprint_skipped": skipped, "footprint_note": FOOTPRINT_NOTE})
    return props, rings


# ---- GeoJSON ---------------------------------------------------------------------------------


def _ellipsoidal(points: np.ndarray) -> list[list[float]]:
    """(n, 3) lon, lat, sea-level height → [[lon, lat, WGS84 ellipsoidal height]…] (RFC 7946 §4)."""
    from ..geoid import to_ellipsoidal

    p = np.array(points, float).reshape(-1, 3)
    p[:, 2] = to_ellipsoidal(p[:, 1], p[:, 0], p[:, 2])
    return p.tolist()


def geojson_document(flight: Flight) -> dict:
    features: list[dict] = []
    for number, wps in flight.by_mission():
        name = flight.missions[wps[0].mission].name
        start = flight.takeoff_of(wps[0].mission)
        plane = start.height_m
        coords = _ellipsoidal([[w.longitude_deg, w.latitude_deg, w.height_m] for w in wps])
        features.append({"type": "Feature",
                         "properties": {"kind": "path", "mission": name, "mission_number": number,
                                        "takeoff": _ellipsoidal([start.longitude_deg, start.latitude_deg, plane])[0],
                                        "takeoff_height_m": plane},
                         "geometry": {"type": "LineString", "coordinates": coords}})
        for index, wp in enumerate(wps):
            props, rings = _waypoint(flight, number, index, wp)
            features.append({"type": "Feature", "properties": props,
                             "geometry": {"type": "Point", "coordinates": coords[index]}})
            for frame, ring in rings:
                features.append({"type": "Feature",
                                 "properties": {"kind": "footprint", "frame": frame, "mission": name, "mission_number": number,
                                                "waypoint": index, "plane_height_m": plane},
                                 "geometry": {"type": "Polygon", "coordinates": [_ellipsoidal(ring)]}})
    return {"type": "FeatureCollection", "features": features}


def write_geojson(flight: Flight, path: Path) -> list[Path]:
    path.write_text(json.dumps(geojson_document(flight), allow_nan=False), encoding="utf-8")
    return [path]


# ---- KML -------------------------------------------------------------------------------------


def _el(parent: ET.Element, tag: str, text: str | None = None) -> ET.Element:
    el = ET.SubElement(parent, f"{{{KML_NS}}}{tag}")
    if text is not None:
        el.text = text
    return el


def _coords(points) -> str:
    return " ".join(f"{lon!r},{lat!r},{h!r}" for lon, lat, h in points)


def _data(parent: ET.Element, values: dict) -> None:
    ext = _el(parent, "ExtendedData")
    for key, value in values.items():
        if isinstance(value, list):
            value = ";".join(v if isinstance(v, str) else repr(float(v)) for v in value)
        elif isinstance(value, float):
            value = repr(value)
        data = _el(ext, "Data")
        data.set("name", key)
        _el(data, "value", str(value))


def kml_bytes(flight: Flight, title: str) -> bytes:
    ET.register_namespace("", KML_NS)
    root = ET.Element(f"{{{KML_NS}}}kml")
    doc = _el(root, "Document")
    _el(doc, "name", title)
    for number, wps in flight.by_mission():
        name = flight.missions[wps[0].mission].name
        folder = _el(doc, "Folder")
        _el(folder, "name", name)
        start = flight.takeoff_of(wps[0].mission)
        path = _el(folder, "Placemark")
        _el(path, "name", f"{name} path")
        _data(path, {"kind": "path", "mission": name, "mission_number": number,
                     "takeoff": _coords([(start.longitude_deg, start.latitude_deg, start.height_m)])})
        line = _el(path, "LineString")
        _el(line, "altitudeMode", "absolute")
        _el(line, "coordinates", _coords((w.longitude_deg, w.latitude_deg, w.height_m) for w in wps))
        prints = _el(folder, "Folder")
        _el(prints, "name", "footprints")
        for index, wp in enumerate(wps):
            props, rings = _waypoint(flight, number, index, wp)
            pm = _el(folder, "Placemark")
            _el(pm, "name", f"{name} waypoint {index + 1}")
            style = _el(_el(pm, "Style"), "IconStyle")
            _el(style, "heading", repr(wp.photos[0].heading_deg))
            _data(pm, props)
            point = _el(pm, "Point")
            _el(point, "altitudeMode", "absolute")
            _el(point, "coordinates", _coords([(wp.longitude_deg, wp.latitude_deg, wp.height_m)]))
            for frame, ring in rings:
                fp = _el(prints, "Placemark")
                _el(fp, "name", frame)
                _data(fp, {"kind": "footprint", "frame": frame, "mission": name, "waypoint": index,
                           "plane_height_m": start.height_m})
                poly = _el(fp, "Polygon")
                _el(poly, "altitudeMode", "absolute")
                ring_el = _el(_el(poly, "outerBoundaryIs"), "LinearRing")
                _el(ring_el, "coordinates", _coords(ring.tolist()))
    ET.indent(root, space=" ")
    return ET.tostring(root, encoding="utf-8", xml_declaration=True)


def write_kml(flight: Flight, path: Path) -> list[Path]:
    path.write_bytes(kml_bytes(flight, path.stem))
    return [path]
