"""``sightplan info MODEL``."""

from __future__ import annotations

import json
from typing import Annotated

import typer
from rich.table import Table

from ..model.mesh import MeshGrouping
from .base import app, console
from .errors import friendly_errors
from .loading import load_with_progress, print_warnings


@app.command()
@friendly_errors
def info(
    model: Annotated[str, typer.Argument(help="IFC or mesh file; 'sample' for the bundled Duplex model")],
    as_json: Annotated[bool, typer.Option("--json", help="Print the summary as JSON")] = False,
    mesh_elements: Annotated[MeshGrouping, typer.Option(
        help="For a mesh: its elements are the file's objects/nodes, connected components, or single faces")] = "objects",
    mesh_scale: Annotated[float, typer.Option(help="For a mesh: metres per file unit (0.001 for millimetres)")] = 1.0,
    cache: Annotated[bool, typer.Option(help="Reuse the model cache")] = True,
) -> None:
    """Summarise a model: elements by class, discipline and storey; bounds; triangles; the load report."""
    from ..model.summary import summarize

    scene, report = load_with_progress(console, model, cache, mesh_elements, mesh_scale)
    s = summarize(scene, report)
    if as_json:
        typer.echo(json.dumps(s, indent=2, default=str))
        return
    print_summary(s)


def _kv_table(title: str, items: dict) -> Table:
    t = Table("", "", title=title, title_justify="left", show_header=False)
    for k, v in items.items():
        t.add_row(str(k).replace("_", " "), f"{v:.6g}" if isinstance(v, float) else str(v))
    return t


def print_summary(s: dict) -> None:
    """The model summary as readable tables."""
    facts = {k: v for k, v in s.items() if not isinstance(v, dict | list) and v is not None}
    console.print(_kv_table("model", facts))
    lo, hi = s["bounds_m"]["min"], s["bounds_m"]["max"]
    size = [h - lo_ for lo_, h in zip(lo, hi)]
    console.print(f"bounds (m): min {lo}, max {hi}, size {[round(x, 2) for x in size]}")
    if s.get("tied_faces"):
        console.print(f"{s['tied_faces']:,} faces of {s['tied_elements']:,} elements are flush with another element's "
                      "(coincident surfaces: a pixel on them counts for each element)", highlight=False)
    for key in ("by_class", "by_discipline", "by_storey"):
        t = Table(key.removeprefix("by_"), "elements", "targets", "occluders", title=key.replace("_", " "), title_justify="left")
        for name, row in sorted(s[key].items(), key=lambda kv: -kv[1]["elements"]):
            t.add_row(name or "—", *(str(row[c]) for c in ("elements", "targets", "occluders")))
        console.print(t)
    for key in ("excluded", "containers"):
        if s.get(key):
            t = Table("class", "count", title=f"{key} (not elements)", title_justify="left")
            for name, count in sorted(s[key].items(), key=lambda kv: -kv[1]):
                t.add_row(name, str(count))
            console.print(t)
    for key in ("georeference", "site_location"):
        if s.get(key):
            console.print(_kv_table(key.replace("_", " "), s[key]))
    skipped = s.get("skipped") or []
    if skipped:
        t = Table(*skipped[0].keys(), title=f"products without geometry ({len(skipped)})", title_justify="left")
        for row in skipped[:50]:
            t.add_row(*(str(v) for v in row.values()))
        if len(skipped) > 50:
            t.add_row(f"… {len(skipped) - 50} more", *[""] * (len(t.columns) - 1))
        console.print(t)
    else:
        console.print("every product with a Body representation was tessellated (no product skipped)")
    fallbacks = s.get("fallbacks") or []
    if fallbacks:
        t = Table(*fallbacks[0].keys(), title=f"products whose geometry blew up ({len(fallbacks)})", title_justify="left")
        for row in fallbacks[:50]:
            t.add_row(*(str(v) for v in row.values()))
        if len(fallbacks) > 50:
            t.add_row(f"… {len(fallbacks) - 50} more", *[""] * (len(t.columns) - 1))
        console.print(t)
    print_warnings(console, s.get("warnings") or [])


@app.command()
@friendly_errors
def engines(as_json: Annotated[bool, typer.Option("--json", help="Print as JSON")] = False) -> None:
    """The visibility engines on this machine, what `--engine auto` picks, and the OpenGL driver found."""
    from ..engines import available_engines, gl
    from ..engines.registry import best_engine

    names = available_engines()
    probe = gl.probe()
    auto = best_engine() if names else None
    if as_json:
        typer.echo(json.dumps({"available": names, "auto": auto, "opengl": probe}, indent=2))
        return
    t = Table("engine", "status", "notes", title="visibility engines", title_justify="left")
    notes = {"embree": "CPU ray casting (Intel Embree)",
             "gl": (f"OpenGL rasteriser on {probe['renderer']}" + ("" if probe["hardware"] else " (software: CPU)")
                    if probe["available"] else probe["error"]),
             "trimesh": "pure-numpy ray tracer: a slow cross-check"}
    for name in ("embree", "gl", "trimesh"):
        status = "auto" if name == auto else ("available" if name in names else "unavailable")
        t.add_row(name, status, notes[name])
    console.print(t)
