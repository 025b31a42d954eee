"""The ``--camera`` and ``--focal-mm`` options that every command taking a camera shares."""

from __future__ import annotations

from typing import TYPE_CHECKING, Annotated

import typer

if TYPE_CHECKING:
    from ..camera.models import Camera

CAMERA_FORMS = ("a catalogue id or name (`sightplan cameras`), a sensor-table camera with --focal-mm, "
                "or a camera JSON file")
PlanCameraOpt = Annotated[str | None, typer.Option(
    help="Camera of a poses CSV or flight-app mission (" + CAMERA_FORMS + "); replaces the plan's own")]
FocalOpt = Annotated[float | None, typer.Option(
    "--focal-mm", help="Lens focal length in mm: needed with a sensor-table --camera, and replaces a catalogue "
                       "camera's lens")]


def cli_camera(camera: str | None, focal_mm: float | None = None) -> Camera | None:
    """The camera ``--camera`` and ``--focal-mm`` name, or None when no --camera is given."""
    from ..camera.files import camera_from_option
    from ..errors import CameraError

    if camera is None:
        if focal_mm is not None:
            raise CameraError("--focal-mm needs --camera: the camera (catalogue or sensor table) whose lens it gives")
        return None
    return camera_from_option(camera, focal_mm)


DEFAULT_PRESET = "noise"  # as sightplan.loop.photo.DEFAULT_PRESET, without importing it here
PhotoRealismOpt = Annotated[str, typer.Option(
    "--photo-realism", help="How photograph-like the renders are: noise (each element its own colour under a rich "
                            "procedural texture, unlit: the upper bound a plan allows), flat (a colour per material), "
                            "textured (material "
                            "textures), shaded (+ sun, shadows, sky, ground), full (+ exposure, white balance, "
                            "noise, motion blur, lens distortion estimated back by the SfM)")]
SeedOpt = Annotated[int, typer.Option(help="Seed of every random choice of the renders (noise, exposure, white "
                                           "balance): the same seed gives the same images")]
