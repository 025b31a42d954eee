"""Camera models and the camera catalogue."""

from .catalogue import CatalogueEntry, SensorInfo, get_camera, list_cameras, lookup_sensor, parse_camera_spec
from .models import Camera, CameraKind, EquirectangularCamera, PinholeCamera, camera_from_dict

__all__ = [
    "Camera",
    "CameraKind",
    "CatalogueEntry",
    "EquirectangularCamera",
    "PinholeCamera",
    "SensorInfo",
    "camera_from_dict",
    "get_camera",
    "list_cameras",
    "lookup_sensor",
    "parse_camera_spec",
]
