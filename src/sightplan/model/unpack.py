"""The limit on what a compressed input may unpack to: an .ifczip's IFC, a LAZ file's points.

A small archive can hold a huge padded file, and a LAZ header can declare billions of points; both are refused
before anything is unpacked or allocated. The limit is ``$SIGHTPLAN_MAX_UNPACKED_MB`` (``sightplan serve`` sets it
to ten times its upload limit), else :data:`DEFAULT_MAX_UNPACKED_MB`.
"""

from __future__ import annotations

import os

DEFAULT_MAX_UNPACKED_MB = 4096.0


def max_unpacked_bytes() -> int:
    """The most bytes a compressed input may unpack to."""
    try:
        mb = float(os.environ.get("SIGHTPLAN_MAX_UNPACKED_MB", DEFAULT_MAX_UNPACKED_MB))
    except ValueError:
        mb = DEFAULT_MAX_UNPACKED_MB
    return int(max(mb, 1.0) * 1024 * 1024)


def too_big(name: str, size_bytes: float | None = None) -> str:
    """The message refusing ``name`` for unpacking to ``size_bytes`` (or to more than the limit, when unknown)."""
    limit = max_unpacked_bytes() / 2**20
    what = f"{size_bytes / 2**20:,.0f} MB, over" if size_bytes is not None else "more than"
    return f"{name} unpacks to {what} the limit of {limit:,.0f} MB (SIGHTPLAN_MAX_UNPACKED_MB): refused"
