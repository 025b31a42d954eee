"""``sightplan cameras [SEARCH]``: the built-in cameras, and a search of OpenSfM's sensor tables."""

from __future__ import annotations

from typing import Annotated

import typer
from rich.markup import escape
from rich.table import Table

from .base import app, console
from .errors import friendly_errors


def _mm(w: float | None, h: float | None) -> str:
    if w is None:
        return "—"
    return f"{w:g} × {h:g}" if h else f"{w:g} wide"


def _px(w: int | None, h: int | None) -> str:
    return f"{w}×{h}" if w and h else "—"


@app.command()
@friendly_errors
def cameras(
    words: Annotated[list[str] | None, typer.Argument(
        metavar="[SEARCH]...", help="Words to look for, in any order and case (e.g. sony 7r); none: the built-in "
                                    "catalogue")] = None,
    limit: Annotated[int, typer.Option(help="Show at most this many sensor-table cameras")] = 40,
) -> None:
    """List the built-in cameras, and search OpenSfM's sensor tables too."""
    from ..camera.catalogue import get_camera, search_cameras, similar_names
    from ..camera.models import PinholeCamera
    from ..errors import CameraError

    search = " ".join(words or [])
    found = search_cameras(search)
    built_in = [m for m in found if m.source == "catalogue"]
    table_rows = [m for m in found if m.source == "sensor table"]
    if not found:
        hint = similar_names(search)
        also = f"; close: {', '.join(map(repr, hint))}" if hint else ""
        raise CameraError(f"no camera matches {search!r} in the catalogue or the sensor tables{also}. Any camera can "
                          "be given as a JSON file of its intrinsics (see the README, Camera catalogue)")
    if built_in:
        t = Table(title="built-in cameras: --camera ID", title_justify="left")
        for header in ("id", "name", "model", "sensor (mm)", "image (px)", "focal (px)", "FOV (°)", "aliases"):
            t.add_column(header, no_wrap=header not in ("name", "aliases"))
        for m in built_in:
            cam = get_camera(m.key)
            if isinstance(cam, PinholeCamera):
                t.add_row(m.key, escape(m.name), "pinhole", _mm(m.sensor_width_mm, m.sensor_height_mm),
                          _px(cam.width, cam.height), f"{cam.fx:.0f}", f"{cam.hfov_deg:.1f}×{cam.vfov_deg:.1f}",
                          escape(", ".join(m.aliases)))
            else:
                t.add_row(m.key, escape(m.name), "equirectangular", "—", _px(cam.width, cam.height), "—", "360×180",
                          escape(", ".join(m.aliases)))
        console.print(t)
    if table_rows:
        shown = table_rows[:max(limit, 0)]
        t = Table(title="OpenSfM sensor tables: --camera \"NAME\" --focal-mm F (the lens is not in the tables)",
                  title_justify="left")
        for header in ("camera (EXIF make and model)", "sensor (mm)", "image (px)", "needs"):
            t.add_column(header, no_wrap=header in ("sensor (mm)", "image (px)"))
        for m in shown:
            t.add_row(escape(m.name), _mm(m.sensor_width_mm, m.sensor_height_mm), _px(m.width, m.height), m.needs)
        console.print(t)
        if len(table_rows) > len(shown):
            console.print(f"… and {len(table_rows) - len(shown)} more sensor-table cameras: add words to narrow the "
                          "search, or --limit N")
    if not search:
        console.print("Search the sensor tables too with `sightplan cameras WORDS`; any other camera can be given as a "
                      "JSON file of its intrinsics.")
