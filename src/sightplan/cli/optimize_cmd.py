"""``sightplan optimize MODEL``: the plan that meets the targets with the fewest frames, minutes and batteries."""

from __future__ import annotations

from pathlib import Path
from typing import Annotated

import typer
from rich.table import Table

from ..errors import PlanError
from .base import ENGINE_HELP, app, console
from .camera_opts import CAMERA_FORMS, FocalOpt, cli_camera
from .errors import friendly_errors, writable_file
from .flight import AltitudeOpt, MinHeightOpt, StationOpt, VlosOpt, default_flight_settings, print_feasibility
from .fourd import ActualOpt, BasisOpt, DateOpt, RulesOpt, ScheduleOpt, UnscheduledOpt, dated_scene
from .loading import load_with_progress, stage_bars

COMPARED = ("facade", "orbit", "lawnmower")


@app.command("optimize")
@friendly_errors
def optimize_command(
    model: Annotated[str, typer.Argument(help="IFC or mesh file; 'sample' for the bundled Duplex model")],
    output: Annotated[Path, typer.Option("-o", "--output", help="Plan file to write (sightplan JSON)")] = Path(
        "plan.json"),
    targets: Annotated[Path | None, typer.Option(
        help="Targets TOML: k, max_ssd_m_px, max_angle_deg, omega_px, min_features and [[rule]] tables by ifc_class, "
             "storey, discipline or global_id (see the README)")] = None,
    k: Annotated[int | None, typer.Option("--k", help="Views each target element needs (default 3)")] = None,
    max_ssd: Annotated[float | None, typer.Option(
        "--max-ssd", help="Coarsest surface sampling distance a view may have (m/px); default: the camera's at the "
                          "safety distance × 1.5")] = None,
    max_angle: Annotated[float | None, typer.Option("--max-angle", help="Widest angle to the surface (°), default "
                                                                        "45")] = None,
    budget_frames: Annotated[int | None, typer.Option("--budget-frames", help="At most this many frames")] = None,
    budget_minutes: Annotated[float | None, typer.Option("--budget-minutes", help="At most this many minutes of "
                                                                                  "flight")] = None,
    batteries: Annotated[int | None, typer.Option(help="At most this many battery charges")] = None,
    from_plan: Annotated[str | None, typer.Option(
        "--from", help="A plan to improve: its frames are kept unless redundant, and frames are added for the "
                       "targets it misses")] = None,
    camera: Annotated[str, typer.Option(help="Camera: " + CAMERA_FORMS)] = "p4p",
    focal_mm: FocalOpt = None,
    safety_distance: Annotated[float | None, typer.Option(
        "--safety-distance", help="Least distance to the model (m); default 10, 0.3 indoors (a 360° camera)")] = None,
    vlos_radius: VlosOpt = 500.0,
    ground_station: StationOpt = None,
    aircraft: Annotated[str | None, typer.Option(help="Aircraft preset (p4p, m3e, m300) or a JSON file of its fields; "
                                                      "'none': no battery. Default p4p")] = None,
    altitude_limit: AltitudeOpt = 120.0,
    min_height: MinHeightOpt = None,
    scale: Annotated[float, typer.Option(help="Resolution scale the candidates are cast at")] = 0.25,
    spacing: Annotated[float | None, typer.Option(
        help="Spacing of the candidate views' anchors on the surfaces (m); default: a sixth of a frame's "
             "footprint at the safety distance. A 360° camera: of the grid of positions on each storey, default "
             "1.0")] = None,
    engine: Annotated[str, typer.Option(help=ENGINE_HELP)] = "auto",
    compare: Annotated[bool, typer.Option(help="Also plan and score the facade, orbit and lawn-mower templates at the "
                                               "same safety distance, for comparison")] = True,
    date: DateOpt = None,
    schedule: ScheduleOpt = None,
    rules: RulesOpt = None,
    prefer_actual: ActualOpt = False,
    date_basis: BasisOpt = "finish",
    unscheduled: UnscheduledOpt = "present",
    cache: Annotated[bool, typer.Option(help="Reuse the model cache and the per-frame cache")] = True,
    cluster: Annotated[str | None, typer.Option(
        help="Cast the candidates on a dask cluster: a scheduler address (tcp://host:8786) or local:N for N local "
             "worker processes; frames in the per-frame cache are not cast again")] = None,
    batch_frames: Annotated[int, typer.Option(min=1, help="With --cluster: frames per task")] = 64,
) -> None:
    """Find the plan that meets the targets with the fewest frames, minutes and batteries: candidate views cast once,
    a submodular selection, a route, and the flight checks."""
    from ..optimize import Budget, OptimizeSettings, Targets, optimize
    from ..plan.format import read_plan, write_plan

    writable_file(output, "--output")
    values = {"k": k, "max_ssd_m_px": max_ssd, "max_angle_deg": max_angle}
    goal = Targets.read(targets, **values) if targets is not None else Targets().with_defaults(**values)
    budget = Budget(frames=budget_frames, minutes=budget_minutes, batteries=batteries)
    cam = cli_camera(camera, focal_mm)
    start = read_plan(from_plan) if from_plan is not None else None
    scene, _ = load_with_progress(console, model, cache)
    scene = dated_scene(console, scene, model, schedule, rules, prefer_actual, date, date_basis, unscheduled)
    walked = cam.kind == "equirectangular"  # a 360° camera: an indoor plan, walked storey by storey
    flight = default_flight_settings(walked, safety_distance, None if walked else vlos_radius,
                                     None if walked else ground_station, aircraft, None if walked else altitude_limit,
                                     min_height=min_height, scene=scene)
    settings = OptimizeSettings(scale=scale, engine=engine, spacing_m=spacing, cache_dir=None if cache else False,
                                cluster=cluster, batch_frames=batch_frames)
    with stage_bars(console) as progress:
        result = optimize(scene, cam, goal, budget, flight=flight, settings=settings, start=start, progress=progress)
    write_plan(result.plan, output)
    print_feasibility(console, result.report, f"optimised plan around {Path(str(model)).name} — {cam.name or camera}")
    s = result.summary()
    console.print(f"targets met: {s['met']} of {s['targets']} elements · {s['frames']} frames from {s['candidates']} "
                  f"candidates ({s['removed']} redundant removed) · {s['missions']} missions · "
                  f"{s['minutes']} min · {s['batteries']} batteries", highlight=False)
    console.print(f"{s['stability_views']} frames added so that runs register · {s['unstable_frames']} frames below "
                  f"the stability floor · {s['blind_frames']} frames that see no target", highlight=False)
    if compare and not walked:  # the templates compared are flown outside
        _compare(scene, cam, result, flight, settings)
    console.print(f"wrote {output} — evaluate it with `sightplan evaluate {model} {output}`")


