"""``sightplan progress MODEL PLAN``: one plan over the schedule, date by date."""

from __future__ import annotations

from pathlib import Path
from typing import Annotated

import typer
from rich.table import Column, Table

from ..engines.base import EngineName
from .base import ENGINE_HELP, app, console
from .camera_opts import CAMERA_FORMS, FocalOpt, cli_camera
from .errors import cell, friendly_errors
from .evaluate_cmd import EVALUATION_STAGES
from .fourd import (
    ActualOpt,
    BasisOpt,
    RealityOpt,
    RulesOpt,
    ScheduleOpt,
    UnscheduledOpt,
    check_date_options,
    link_with_schedule,
    with_reality,
)
from .loading import georef_kwargs, load_with_progress, print_warnings
from .stages import StageDisplay, step


@app.command("progress")
@friendly_errors
def progress_command(
    model: Annotated[str, typer.Argument(help="IFC or mesh file; 'sample' for the bundled Duplex model")],
    plan: Annotated[str, typer.Argument(help="Plan file (any format `sightplan evaluate` reads)")],
    schedule: ScheduleOpt = None,
    rules: RulesOpt = None,
    reality: RealityOpt = None,
    prefer_actual: ActualOpt = False,
    date: Annotated[list[str] | None, typer.Option(help="A capture date YYYY-MM-DD (repeat for several)")] = None,
    every_task: Annotated[bool, typer.Option(help="Evaluate at every day on which an element comes to stand")] = False,
    date_basis: BasisOpt = "finish",
    unscheduled: UnscheduledOpt = "present",
    camera: Annotated[str | None, typer.Option(
        help="Camera of a poses CSV or a flight-app mission: " + CAMERA_FORMS)] = None,
    focal_mm: FocalOpt = None,
    engine: Annotated[EngineName, typer.Option(help=ENGINE_HELP)] = "auto",
    scale: Annotated[float, typer.Option(help="Resolution scale s")] = 0.5,
    feature_density: Annotated[float, typer.Option(help="Surface features per m²")] = 1.0,
    out: Annotated[Path, typer.Option(help="Folder for progress.csv and progress.png")] = Path("sightplan-progress"),
    cache: Annotated[bool, typer.Option(help="Reuse the model and per-frame caches")] = True,
) -> None:
    """Evaluate one plan at several capture dates of a 4D model: a table and a plot of every metric over time."""
    from ..errors import ScheduleError
    from ..evaluate import EvaluationSettings
    from ..plan.load import load_plan
    from ..series import evaluate_series, schedule_days

    check_date_options(date_basis, unscheduled)
    if not date and not every_task:
        raise ScheduleError("give --date (once per capture date) or --every-task")
    scene, _ = load_with_progress(console, model, cache)
    with step(console, "linking the schedule and reading the plan"):
        scene = link_with_schedule(console, scene, model, schedule, rules, prefer_actual)
        scene = with_reality(console, scene, reality)
        the_plan = load_plan(plan, camera=cli_camera(camera, focal_mm), **georef_kwargs(scene))
    days = list(date or []) + (schedule_days(scene, date_basis) if every_task else [])  # type: ignore[arg-type]
    settings = EvaluationSettings(engine=engine, scale=scale, feature_density=feature_density)
    with StageDisplay(console, {"dates": "capture dates", **EVALUATION_STAGES}) as display:
        at = [""]  # the date evaluated now: each of its stages' lines says which

        def dates(i: int, n: int, day: str) -> None:
            at[0] = f"at {day} ({min(i + 1, n)} of {n} dates)"
            display("dates", i, n, day)

        series = evaluate_series(scene, the_plan, days, settings, basis=date_basis, unscheduled=unscheduled,  # type: ignore[arg-type]
                                 cache_dir=None if cache else False, progress=dates,
                                 stages=lambda stage, done, total: display(stage, done, total, at[0]))
    print_warnings(console, series.warnings)
    t = Table(Column("date", no_wrap=True, min_width=10), "built", "VC %", "V̄C %", "VR", "R (m/px)", "O (°)", "T", "stable %",
              title=f"{Path(plan).name} over the schedule of {Path(str(model)).name}", title_justify="left")
    for r in series.rows():
        t.add_row(r["date"] + (" (=)" if r["same_as"] else ""), str(r["built"]), cell(r["VC"], ".1f"),
                  cell(r["VC_bar"], ".1f"), cell(r["VR"], ".1f"), cell(r["R"], ".4f"), cell(r["O"], ".1f"),
                  cell(r["T"], ".0f"), cell(r["stable_share"], ".0f"))
    console.print(t)
    out.mkdir(parents=True, exist_ok=True)
    csv_path = series.write_csv(out / "progress.csv")
    with step(console, "drawing progress.png"):
        png = series.plot(out / "progress.png", title=f"{Path(plan).name} over the schedule of {Path(str(model)).name}")
    console.print(f"(=): the same elements stand as on an earlier date, not cast again\nwrote {csv_path}, {png}")
