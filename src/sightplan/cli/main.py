"""The ``sightplan`` command line: thin commands over the library. Importing this module registers every command
on :data:`app` (defined in :mod:`.base`, which the command modules import)."""

from __future__ import annotations

from . import (  # noqa: F401  (registers the commands)
    cameras_cmd,
    evaluate_cmd,
    export_cmd,
    info_cmd,
    loop_cmd,
    optimize_cmd,
    plan_cmd,
    progress_cmd,
    render_cmd,
    serve_cmd,
    study_cmd,
    validate_cmd,
)
from .base import app

__all__ = ["app", "main"]


def main() -> None:  # pragma: no cover
    app()
