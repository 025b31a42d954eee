"""GeoJSON (RFC 7946): a map export of every mission in one file, for viewing in a map or GIS.

A ``FeatureCollection`` of a ``LineString`` per mission (``kind`` "path", with its ``takeoff`` position), a
``Point`` per waypoint (``kind`` "waypoint", the properties of the KML export (:mod:`.kml`) with lists) and a
``Polygon`` per frame footprint (``kind`` "footprint", :func:`~.flight.footprints`; frames without one are listed
in their waypoint's ``footprint_skipped``). Positions are [longitude, latitude, height] with the height above the
WGS84 ellipsoid (RFC 7946 §4): the sea-level height + the EGM96 geoid undulation (:mod:`sightplan.geoid`);
``height_m`` keeps the sea-level height. Headings are true headings, pitches gimbal pitches (see :mod:`.flight`).
"""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np

from .base import FlightFormat, Target
from .flight import Flight, waypoint_properties


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
            props, rings = waypoint_properties(flight, number, index, wp)
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


def _write(flight: Flight, path: Path, target: Target) -> list[Path]:
    return write_geojson(flight, path)


FORMAT = FlightFormat(name="geojson", label="GeoJSON", order=60, write=_write, suffix=".geojson",
                      media_type="application/geo+json")