def _compare(scene, cam, result, flight, settings) -> None:
    """The optimised plan beside the facade, orbit and lawn-mower templates on the same model: frames, minutes,
    targets met, VC and median R_i."""
    from ..optimize import score_plan
    from ..plan.templates.registry import plan_from_template

    et = result.targets
    rows = []
    plans = [("optimised", result.plan, result.report)]
    for name in COMPARED:
        try:
            plan, report = plan_from_template(name, scene, cam, {}, flight)
        except PlanError as exc:
            console.print(f"[yellow]{name} template: {exc}", highlight=False)
            continue
        plans.append((name, plan, report))
    for name, plan, report in plans:
        s = score_plan(scene, plan, et, scale=settings.scale, engine=settings.engine, cache_dir=settings.cache_dir)
        rows.append((name, len(plan), report.total_time_s, int(s.met.sum()), s.VC, s.median_R_m_px))
    table = Table(title="against the templates (same camera, safety distance and targets)")
    for col in ("plan", "frames", "minutes", "targets met", "VC %", "median R_i (mm/px)"):
        table.add_column(col, justify="left" if col == "plan" else "right")
    for name, n, t, met, vc, r in rows:
        table.add_row(name, str(n), "—" if t is None else f"{t / 60:.1f}", f"{met} of {et.n_active}",
                      "—" if vc is None else f"{100 * vc:.1f}", "—" if r is None else f"{r * 1000:.2f}")
    console.print(table)
