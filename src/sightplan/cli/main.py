"""The ``sightplan`` command line: thin commands over the library."""

from __future__ import annotations

from pathlib import Path

import typer
from rich.console import Console

app = typer.Typer(add_completion=False, no_args_is_help=True,
                  help="Create and evaluate reality capture plans against building models.")
console = Console()
ENGINE_HELP = ("Visibility engine: auto (OpenGL on a GPU when there is one, else Embree), embree, gl, trimesh; "
               "see `sightplan engines`")

from . import cameras_cmd, evaluate_cmd, export_cmd, info_cmd, plan_cmd, progress_cmd, serve_cmd, study_cmd, validate_cmd  # noqa: E402,F401  (registers the commands)


def main() -> None:  # pragma: no cover
    app()


_ = Path  # re-exported for the command modules' annotations
