"""``sightplan plan TEMPLATE MODEL``: make a capture plan from a template."""

from __future__ import annotations

import json
from pathlib import Path
from typing import Annotated, Literal

import typer

from ..plan.site import with_site
from .base import app, console
from .camera_opts import CAMERA_FORMS, FocalOpt, cli_camera
from .errors import friendly_errors, writable_file
from .flight import (
    AltitudeOpt,
    MinHeightOpt,
    StationOpt,
    VlosOpt,
    default_flight_settings,
    parse_point,
    print_feasibility,
)
from .fourd import (
    ActualOpt,
    BasisOpt,
    DateOpt,
    RealityOpt,
    RulesOpt,
    ScheduleOpt,
    UnscheduledOpt,
    dated_scene,
    with_reality,
)
from .loading import georef_kwargs, load_with_progress, warn_if_far

TemplateName = Literal["facade", "orbit", "lawnmower", "bridge", "route"]


@app.command("plan")
@friendly_errors
def plan_command(
    template: Annotated[TemplateName, typer.Argument(
        help="facade (grids around the sides), orbit (rings), lawnmower (nadir grid), bridge (passes along an axis) "
             "or route (indoor polyline)")],
    model: Annotated[str, typer.Argument(help="IFC or mesh file; 'sample' for the bundled Duplex model")],
    output: Annotated[Path, typer.Option("-o", "--output", help="Plan file to write (sightplan JSON)")] = Path("plan.json"),
    camera: Annotated[str, typer.Option(help="Camera: " + CAMERA_FORMS)] = "p4p",
    focal_mm: FocalOpt = None,
    safety_distance: Annotated[float | None, typer.Option(
        "--safety-distance", help="Least distance g to the model (m); default 10, 0.3 for a route")] = None,
    overlap: Annotated[float, typer.Option(help="Image overlap l, 0 ≤ l < 1")] = 0.8,
    radius: Annotated[list[float] | None, typer.Option(
        help="orbit: ring radius (m), once per ring; default: the targets' half-diagonal + the safety distance")] = None,
    height: Annotated[list[float] | None, typer.Option(
        help="orbit: ring height (m), once per ring (default: layers by overlap from the minimum height to the safety "
             "distance above the top); bridge: height of a side pass (default: layers by overlap)")] = None,
    step: Annotated[float | None, typer.Option(
        help="orbit: degrees between frames (default: by overlap); route: metres between frames")] = None,
    altitude: Annotated[float | None, typer.Option(help="lawnmower: camera height above the model's base (m)")] = None,
    gsd: Annotated[float | None, typer.Option(help="lawnmower: ground sampling distance on the model's top (m/px)")] = None,
    side_overlap: Annotated[float, typer.Option(help="lawnmower: overlap between lines")] = 0.7,
    point: Annotated[list[str] | None, typer.Option(
        help="route: a point 'x,y,z' of the walked polyline; bridge: a point 'x,y' of the axis; in order")] = None,
    footprint: Annotated[str, typer.Option(
        help="facade: grids on the sides of the bounding 'box', or around the model's real 'outline'")] = "box",
    oblique_pitch: Annotated[float | None, typer.Option(
        help="lawnmower: add crossed east–west lines with the gimbal at this pitch (e.g. -60): a double grid")] = None,
    routes: Annotated[Path | None, typer.Option(
        help="route: polylines from a file (JSON lists of [x, y, z], or CSV route,x,y,z), one mission each")] = None,
    aim: Annotated[str, typer.Option(help="orbit: aim at the model's 'centre' or its nearest 'surface'")] = "centre",
    under_deck: Annotated[bool, typer.Option(help="bridge: add a pass under the deck, looking up")] = True,
    deck_z: Annotated[float | None, typer.Option(help="bridge: height of the deck's underside (default: found)")] = None,
    vlos_radius: VlosOpt = 500.0,
    ground_station: StationOpt = None,
    aircraft: Annotated[str | None, typer.Option(
        help="Aircraft preset (p4p, m3e, m300), rover preset for a route (walker-360, spot, tracked), or a JSON file "
             "of its fields; 'none': no battery. Default p4p, walker-360 for a route")] = None,
    altitude_limit: AltitudeOpt = 120.0,
    min_height: MinHeightOpt = None,
    split: Annotated[bool, typer.Option(help="Split missions to keep line of sight and fit the batteries")] = True,
    date: DateOpt = None,
    schedule: ScheduleOpt = None,
    rules: RulesOpt = None,
    reality: RealityOpt = None,
    prefer_actual: ActualOpt = False,
    date_basis: BasisOpt = "finish",
    unscheduled: UnscheduledOpt = "present",
    cache: Annotated[bool, typer.Option(help="Reuse the model cache")] = True,
) -> None:
    """Make a capture plan from a template around a model, check that it can be flown, and write it."""
    from ..errors import PlanError
    from ..plan.format import write_plan
    from ..plan.templates import read_routes
    from ..plan.templates.registry import WALKED, TemplateParams, plan_from_template

    if footprint not in ("box", "outline"):  # before the model is loaded
        raise PlanError(f"--footprint must be 'box' or 'outline', got {footprint!r}")
    cam = cli_camera(camera, focal_mm)
    scene, _ = load_with_progress(console, model, cache)
    scene = dated_scene(console, scene, model, schedule, rules, prefer_actual, date, date_basis, unscheduled)
    obstacles = with_reality(console, scene, reality)  # templates go around the model; checks see everything
    walked = template in WALKED
    settings = default_flight_settings(walked, safety_distance, None if walked else vlos_radius,
                                       None if walked else ground_station, aircraft, None if walked else altitude_limit,
                                       min_height=min_height)
    params = TemplateParams(
        overlap=overlap, footprint=footprint, radius_m=tuple(radius or ()), height_m=tuple(height or ()), step=step,
        aim=aim, altitude_m=altitude, gsd_m=gsd, side_overlap=side_overlap, oblique_pitch_deg=oblique_pitch,
        axis=tuple(tuple(parse_point(q if q.count(",") == 2 else q + ",0", "bridge axis point")[:2])
                   for q in (point or ())) if template == "bridge" else (),
        under_deck=under_deck, deck_z_m=deck_z,
        points=tuple(tuple(parse_point(q, "route point")) for q in (point or ())) if template == "route" else (),
        routes=read_routes(routes) if template == "route" and routes is not None else None)
    plan, report = plan_from_template(template, scene, cam, params, settings, obstacles=obstacles, split=split)
    write_plan(plan, output)
    print_feasibility(console, report, f"{template} plan around {Path(str(model)).name} — {cam.name or camera}")
    if "dropped_frames" in plan.parameters:
        dropped = int(plan.parameters["dropped_frames"])
        console.print(f"dropped {dropped} frame(s) of the template: {plan.parameters.get('dropped_reason')}" if dropped
                      else "dropped no frame: every frame of the template has a target of the model in view",
                      highlight=False)
    params = {k: v for k, v in plan.parameters.items() if k.endswith("_m") and isinstance(v, float)}
    if params:
        console.print(", ".join(f"{k.removesuffix('_m').replace('_', ' ')} {v:.3g} m" for k, v in params.items()))
    console.print(f"wrote {output} — evaluate it with `sightplan evaluate {model} {output}`")


