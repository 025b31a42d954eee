"""``sightplan export PLAN --format …``: write a plan for a flight app or a GIS."""

from __future__ import annotations

from pathlib import Path
from typing import Annotated

import typer

from ..formats.mavlink import Autopilot
from ..formats.registry import FORMATS, ExportFormat, export_choices, writers_with
from .base import app, console
from .camera_opts import CAMERA_FORMS, FocalOpt, cli_camera
from .errors import friendly_errors
from .flight import parse_gimbal, parse_point

MIN_ALTITUDE_M = 2.0


def parse_origin(text: str):
    """'LAT,LON[,HEIGHT]' → (lat, lon, height)."""
    from ..geo import GeoreferenceError

    try:
        vals = [float(v) for v in text.split(",")]
    except ValueError:
        vals = []
    if len(vals) not in (2, 3):
        raise GeoreferenceError(f"--origin {text!r} must be 'LAT,LON' or 'LAT,LON,HEIGHT' in degrees and metres")
    return vals[0], vals[1], vals[2] if len(vals) == 3 else 0.0


@app.command("export")
@friendly_errors
def export_command(
    plan_file: Annotated[str, typer.Argument(metavar="PLAN", help="Plan file (sightplan JSON or any format sightplan reads)")],
    fmt: Annotated[ExportFormat, typer.Option("--format", "-f", help=export_choices())],
    output: Annotated[Path | None, typer.Option("-o", "--output", help="File to write (default: PLAN's name with the "
                                                "format's suffix); one file per mission where the format needs it")] = None,
    model: Annotated[str | None, typer.Option(help="Model whose georeference places the plan (IfcMapConversion or "
                                              "IfcSite latitude/longitude) when the plan carries none")] = None,
    origin: Annotated[str | None, typer.Option(help="Georeference by hand: 'LAT,LON[,HEIGHT]' of the model point "
                                               "--origin-point (default 0,0,0); overrides the plan's and the model's")] = None,
    origin_point: Annotated[str, typer.Option(help="Model point 'x,y,z' that --origin gives the position of")] = "0,0,0",
    north: Annotated[float, typer.Option(
        help="With --origin: true heading of the model's +Y axis (° clockwise from north)")] = 0.0,
    takeoff: Annotated[str | None, typer.Option(help="Take-off point 'x,y,z' on the ground (model frame) of every "
                                                "mission, the zero of relative altitudes. Default: each mission's own "
                                                "ground station")] = None,
    speed: Annotated[float, typer.Option(help="Flight speed between waypoints (m/s)")] = 5.0,
    mission: Annotated[int | None, typer.Option(help="Export only this mission (1 = the first)")] = None,
    autopilot: Annotated[Autopilot | None, typer.Option(
        help="qgc and wpl: the flight controller the file is for (they accept different commands). "
             "Default: px4 for qgc, ardupilot for wpl")] = None,
    aircraft: Annotated[str | None, typer.Option(
        help="wpml: the DJI aircraft the file is for: m3e, m350-h20, m350-p1, m300-h20, m300-p1. "
             "Default: the one that carries the plan's camera (others are refused)")] = None,
    camera: Annotated[str | None, typer.Option(help="Camera of a poses CSV: " + CAMERA_FORMS)] = None,
    focal_mm: FocalOpt = None,
    cache: Annotated[bool, typer.Option(help="Reuse the model cache")] = True,
    force: Annotated[bool, typer.Option(help="Export a plan that fails its flight checks (they are printed)")] = False,
    gimbal: Annotated[str | None, typer.Option(
        help="The gimbal's pitch slew rate and settling time, 'DEG_PER_S,SECONDS' (default 30,0.5): they size the "
             "waits between a change of pitch and the photo, and the replay of MAVLink files")] = None,
) -> None:
    """Export a plan to a flight app (QGroundControl, Mission Planner, DJI Pilot 2, Litchi) or to KML/GeoJSON."""
    from ..export import file_summary
    from ..export.files import export_files, takeoff_point
    from ..geo import Georeference, resolve_georeference
    from ..plan.load import load_plan
    from .loading import load_with_progress

    the_gimbal = parse_gimbal(gimbal)  # refused before anything is read
    plan = load_plan(plan_file, camera=cli_camera(camera, focal_mm))
    scene = load_with_progress(console, model, cache)[0] if model else None
    user = None
    if origin:
        lat, lon, h = parse_origin(origin)
        user = Georeference.from_origin(lat, lon, h, north, parse_point(origin_point, "--origin-point"), source="--origin")
    geo = resolve_georeference(user, plan.parameters.get("georeference"),
                               Georeference.from_scene_metadata(scene.metadata) if scene is not None else None,
                               what=f"a {fmt} export")
    takeoff_m = parse_point(takeoff, "--takeoff") if takeoff else takeoff_point(
        plan, scene, hint="give --takeoff x,y,z (model frame, on the ground) or --model MODEL to take the south-west "
                          "corner of the plan's region")
    spec = FORMATS[fmt]
    if autopilot is not None and not spec.autopilot:
        console.print(f"[yellow]warning:[/] --autopilot is for the {' and '.join(writers_with('autopilot'))} formats; "
                      f"a {fmt} export ignores it", highlight=False)
    from ..errors import PlanError
    from ..plan.checks.gate import export_violations

    failed = export_violations(plan, takeoff_m, scene, per_mission=takeoff is None)  # against --model, else recorded
    if failed and not force:
        more = f" (and {len(failed) - 1} more)" if len(failed) > 1 else ""
        raise PlanError(f"the plan fails its flight checks: {failed[0]}{more}; fix the plan, or export it anyway "
                        "with --force")
    for v in failed:
        console.print(f"[yellow]warning:[/] exported with --force despite: {v}", highlight=False)
    out = output or Path(plan_file).with_suffix(spec.suffix)
    if aircraft is not None and not spec.aircraft_choice:
        console.print(f"[yellow]warning:[/] --aircraft is for the {' and '.join(writers_with('aircraft_choice'))} "
                      f"format; a {fmt} export ignores it", highlight=False)
    written: list = []
    paths = export_files(plan, fmt, out, geo, takeoff_m, speed_m_s=speed, mission=mission, mission_label="--mission",
                         autopilot=autopilot, aircraft=aircraft if spec.aircraft_choice else None,
                         per_mission_takeoff=takeoff is None, report=written, faithful=not force,
                         gimbal=the_gimbal)
    console.print(f"georeference: {geo.describe()}", highlight=False)
    low = [f for f in written if f.lowest_altitude_m < MIN_ALTITUDE_M - 1e-6]
    if low:
        console.print(f"[yellow]warning:[/] {len(low)} file(s) have waypoints less than {MIN_ALTITUDE_M:g} m above the "
                      f"take-off point (lowest {min(f.lowest_altitude_m for f in low):+.1f} m, in {low[0].path.name}): "
                      "raise them before flying, or check --takeoff", highlight=False)
    summaries = {f.path: f.summary() for f in written}
    for p in paths:
        console.print(f"wrote {p} {summaries.get(Path(p)) or '(' + file_summary(fmt, autopilot) + ')'}", highlight=False)
