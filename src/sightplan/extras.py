"""Optional parts of sightplan and what installs them: ``gl`` (the OpenGL engine), ``web`` (``sightplan serve``),
``cluster`` (``--cluster``), ``loop`` (``sightplan reconstruct``: structure from motion with pycolmap); ``all`` is every
one (what ``make setup`` installs)."""

from __future__ import annotations

import importlib

from .errors import SightplanError

EXTRAS = {"gl": ("moderngl",), "web": ("fastapi", "uvicorn", "sqlalchemy", "alembic", "multipart", "argon2"),
          "cluster": ("distributed",), "loop": ("pycolmap",)}


def install_hint(extra: str) -> str:
    return f"pip install 'sightplan[{extra}]'"


def require(extra: str, what: str) -> None:
    """A SightplanError naming the extra to install when a module of ``extra`` cannot be imported (``what`` is the
    feature that needs it, e.g. "sightplan serve")."""
    for module in EXTRAS[extra]:
        try:
            importlib.import_module(module)
        except ImportError as exc:
            raise SightplanError(f"{what} needs sightplan's '{extra}' extra, which is not installed ({exc}): "
                                 f"{install_hint(extra)}") from None
