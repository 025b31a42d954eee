"""``sightplan optimize MODEL``: the plan that meets the targets with the fewest frames, minutes and batteries."""

from __future__ import annotations

from pathlib import Path
from typing import Annotated

import typer
from rich.table import Table

from .base import ENGINE_HELP, app, console
from .camera_opts import CAMERA_FORMS, FocalOpt, cli_camera
from .errors import friendly_errors, writable_file
from .flight import AltitudeOpt, MinHeightOpt, StationOpt, VlosOpt, default_flight_settings, print_feasibility
from .fourd import ActualOpt, BasisOpt, DateOpt, RulesOpt, ScheduleOpt, UnscheduledOpt, dated_scene
from .loading import load_with_progress, stage_bars


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
    compare: Annotated[bool, typer.Option(
        help="Also plan, flight-check and score the template grid (facade box and outline, orbit, lawn-mower at 60, "
             "70 and 80 % overlap) and set the optimiser beside the best one, like for like and at its minutes")
                       ] = True,
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
        _compare(scene, cam, goal, result, flight, settings)
    console.print(f"wrote {output} — evaluate it with `sightplan evaluate {model} {output}`")


def _pct(value: float | None, reference: float | None) -> str:
    if value is None or not reference:
        return ""
    return f"{100 * (value / reference - 1):+.0f} %".replace("-", "−")


def _compare(scene, cam, goal, result, flight, settings) -> None:
    """The template grid, flight-checked and scored against the optimiser's targets, and the optimiser beside the
    best template: with every target, like for like (the template's targets) and at the template's minutes."""
    from ..optimize import Scored, compare_with_best_template, score_plan

    with stage_bars(console) as progress:
        c = compare_with_best_template(scene, cam, goal, result, flight=flight, settings=settings, progress=progress)
    et = result.targets
    for label, why in c.failed.items():
        console.print(f"[yellow]{label}: {why}", highlight=False)
    if c.best is None:
        console.print("[yellow]no template of the grid could be planned here: nothing to compare", highlight=False)
        return

    def cells(r: Scored) -> list[str]:
        s = r.score
        n = len(r.report.violations)
        checks = "ok" if r.report.ok else f"{n} violation{'' if n == 1 else 's'}"
        return [str(len(r.plan)), "—" if r.minutes is None else f"{r.minutes:.1f}", str(len(r.plan.missions)), checks,
                f"{r.met} of {et.n_active}", "—" if s.VC is None else f"{100 * s.VC:.1f}",
                "—" if s.median_R_m_px is None else f"{1000 * s.median_R_m_px:.2f}"]

    columns = ("frames", "minutes", "missions", "checks", "targets met", "VC %", "median R_i (mm/px)")
    grid = Table(title="the template grid (same camera, safety distance and targets; the best: checks pass, most "
                       "targets met, then fewest minutes)", title_justify="left")
    for col in ("template", *columns):
        grid.add_column(col, justify="left" if col in ("template", "checks") else "right")
    for r in c.templates:
        grid.add_row(f"{r.label} (best)" if r is c.best else r.label, *cells(r))
    console.print(grid)

    mine = Scored("optimised, every target", result.plan, result.report,
                  score_plan(scene, result.plan, et, scale=settings.scale, engine=settings.engine,
                             cache_dir=settings.cache_dir))
    best = c.best
    table = Table(title=f"against the best template, {best.label}", title_justify="left")
    for col in ("plan", *columns, "against the template"):
        table.add_column(col, justify="left" if col in ("plan", "checks", "against the template") else "right")
    table.add_row(best.label, *cells(best), "")
    for r in (mine, c.like_for_like):
        if r is not None:
            missed = int((best.score.met & ~r.score.met).sum())
            table.add_row(r.label, *cells(r), f"frames {_pct(len(r.plan), len(best.plan))}, minutes "
                          f"{_pct(r.minutes, best.minutes)}, "
                          + ("all its targets met" if not missed else f"misses {missed} of its targets"))
    if c.equal_minutes is not None:
        r = c.equal_minutes
        table.add_row(f"{r.label} ({best.minutes:.1f})", *cells(r),
                      f"{r.met - best.met:+d} targets met".replace("-", "−"))
    console.print(table)
