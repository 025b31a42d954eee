"""``sightplan plan TEMPLATE MODEL``: make a capture plan from a template."""

from __future__ import annotations

from pathlib import Path
from typing import Annotated, Literal

import typer
from rich.table import Table

from .errors import friendly_errors
from .loading import load_with_progress
from .main import app, console

TemplateName = Literal["facade", "orbit", "lawnmower", "route"]


@app.command("plan")
@friendly_errors
def plan_command(
    template: Annotated[TemplateName, typer.Argument(
        help="facade (grids on the four sides), orbit (rings), lawnmower (nadir grid) or route (indoor polyline)")],
    model: Annotated[str, typer.Argument(help="IFC or mesh file; 'sample' for the bundled Duplex model")],
    output: Annotated[Path, typer.Option("-o", "--output", help="Plan file to write (sightplan JSON)")] = Path("plan.json"),
    camera: Annotated[str, typer.Option(help="Camera (catalogue id, `sightplan cameras`)")] = "p4p",
    safety_distance: Annotated[float, typer.Option(help="facade: distance g from the model's sides (m)")] = 10.0,
    overlap: Annotated[float, typer.Option(help="Image overlap l, 0 ≤ l < 1")] = 0.8,
    radius: Annotated[list[float] | None, typer.Option(help="orbit: ring radius (m), once per ring")] = None,
    height: Annotated[list[float] | None, typer.Option(help="orbit: ring height (m), once per ring")] = None,
    step: Annotated[float | None, typer.Option(
        help="orbit: degrees between frames (default: by overlap); route: metres between frames")] = None,
    altitude: Annotated[float | None, typer.Option(help="lawnmower: camera height above the model's base (m)")] = None,
    gsd: Annotated[float | None, typer.Option(help="lawnmower: ground sampling distance on the model's top (m/px)")] = None,
    side_overlap: Annotated[float, typer.Option(help="lawnmower: overlap between lines")] = 0.7,
    point: Annotated[list[str] | None, typer.Option(help="route: a point 'x,y,z' of the walked polyline, in order")] = None,
    cache: Annotated[bool, typer.Option(help="Reuse the model cache")] = True,
) -> None:
    """Make a capture plan from a template around a model and write it as sightplan JSON."""
    from ..camera.catalogue import get_camera
    from ..errors import PlanError
    from ..plan.format import write_plan
    from ..plan.templates import facade_grid, indoor_route, lawnmower, orbit

    scene, _ = load_with_progress(console, model, cache)
    cam = get_camera(camera)
    if template == "facade":
        plan = facade_grid(scene, cam, safety_distance, overlap)
    elif template == "orbit":
        if not radius or not height:
            raise PlanError("an orbit needs --radius and --height, once per ring")
        plan = orbit(scene, cam, radius, height, step_deg=step, overlap=overlap)
    elif template == "lawnmower":
        plan = lawnmower(scene, cam, altitude_m=altitude, gsd_m=gsd, front_overlap=overlap, side_overlap=side_overlap)
    else:
        if not point or step is None:
            raise PlanError("a route needs --point x,y,z at least twice and --step in metres")
        pts = []
        for p in point:
            try:
                xyz = [float(v) for v in p.split(",")]
            except ValueError:
                xyz = []
            if len(xyz) != 3:
                raise PlanError(f"route point {p!r} must be three numbers 'x,y,z' in metres")
            pts.append(xyz)
        plan = indoor_route(cam, pts, step)
    write_plan(plan, output)
    t = Table("mission", "frames", title=f"{template} plan around {Path(str(model)).name} — {cam.name or camera}",
              title_justify="left")
    for m in plan.missions:
        t.add_row(m.name, str(m.stop - m.start))
    t.add_row("[bold]total", f"[bold]{len(plan)}")
    console.print(t)
    params = {k: v for k, v in plan.parameters.items() if k.endswith("_m") and isinstance(v, float)}
    if params:
        console.print(", ".join(f"{k.removesuffix('_m').replace('_', ' ')} {v:.3g} m" for k, v in params.items()))
    console.print(f"wrote {output} — evaluate it with `sightplan evaluate {model} {output}`")
