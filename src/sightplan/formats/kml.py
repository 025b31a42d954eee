"""KML 2.2 (OGC, namespace ``http://www.opengis.net/kml/2.2``, :data:`KML_NS`): the document language of DJI's
WPML files, and a map export of every mission in one file, for viewing in a map or GIS.

A ``Document`` with one ``Folder`` per mission holding the flight path (``LineString``, ``altitudeMode`` absolute;
``ExtendedData`` ``takeoff``, the mission's take-off point "lon,lat,height"), one ``Placemark`` per waypoint
(``Point``; ``ExtendedData`` ``mission``, ``waypoint``, ``altitude_m`` above the mission's take-off, ``height_m``
and the photos' ``frames``, ``heading_deg`` and ``pitch_deg``, lists joined by ";") and a ``footprints`` folder of
``Polygon`` placemarks, one per frame (:func:`~.flight.footprints`; frames without one are listed in their
waypoint's ``footprint_skipped``). Heights: KML's absolute altitude is above the EGM96 geoid (OGC KML 2.2), so
the model's sea-level heights are written as they are. Headings are true headings, pitches gimbal pitches (see
:mod:`.flight`).
"""

from __future__ import annotations

from pathlib import Path
from xml.etree import ElementTree as ET

from .base import FlightFormat, Target
from .flight import Flight, waypoint_properties

KML_NS = "http://www.opengis.net/kml/2.2"


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
            props, rings = waypoint_properties(flight, number, index, wp)
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


def _write(flight: Flight, path: Path, target: Target) -> list[Path]:
    return write_kml(flight, path)


FORMAT = FlightFormat(name="kml", label="KML", order=50, write=_write, suffix=".kml",
                      media_type="application/vnd.google-earth.kml+xml")
