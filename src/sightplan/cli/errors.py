"""How the CLI reports failures: one readable line and a non-zero exit, never a traceback."""

from __future__ import annotations

import functools
import os
import sys
from collections.abc import Callable
from typing import TypeVar

import typer
from rich.console import Console

from ..errors import SightplanError

F = TypeVar("F", bound=Callable)
err_console = Console(stderr=True)


def friendly_errors(func: F) -> F:
    @functools.wraps(func)
    def wrapper(*args, **kwargs):
        try:
            return func(*args, **kwargs)
        except SightplanError as exc:
            err_console.print(f"[bold red]error:[/] {exc}", highlight=False, markup=True)
            raise typer.Exit(2) from None
        except KeyboardInterrupt:
            err_console.print("[yellow]interrupted[/]")
            raise typer.Exit(130) from None
        except (typer.Exit, typer.Abort):
            raise
        except Exception as exc:  # a bug, not bad input: still one line unless asked for details
            if os.environ.get("SIGHTPLAN_DEBUG"):
                raise
            err_console.print(f"[bold red]internal error:[/] {type(exc).__name__}: {exc} "
                              "(set SIGHTPLAN_DEBUG=1 for the traceback)", highlight=False)
            sys.stderr.flush()
            raise typer.Exit(3) from None

    return wrapper  # type: ignore[return-value]
