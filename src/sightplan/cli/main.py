"""The ``sightplan`` command line: thin commands over the library."""

from __future__ import annotations

from pathlib import Path
from typing import Annotated

import typer
from rich.console import Console

from .errors import friendly_errors

app = typer.Typer(add_completion=False, no_args_is_help=True,
                  help="Create and evaluate reality capture plans against building models.")
console = Console()
ENGINE_HELP = ("Visibility engine: auto (OpenGL on a GPU when there is one, else Embree), embree, gl, trimesh; "
               "see `sightplan engines`")

from . import evaluate_cmd, export_cmd, info_cmd, plan_cmd, progress_cmd, serve_cmd, study_cmd, validate_cmd  # noqa: E402,F401  (registers the commands)


@app.command()
@friendly_errors
def cameras(search: Annotated[str, typer.Argument(help="Filter by name")] = "") -> None:
    """List the built-in camera catalogue."""
    from rich.table import Table

    from ..camera.catalogue import list_cameras
    from ..camera.models import PinholeCamera

    table = Table("id", "name", "model", "image (px)", "focal (px)", "FOV (°)", "aliases")
    for entry in list_cameras():
        if search.lower() not in f"{entry.id} {entry.name} {' '.join(entry.aliases)}".lower():
            continue
        cam = entry.camera()
        if isinstance(cam, PinholeCamera):
            table.add_row(entry.id, entry.name, "pinhole", f"{cam.width}×{cam.height}", f"{cam.fx:.0f}",
                          f"{cam.hfov_deg:.1f}×{cam.vfov_deg:.1f}", ", ".join(entry.aliases))
        else:
            table.add_row(entry.id, entry.name, "equirectangular", f"{cam.width}×{cam.height}", "—", "360×180",
                          ", ".join(entry.aliases))
    console.print(table)


def main() -> None:  # pragma: no cover
    app()


_ = Path  # re-exported for the command modules' annotations
