"""DJI WPML: the namespaces of its KML documents and the aircraft and payloads sightplan writes for and reads.

Enumeration values: DJI Cloud API "Product Support" page (aircraft type/sub_type; camera type-subtype-gimbalindex).
Pitch ranges: the manufacturers' gimbal specs (controllable tilt), cut at −90° (sightplan's nadir).
"""

from __future__ import annotations

from dataclasses import dataclass

from .kml import KML_NS

__all__ = ["AIRCRAFT", "BUILT_IN_CAMERAS", "KML_NS", "PAYLOAD_CAMERAS", "SPEED_RANGE_M_S", "WPML_NS", "DjiAircraft"]

WPML_NS = "http://www.dji.com/wpmz/1.0.2"
SPEED_RANGE_M_S = (1.0, 15.0)  # autoFlightSpeed, waypointSpeed and globalTransitionalSpeed


@dataclass(frozen=True)
class DjiAircraft:
    """A DJI aircraft and payload for WPML: DJI's enumeration values (``droneEnumValue``, ``droneSubEnumValue``,
    ``payloadEnumValue``), the catalogue cameras it carries, the gimbal's controllable pitch range (degrees) and the
    photo lens (``imageFormat``)."""

    key: str
    name: str
    drone: int
    sub: int
    payload: int
    cameras: tuple[str, ...]
    pitch_range: tuple[float, float]
    image_format: str = "wide"
    speed_range: tuple[float, float] = SPEED_RANGE_M_S


AIRCRAFT: dict[str, DjiAircraft] = {a.key: a for a in (
    DjiAircraft("m3e", "DJI Mavic 3 Enterprise", 77, 0, 66, ("m3e",), (-90.0, 35.0)),
    DjiAircraft("m350-h20", "DJI Matrice 350 RTK with Zenmuse H20", 89, 0, 42, ("h20-wide",), (-90.0, 30.0)),
    DjiAircraft("m350-p1", "DJI Matrice 350 RTK with Zenmuse P1", 89, 0, 50, ("p1-35",), (-90.0, 40.0)),
    DjiAircraft("m300-h20", "DJI Matrice 300 RTK with Zenmuse H20", 60, 0, 42, ("h20-wide",), (-90.0, 30.0)),
    DjiAircraft("m300-p1", "DJI Matrice 300 RTK with Zenmuse P1", 60, 0, 50, ("p1-35",), (-90.0, 40.0)),
)}

#: A mission's payload → the catalogue camera it takes photos with.
PAYLOAD_CAMERAS: dict[int, str] = {a.payload: a.cameras[0] for a in AIRCRAFT.values()}
#: An aircraft whose camera is built in (no payload element needed) → its catalogue camera.
BUILT_IN_CAMERAS: dict[tuple[int, int], str] = {(a.drone, a.sub): a.cameras[0] for a in AIRCRAFT.values()
                                                if a.key == a.cameras[0]}