@app.command("check")
@friendly_errors
def check_command(
    plan_file: Annotated[str, typer.Argument(metavar="PLAN", help="Plan file (any format `sightplan evaluate` reads)")],
    model: Annotated[str, typer.Argument(help="IFC or mesh file; 'sample' for the bundled Duplex model")],
    safety_distance: Annotated[float | None, typer.Option(
        "--safety-distance", help="Least distance to the model (m); default 5, 0.3 for a walked route")] = None,
    vlos_radius: Annotated[float | None, typer.Option(
        "--vlos-radius", help="VLOS radius around the pilot (m); 0: no check. Default 500, none for a walked route")] = None,
    ground_station: StationOpt = None,
    aircraft: Annotated[str | None, typer.Option(
        help="Aircraft or rover preset, a JSON file, or 'none'. Default p4p, walker-360 for a walked route")] = None,
    altitude_limit: Annotated[float | None, typer.Option(
        "--altitude-limit", help="FAA §107.51 limit (m); 0: no check. Default 120, none for a walked route")] = None,
    min_height: MinHeightOpt = None,
    split: Annotated[bool, typer.Option(help="Split the missions to keep line of sight and fit the batteries "
                                             "(write the result with -o)")] = False,
    output: Annotated[Path | None, typer.Option("-o", "--output", help="Write the (split) plan here")] = None,
    json_out: Annotated[Path | None, typer.Option("--json", help="Write every waypoint's and mission's result as JSON")] = None,
    camera: Annotated[str | None, typer.Option(
        help="Camera of a poses CSV or a flight-app mission: " + CAMERA_FORMS)] = None,
    focal_mm: FocalOpt = None,
    date: DateOpt = None,
    schedule: ScheduleOpt = None,
    rules: RulesOpt = None,
    reality: RealityOpt = None,
    prefer_actual: ActualOpt = False,
    date_basis: BasisOpt = "finish",
    unscheduled: UnscheduledOpt = "present",
    cache: Annotated[bool, typer.Option(help="Reuse the model cache")] = True,
) -> None:
    """Check that a plan can be flown: safety distance, line of sight, altitude limit, minimum height and batteries.

    Exits with status 1 when a check fails, so scripts can stop on it."""
    from ..plan.checks.feasibility import check_plan, plan_flights
    from ..plan.format import write_plan
    from ..plan.load import load_plan

    if json_out is not None:
        writable_file(json_out, "--json")  # before the checks run, not after
    scene, _ = load_with_progress(console, model, cache)
    scene = dated_scene(console, scene, model, schedule, rules, prefer_actual, date, date_basis, unscheduled)
    scene = with_reality(console, scene, reality)
    plan = load_plan(plan_file, camera=cli_camera(camera, focal_mm), **georef_kwargs(scene))
    warn_if_far(console, scene, plan)
    walked = plan.parameters.get("template") == "indoor_route"  # a rover or a walker: no sight line, no altitude limit
    settings = default_flight_settings(walked, safety_distance, vlos_radius, ground_station, aircraft, altitude_limit,
                                       drone_safety_m=5.0, min_height=min_height)
    report = (plan_flights if split else check_plan)(scene, plan, settings)
    print_feasibility(console, report, f"{Path(plan_file).name} against {Path(str(model)).name}")
    if output is not None:
        from ..plan.checks.gate import record_checks

        write_plan(record_checks(with_site(report.plan, scene, replace_takeoff=True), report, settings), output)
        console.print(f"wrote {output}")
    if json_out is not None:
        json_out.write_text(json.dumps(report.to_dict(), indent=1), encoding="utf-8")
        console.print(f"wrote {json_out}")
    if not report.ok:
        raise typer.Exit(1)
