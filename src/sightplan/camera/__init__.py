"""Camera models and the camera catalogue."""

from .models import Camera, CameraKind, EquirectangularCamera, PinholeCamera, camera_from_dict

__all__ = ["Camera", "CameraKind", "EquirectangularCamera", "PinholeCamera", "camera_from_dict"]
