"""Camera models and the camera catalogue."""

from .catalogue import (
    CameraMatch,
    CatalogueEntry,
    SensorInfo,
    get_camera,
    list_cameras,
    lookup_sensor,
    search_cameras,
)
from .files import camera_from_json, camera_from_option, check_camera, parse_camera_spec, read_camera_file
from .models import Camera, CameraKind, EquirectangularCamera, PinholeCamera, camera_from_dict

__all__ = [
    "Camera",
    "CameraKind",
    "CameraMatch",
    "CatalogueEntry",
    "EquirectangularCamera",
    "PinholeCamera",
    "SensorInfo",
    "camera_from_dict",
    "camera_from_json",
    "camera_from_option",
    "check_camera",
    "get_camera",
    "list_cameras",
    "lookup_sensor",
    "parse_camera_spec",
    "read_camera_file",
    "search_cameras",
]
