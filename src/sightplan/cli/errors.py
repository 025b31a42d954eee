"""How the CLI reports: failures in one line and a non-zero exit (no traceback), paths checked before work, cells."""

from __future__ import annotations

import functools
import os
import sys
import tempfile
from collections.abc import Callable
from pathlib import Path
from typing import TypeVar

import typer
from rich.console import Console
from rich.markup import escape

from ..errors import SightplanError

F = TypeVar("F", bound=Callable)
err_console = Console(stderr=True)


def finite_options(kwargs: dict) -> None:
    """Every number option finite: ``--speed nan`` is one error naming the option, not a NaN further on."""
    import math

    from ..plan.domain import shown

    for name, value in kwargs.items():
        for v in value if isinstance(value, (list, tuple)) else (value,):
            if isinstance(v, float) and not math.isfinite(v):
                raise SightplanError(f"--{name.replace('_', '-')}: {shown(v)} is not a finite number")


def friendly_errors(func: F) -> F:
    @functools.wraps(func)
    def wrapper(*args, **kwargs):
        try:
            finite_options(kwargs)
            return func(*args, **kwargs)
        except SightplanError as exc:
            err_console.print(f"[bold red]error:[/] {escape(str(exc))}", highlight=False, markup=True, soft_wrap=True)
            raise typer.Exit(2) from None
        except KeyboardInterrupt:
            err_console.print("[yellow]interrupted[/]")
            raise typer.Exit(130) from None
        except (typer.Exit, typer.Abort):
            raise
        except Exception as exc:  # a bug, not bad input: still one line unless asked for details
            if os.environ.get("SIGHTPLAN_DEBUG"):
                raise
            err_console.print(f"[bold red]internal error:[/] {type(exc).__name__}: {escape(str(exc))} "
                              "(set SIGHTPLAN_DEBUG=1 for the traceback)", highlight=False, soft_wrap=True)
            sys.stderr.flush()
            raise typer.Exit(3) from None

    return wrapper  # type: ignore[return-value]


def writable_folder(path: Path, option: str) -> Path:
    """``path`` checked, before any work, to be a folder that exists and can be written or that can be made
    (nothing is created here), else one SightplanError."""
    path = Path(path).absolute()
    existing = path
    while not existing.exists() and existing.parent != existing:
        existing = existing.parent
    if not existing.is_dir():
        raise SightplanError(f"{option} {path}: cannot write there ({existing} is a file, not a folder)")
    try:
        with tempfile.NamedTemporaryFile(dir=existing, prefix=".sightplan-write-test-"):
            pass
    except OSError as exc:
        raise SightplanError(f"{option} {path}: cannot write there ({exc.strerror or exc})") from None
    return path


def writable_file(path: Path, option: str) -> Path:
    """``path``'s folder made and checked writable before any work (the file itself is written later)."""
    path = Path(path)
    if path.is_dir():
        raise SightplanError(f"{option} {path}: is a folder, not a file")
    writable_folder(path.parent if str(path.parent) else Path("."), option)
    if path.exists() and not os.access(path, os.W_OK):
        raise SightplanError(f"{option} {path}: cannot write there (read-only)")
    return path


def cell(x: float | None, spec: str) -> str:
    """A table cell: ``x`` formatted with ``spec``, or a dash for a missing value."""
    return "—" if x is None else format(x, spec)
