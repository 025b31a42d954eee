"""``sightplan loop MODEL PLAN -o OUT``: render the plan, reconstruct it, validate, measure and study it."""

from __future__ import annotations

from pathlib import Path
from typing import Annotated

import typer
from rich.table import Table

from ..engines.base import EngineName
from .base import ENGINE_HELP, app, console
from .camera_opts import DEFAULT_PRESET, FocalOpt, PhotoRealismOpt, PlanCameraOpt, SeedOpt, cli_camera
from .errors import cell, friendly_errors
from .fourd import (
    ActualOpt,
    BasisOpt,
    DateOpt,
    RulesOpt,
    ScheduleOpt,
    UnscheduledOpt,
    check_date_options,
    dated_scene,
)
from .loading import georef_kwargs, load_with_progress, print_warnings, stage_bars

STAGE_NAMES = {"render": "rendering the photographs", "reconstruct": "structure from motion",
               "evaluate": "evaluating the plan", "validate": "validating against the reconstruction",
               "measure": "measuring per element", "study": "the study"}


def comparison_table(study, title: str) -> Table:
    """The per-element correlations beside the paper's Table 2."""
    from ..loop.study import LABELS, PAPER_QUALITIES

    t = Table("predictor", "with", "n", "Pearson r", "p", "Spearman ρ", "p", "paper",
              *(f"paper r ({q})" for q in PAPER_QUALITIES), title=title, title_justify="left")
    for r in study.comparison():
        t.add_row(LABELS.get(r["predictor"], r["predictor"]), r["quality"], str(r["n"]), cell(r["pearson_r"], "+.3f"),
                  cell(r["pearson_p"], ".2g"), cell(r["spearman_r"], "+.3f"), cell(r["spearman_p"], ".2g"),
                  r["paper_metric"] or "—", *(cell(r[f"paper_r_{q}"], "+.2f") for q in PAPER_QUALITIES))
    return t


