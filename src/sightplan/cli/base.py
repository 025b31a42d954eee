"""What every command module shares: the Typer application the commands register on, and the console."""

from __future__ import annotations

import typer
from rich.console import Console

app = typer.Typer(add_completion=False, no_args_is_help=True,
                  help="Create and evaluate reality capture plans against building models.")
console = Console()
err_console = Console(stderr=True)  # progress: standard output stays the command's own (tables, JSON)
ENGINE_HELP = ("Visibility engine: auto (OpenGL on a GPU when there is one, else Embree), embree, gl, trimesh; "
               "see `sightplan engines`")