@app.command("loop")
@friendly_errors
def loop_command(
    model: Annotated[str, typer.Argument(help="IFC or mesh file; 'sample' for the bundled Duplex model")],
    plan: Annotated[str, typer.Argument(help="The plan (any format `sightplan evaluate` reads)")],
    out: Annotated[Path, typer.Option("--out", "-o", help="Folder for the images, the reconstruction and the study")
                   ] = Path("sightplan-loop"),
    scale: Annotated[float | None, typer.Option(
        help="Resolution scale of the rendered photographs (default: about 0.2 Mpx each, 0.1 of a 20 MP camera; "
             "with --reconstruction, its own)")] = None,
    matcher: Annotated[str, typer.Option(help="SfM matcher: auto, sequential, spatial or exhaustive")] = "auto",
    render_engine: Annotated[str, typer.Option(help="Renderer: embree (CPU) or gl")] = "embree",
    reconstruction: Annotated[Path | None, typer.Option(
        help="An existing reconstruction of this plan's photographs: skip rendering and reconstructing")] = None,
    paper_table: Annotated[Path | None, typer.Option(
        help="The paper's Table 2 as CSV, to set its correlations beside the study's (default: the bundled table)")
                           ] = None,
    registration_error: Annotated[float | None, typer.Option(
        "--registration-error", "-e", help="e for the validation (m); default: the reconstruction's residual")] = None,
    tolerance: Annotated[float | None, typer.Option(
        help="τ: a point within this distance (m) of an element is on it; default 1.2·e + 3·ρ")] = None,
    radius: Annotated[float | None, typer.Option(
        help="r: a point covers the surface within this distance (m); default max(τ, the points' own spacing)")
                   ] = None,
    threshold: Annotated[float, typer.Option(help="Completeness from which an element counts as reconstructed")
                         ] = 0.5,
    date: DateOpt = None,
    schedule: ScheduleOpt = None,
    rules: RulesOpt = None,
    prefer_actual: ActualOpt = False,
    date_basis: BasisOpt = "finish",
    unscheduled: UnscheduledOpt = "present",
    camera: PlanCameraOpt = None,
    focal_mm: FocalOpt = None,
    engine: Annotated[EngineName, typer.Option(help=ENGINE_HELP)] = "auto",
    eval_scale: Annotated[float, typer.Option(help="Resolution scale s of the evaluation's rays")] = 1.0,
    omega: Annotated[float, typer.Option(help="Visibility threshold Ω in pixels of the photographs")] = 625.0,
    photo_realism: PhotoRealismOpt = DEFAULT_PRESET,
    seed: SeedOpt = 0,
    cache: Annotated[bool, typer.Option(help="Reuse the model cache")] = True,
    threads: Annotated[int | None, typer.Option(
        help="Worker threads (default: all cores); the SfM's mapping uses one, so the points and the study are "
        "the same whatever the count")] = None,
) -> None:
    """The closed loop: photographs of the plan, a real SfM run on them, and the predicted metrics set beside
    what the reconstruction measured, per element and per frame (out/index.html)."""
    from ..errors import SightplanError
    from ..evaluate import EvaluationSettings
    from ..loop.photo import photo_options
    from ..loop.run import loop
    from ..metrics import MetricParams
    from ..plan.load import load_plan

    check_date_options(date_basis, unscheduled)
    if scale is not None and not 0 < scale <= 1:
        raise SightplanError(f"--scale must be in (0, 1], got {scale}")
    if paper_table is not None and not paper_table.is_file():
        raise SightplanError(f"--paper-table: no such file: {paper_table}")
    settings = EvaluationSettings(engine=engine, scale=eval_scale, threads=threads, metric=MetricParams(omega=omega))
    scene, _ = load_with_progress(console, model, cache)
    scene = dated_scene(console, scene, model, schedule, rules, prefer_actual, date, date_basis, unscheduled)
    the_plan = load_plan(plan, camera=cli_camera(camera, focal_mm), **georef_kwargs(scene))
    print_warnings(console, the_plan.parameters.get("warnings", []))
    console.print(f"model: {scene.source or model} — {int(scene.targets.sum())} target elements; plan: "
                  f"{len(the_plan)} frames", highlight=False)
    if reconstruction is None:
        from ..loop.estimate import default_scale, estimate

        scale = scale if scale is not None else default_scale(the_plan)
        console.print(estimate(the_plan, scale).text(), highlight=False)
    with stage_bars(console, STAGE_NAMES) as progress:
        result = loop(scene, the_plan, out, scale=scale, matcher=matcher, render_engine=render_engine,
                      settings=settings, threads=threads, registration_error_m=registration_error,
                      tolerance_m=tolerance, radius_m=radius, threshold=threshold, paper_table=paper_table,
                      reconstruction=reconstruction,
                      labels={"model": Path(str(model)).name, "plan": Path(str(plan)).name}, progress=progress,
                      photo_options=photo_options(photo_realism, seed))
    rec, m, v, s = result.reconstruction, result.measures, result.validation, result.study
    print_warnings(console, list(m.warnings) + list(v.warnings))
    summ = m.summary()
    lens = rec.info.get("distortion")
    if lens:
        est = next(iter(lens["estimated"].values()), None)
        console.print(f"photographs: preset {rec.info.get('photo_realism')}, seed {rec.info.get('photo_seed')}; lens "
                      f"k1 k2 p1 p2 true {' '.join(f'{x:+.4f}' for x in next(iter(lens['true'].values())))}, "
                      f"estimated {' '.join(f'{x:+.4f}' for x in est) if est else '—'}", highlight=False)
    console.print(f"frames registered: {rec.n_registered} of {len(rec.frame_names)}; residual {rec.residual_m:.4g} m "
                  f"({100 * rec.residual_share:.3f} % of the scene's {rec.scene_size_m:.3g} m); "
                  f"{summ['points']:,} points, {summ['points_on_model']:,} on the model", highlight=False)
    console.print(f"validation: A {cell(v.A, '.4f')} m, Ce {cell(v.Ce, '.3f')}, Cv {cell(v.Cv, '.3f')}, "
                  f"Ct {cell(v.Ct, '.3f')} (λ = {v.lam:.4g} m); points to the model: median "
                  f"{cell(v.A_median, '.4f')} m, 90th percentile {cell(v.A_p90, '.4f')} m, {v.outliers:,} outliers "
                  "left out", highlight=False)
    console.print(comparison_table(s, f"{s.n_elements} elements: predicted against measured completeness"))
    fit = s.logistic
    if fit is not None:
        console.print(f"logistic fit of reconstructed (completeness ≥ {s.threshold:g}) on "
                      f"{', '.join(fit.predictors)}: accuracy {100 * fit.accuracy:.1f} % over {fit.n} elements "
                      f"({fit.positives} reconstructed), pseudo-R² {fit.pseudo_r2:.3f}", highlight=False)
    else:
        console.print(f"no logistic fit: {s.fit_note}", highlight=False)
    f = s.frames
    console.print(f"frames: {f.stable} predicted stable; stable & registered {f.stable_registered}, stable & not "
                  f"{f.stable_unregistered}, unstable & registered {f.unstable_registered}, unstable & not "
                  f"{f.unstable_unregistered}", highlight=False)
    console.print(f"wrote {result.paths['page']} and {len(result.paths) - 1} more files in {out}", highlight=False)
