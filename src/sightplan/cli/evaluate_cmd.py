"""``sightplan evaluate MODEL [PLAN]``."""

from __future__ import annotations

from pathlib import Path
from typing import TYPE_CHECKING, Annotated

import numpy as np
import typer
from rich.table import Table

from ..engines.base import EngineName
from ..errors import SightplanError
from ..model.mesh import MeshGrouping
from .base import ENGINE_HELP, app, console
from .camera_opts import CAMERA_FORMS, FocalOpt, cli_camera
from .errors import cell, friendly_errors, writable_folder
from .fourd import (
    ActualOpt,
    BasisOpt,
    DateOpt,
    RealityOpt,
    RulesOpt,
    ScheduleOpt,
    UnscheduledOpt,
    check_date_options,
    dated_scene,
    with_reality,
)
from .loading import georef_kwargs, load_with_progress, print_warnings, refuse_if_far
from .stages import StageDisplay, step

#: an evaluation's stages as the progress lines name them
EVALUATION_STAGES = {"ties": "finding tie pairs", "features": "simulated features", "engine": "building the engine",
                     "frames": "casting frames", "predict": "predicting completeness",
                     "report": "writing the report"}
#: the elements --predict-completeness prints (the least complete); elements.csv holds them all
PREDICTION_ROWS = 15
MAX_RING_FRAMES = 100_000  # as many as a route may have: a ring plan is built before anything is cast

if TYPE_CHECKING:
    from ..report.colours import ColourBy


def summary_table(ev, title: str) -> Table:
    """The plan metrics, one per row, as in the paper's Table 2, each with its definition
    (:mod:`sightplan.metrics.glossary`)."""
    from ..metrics.glossary import explain

    p = ev.metrics.plan
    pct = lambda x: None if x is None else 100 * x  # noqa: E731
    t = Table("metric", "value", "unit", "meaning", title=title, title_justify="left")
    mp = ev.settings.metric
    rows = [
        ("VC", cell(pct(p.VC), ".2f"), "%", f"{explain('VC_pct', mp)} ({p.n_visible} of {p.z})"),
        ("V̄C", cell(pct(p.VC_bar), ".2f"), "%", f"{explain('VC_bar_pct', mp)} ({p.n_visible} of {p.n_observed})"),
        ("VR", cell(p.VR, ".2f"), "frames", explain("VR", mp)),
        ("R", cell(p.R, ".4f"), "m/px", explain("R_m_per_px", mp)),
        ("O", cell(p.O, ".2f"), "°", explain("O_deg", mp)),
        ("T", cell(p.T, ".1f"), "features", explain("T", mp)),
        ("stable", cell(pct(p.stable_share), ".1f"), "%", explain("stable_frames_pct", mp)),
        ("time", f"{ev.timings['total_s']:.1f}", "s",
         f"{p.n_frames} frames, all from the cache" if not ev.timings["frames_cast"] else
         f"{p.n_frames} frames, {ev.timings['frames_cast']} cast ({ev.timings['s_per_frame']:.3f} s each), "
         f"{ev.cache_hits} from the cache"),
    ]
    for row in rows:
        t.add_row(*row)
    return t


def flown_plan(console, path: str, plan, scene, autopilot: str | None):
    """The plan of a MAVLink export as its autopilot flies it (:func:`~sightplan.flight.asflown.as_flown_plan`),
    with how far its photos fall from the file's frames."""
    from ..flight.asflown import as_flown_plan, deviations
    from ..formats.mavlink import resolve_autopilot
    from ..geo import Georeference, resolve_georeference

    if path is None:
        raise SightplanError("--as-flown needs a PLAN: the exported mission to replay")
    if autopilot is not None:
        autopilot = resolve_autopilot(autopilot)
    geo = resolve_georeference(plan.parameters.get("georeference"), Georeference.from_scene_metadata(scene.metadata),
                               what="--as-flown")
    with step(console, "replaying the mission"):
        flown, rep = as_flown_plan(path, plan, geo, autopilot)
    d, a = deviations(plan, flown)
    console.print(f"as flown ({rep.autopilot}): {len(flown)} photos in {rep.time_s / 60:.1f} min; off their frames "
                  f"by up to {d.max():.2f} m (median {np.median(d):.2f}) and {a.max():.1f}° (median "
                  f"{np.median(a):.1f}°); {sum(not p.gimbal_still for p in rep.photos)} taken while the gimbal moved",
                  highlight=False)
    return flown


def completeness_prediction(scene, plan, ev, settings, feature_set, cache: bool, model):
    """The predicted completeness of every element of the evaluated plan (:mod:`sightplan.predict.apply`)."""
    from ..evaluate import scene_features
    from ..predict.apply import predict_completeness

    fs = scene_features(scene, settings, feature_set, cache=cache)
    if fs.key != ev.observations.meta.get("features"):
        raise SightplanError("--predict-completeness: the features differ from the evaluation's")
    pixels = np.array([plan.camera_of(f).width * plan.camera_of(f).height for f in range(len(plan))], float)
    return predict_completeness(ev.observations, pixels, plan.C_world, fs.points, fs.element, model)


def prediction_table(prediction, scene) -> Table:
    """The least complete elements as predicted, with their intervals, and the model's scope in the title."""
    info = prediction.info
    seen = np.flatnonzero(np.isfinite(prediction.predicted))
    order = seen[np.argsort(prediction.predicted[seen], kind="stable")][:PREDICTION_ROWS]
    level = f"{100 * prediction.level:.0f} %"
    lomo = info.get("lomo", {})
    mean = prediction.summary()["mean_predicted"]
    title = (f"predicted completeness ({len(seen)} elements seen, mean {cell(mean, '.2f')}; the "
             f"{len(order)} least complete): photographs of {prediction.photo_pixels / 1e6:.2f} Mpx, look "
             f"'{info.get('photo_realism', '?')}'; on models it was not fitted on r = {cell(lomo.get('r'), '.2f')}, "
             f"calibration slope {cell(lomo.get('slope'), '.2f')}")
    t = Table("element", "class", "predicted", f"{level} interval", title=title, title_justify="left")
    el = scene.elements
    for i in order:
        name = str(el.name[i]) or str(el.global_id[i])
        t.add_row(name[:40], str(el.ifc_class[i]), f"{prediction.predicted[i]:.2f}",
                  f"{prediction.low[i]:.2f}–{prediction.high[i]:.2f}")
    return t


PLAN_METRICS = (("VC", "VC", "%", 100.0), ("VC_bar", "V̄C", "%", 100.0), ("VR", "VR", "frames", 1.0),
                ("R", "R", "m/px", 1.0), ("O", "O", "°", 1.0), ("T", "T", "features", 1.0))


def comparison_table(base, flown, title: str) -> Table:
    """The plan metrics of two evaluations side by side, with the difference."""
    t = Table("metric", "planned", "as flown", "difference", "unit", title=title, title_justify="left")
    for name, label, unit, scale in PLAN_METRICS:
        a, b = getattr(base.metrics.plan, name), getattr(flown.metrics.plan, name)
        diff = None if a is None or b is None else scale * (b - a)
        t.add_row(label, cell(None if a is None else scale * a, ".4g"),
                  cell(None if b is None else scale * b, ".4g"), cell(diff, "+.4g"), unit)
    return t


def write_comparison(base, flown, planned, flown_plan, path: Path) -> Path:
    """as_flown.json: both evaluations' plan metrics and each frame's deviation (m, °)."""
    import json

    from ..flight.asflown import deviations

    d, a = deviations(planned, flown_plan)
    doc = {"planned": {k: getattr(base.metrics.plan, k) for k, _, _, _ in PLAN_METRICS},
           "as_flown": {k: getattr(flown.metrics.plan, k) for k, _, _, _ in PLAN_METRICS},
           "replay": flown_plan.parameters.get("as_flown"),
           "frames": [{"name": str(n), "deviation_m": round(float(x), 4), "deviation_deg": round(float(y), 3)}
                      for n, x, y in zip(planned.frame_names, d, a)]}
    path.write_text(json.dumps(doc, indent=1, default=lambda v: None), encoding="utf-8")
    return path


def _check_draw_options(position_error: str | None, draws: int | None, pool: int | None, draw_seed: int | None,
                        cluster: str | None):
    """(pose error, draws, pool) of the --position-error options, checked before anything is loaded; (None, 0,
    None) without --position-error."""
    if position_error is None:
        given = [name for name, v in (("--draws", draws), ("--pool", pool), ("--draw-seed", draw_seed)) if v is not None]
        if given:
            raise SightplanError(f"{', '.join(given)} applies to draws under --position-error, which is not given")
        return None, 0, None
    from ..plan.perturb import PoseError
    from ..robustness import check_draws

    if cluster is not None:
        raise SightplanError("--position-error casts its draws here, not on a --cluster: drop one of them")
    if draw_seed is not None and draw_seed < 0:
        raise SightplanError(f"--draw-seed must be ≥ 0, got {draw_seed}")
    n = 64 if draws is None else draws
    try:
        n_pool = check_draws(n, pool)
    except SightplanError as exc:
        raise SightplanError(f"--draws/--pool: {exc}") from None
    return PoseError.parse(position_error), n, n_pool


def robustness_table(result):
    """Each plan metric as planned and over the draws (mean, 5th and 95th percentiles), the frames' least distance
    to the model, and how often a frame comes closer than the safety distance: a heading line, a table, a line."""
    import numpy as np
    from rich.console import Group
    from rich.text import Text

    s = result.summary.plan
    pct = lambda x: None if x is None else 100 * x  # noqa: E731
    rows = [("V", s["n_visible"], ".1f", 1, "elements"), ("VC", s["VC"], ".2f", 100, "%"),
            ("V̄C", s["VC_bar"], ".2f", 100, "%"), ("VR", s["VR"], ".2f", 1, "frames"),
            ("R", s["R"], ".4f", 1, "m/px"), ("O", s["O"], ".2f", 1, "°"), ("T", s["T"], ".1f", 1, "features"),
            ("stable", s["stable_share"], ".1f", 100, "%")]
    pool = "independent" if result.pool == result.draws else f"sharing {result.pool} poses per frame"
    t = Table("metric", "planned", "mean", "p5", "p95", "unit")
    scale = lambda x, f: None if x is None else x * f  # noqa: E731
    for name, sp, spec, f, unit in rows:
        t.add_row(name, cell(scale(sp.nominal, f), spec), cell(scale(sp.mean, f), spec), cell(scale(sp.p5, f), spec),
                  cell(scale(sp.p95, f), spec), unit)
    sf = result.safety
    least = [float(x) for x in (sf.least_m.mean(), *np.percentile(sf.least_m, [5, 95]))]
    t.add_row("least distance", cell(sf.nominal_least_m, ".2f"), *(cell(x, ".2f") for x in least), "m")
    head = (f"under position error {result.error.label()} (95 % bounds): {result.draws} draws ({pool}), "
            f"seed {result.seed}")
    foot = (f"a frame closer to the model than the safety distance ({sf.minimum_m:g} m) in "
            f"{cell(pct(sf.draw_share), '.1f')} % of the draws; {cell(pct(sf.frame_share), '.2f')} % of all frames")
    return Group(Text(head, style="italic"), t, Text(foot))


def _check_report_options(html: Path | None, gltf: Path | None, colour_by: str,
                          bounds: str | None) -> tuple[ColourBy, tuple[float, float] | None]:
    """Refuse a bad --colour-by, --bounds or output path before anything is cast."""
    from ..errors import ReportError
    from ..report.colours import check_colour_by, parse_bounds
    from ..report.files import check_writable

    colour = check_colour_by(colour_by)
    parsed = None if bounds is None else parse_bounds(bounds)
    if parsed is not None and colour == "visibility":
        raise ReportError("--bounds applies to --colour-by vr, ssd or orientation, not to visibility")
    for path in (html, gltf):
        if path is not None:
            check_writable(path)
    if html is not None:
        from ..report.html import find_three

        find_three()
    return colour, parsed


@app.command()
@friendly_errors
def evaluate(
    model: Annotated[str, typer.Argument(help="IFC or mesh file; 'sample' for the bundled Duplex model")],
    plan: Annotated[str | None, typer.Argument(help="Plan file (sightplan JSON, poses CSV, COLMAP model, OpenSfM "
                                                     "reconstruction.json); omit for a ring of frames")] = None,
    camera: Annotated[str | None, typer.Option(
        help="Camera of the ring plan (default p4p) or of a poses CSV: " + CAMERA_FORMS + "; given with a PLAN that "
             "has cameras of its own, it replaces them")] = None,
    focal_mm: FocalOpt = None,
    ring_frames: Annotated[int, typer.Option(help="Frames in the ring plan when no PLAN is given")] = 36,
    ring_distance: Annotated[float, typer.Option(help="Ring clearance from the model's box (m)")] = 15.0,
    date: DateOpt = None,
    schedule: ScheduleOpt = None,
    rules: RulesOpt = None,
    reality: RealityOpt = None,
    prefer_actual: ActualOpt = False,
    date_basis: BasisOpt = "finish",
    unscheduled: UnscheduledOpt = "present",
    engine: Annotated[EngineName, typer.Option(help=ENGINE_HELP)] = "auto",
    scale: Annotated[float, typer.Option(help="Resolution scale s: cast (s·W)×(s·H) rays and scale counts")] = 1.0,
    omega: Annotated[float, typer.Option(help="Visibility threshold Ω in pixels")] = 625.0,
    k: Annotated[int, typer.Option(help="Top-k frames for R_i and O_i")] = 3,
    min_track: Annotated[int, typer.Option(help="Minimum track length Y (consecutive frames)")] = 5,
    min_features: Annotated[int, typer.Option(help="Minimum stable features per frame Λ")] = 50,
    feature_density: Annotated[float, typer.Option(help="Surface features per m²")] = 1.0,
    seed: Annotated[int, typer.Option(help="Seed of the feature sampling")] = 0,
    features: Annotated[Path | None, typer.Option(help="Use this saved feature set (.npz) instead of sampling")] = None,
    save_features: Annotated[Path | None, typer.Option(help="Write the simulated feature set (.npz) for reuse")] = None,
    d_max: Annotated[float, typer.Option(help="D_max: farthest visible surface (m)")] = 1000.0,
    transform: Annotated[Path | None, typer.Option(help="JSON 4×4 similarity from the poses' frame to the model's")] = None,
    save_plan: Annotated[Path | None, typer.Option(help="Also write the evaluated plan as sightplan JSON")] = None,
    out: Annotated[Path, typer.Option(help="Output folder for report.json, elements.csv, frames.csv")] = Path("sightplan-out"),
    mesh_elements: Annotated[MeshGrouping, typer.Option(
        help="For a mesh: its elements are the file's objects/nodes, connected components, or single faces")] = "objects",
    mesh_scale: Annotated[float, typer.Option(help="For a mesh: metres per file unit (0.001 for millimetres)")] = 1.0,
    patch_area: Annotated[float | None, typer.Option(
        help="For a reality mesh (--mesh-elements patches) or a point cloud: area of an element patch (m², default 10)")] = None,
    cache: Annotated[bool, typer.Option(help="Reuse the model, per-frame and picture-view caches")] = True,
    picture: Annotated[bool, typer.Option(
        help="Also write overview.png and storeys.png: the model coloured by visibility (their views are cached: a "
             "re-evaluation draws them without casting)")] = True,
    html: Annotated[Path | None, typer.Option(
        help="Also write one self-contained HTML report (metrics, plots, worst elements, 3D view) to this file")] = None,
    gltf: Annotated[Path | None, typer.Option(
        help="Also write the model as binary glTF (.glb), one node per element, coloured by --colour-by")] = None,
    colour_by: Annotated[str, typer.Option(
        help="Metric that colours --gltf and the HTML's 3D view: visibility, vr (VR_i), ssd (R_i) or orientation (O_i)")
    ] = "visibility",
    bounds: Annotated[str | None, typer.Option(
        help="LO,HI: the colour gradient's ends for vr, ssd or orientation (default: the range over the visible "
             "elements)")] = None,
    threads: Annotated[int | None, typer.Option(help="Worker threads (default: all cores)")] = None,
    cluster: Annotated[str | None, typer.Option(
        help="Cast on a dask cluster: a scheduler address (tcp://host:8786) or local:N for N local worker processes")] = None,
    batch_frames: Annotated[int, typer.Option(help="With --cluster: frames per task")] = 64,
    as_flown: Annotated[bool, typer.Option(
        "--as-flown", help="PLAN is a MAVLink export (.plan, .waypoints): replay it under its autopilot's rules and "
                           "evaluate the photos where they will be taken, beside the file's own frames")] = False,
    autopilot: Annotated[str | None, typer.Option(
        help="With --as-flown: px4 or ardupilot (default: the .plan's firmwareType; ArduPilot for WPL)")] = None,
    position_error: Annotated[str | None, typer.Option(
        "--position-error", help="Also evaluate the plan as it may be flown: draws with every frame moved by a normal "
                                 "error whose 95 % bounds are 'H,V' metres (horizontal radius, vertical) and an "
                                 "optional heading ',YAW' degrees; or 'gnss' (±1.5 m, ±0.5 m), 'rtk' (±0.1 m), with "
                                 "an optional ',YAW'. Writes robustness.json and two CSVs to --out")] = None,
    draws: Annotated[int | None, typer.Option(help="With --position-error: the number of draws (default 64)")] = None,
    pool: Annotated[int | None, typer.Option(
        help="With --position-error: perturbed poses cast per frame, which the draws share (default the smaller of "
             "16 and --draws; --pool equal to --draws: independent draws)")] = None,
    draw_seed: Annotated[int | None, typer.Option(
        help="With --position-error: seed of the draws (default --seed)")] = None,
    predict_completeness: Annotated[bool, typer.Option(
        "--predict-completeness", help="Also predict each element's completeness in a reconstruction of the plan's "
                                       "photographs, with a 90 % interval (the closed loop's fitted model; see "
                                       "docs/closed-loop.md): printed for the least complete elements, and in "
                                       "elements.csv and report.json")] = False,
    completeness_model: Annotated[Path | None, typer.Option(
        help="With --predict-completeness: a fitted model (JSON) instead of the bundled one")] = None,
) -> None:
    """Evaluate a capture plan against a model: VC, V̄C, VR, R, O, T, per element and per frame."""
    from ..evaluate import EvaluationSettings
    from ..evaluate import evaluate as run_evaluation
    from ..metrics import MetricParams
    from ..observations.features import FeatureSet
    from ..plan.load import load_plan
    from ..plan.ring import ring_plan
    from ..report import write_report

    check_date_options(date_basis, unscheduled)
    pose_error, n_draws, n_pool = _check_draw_options(position_error, draws, pool, draw_seed, cluster)
    if not 1 <= ring_frames <= MAX_RING_FRAMES:
        raise SightplanError(f"--ring-frames must be 1 to {MAX_RING_FRAMES:,}, got {ring_frames:,}")
    writable_folder(out, "--out")
    model_fit = None
    if completeness_model is not None and not predict_completeness:
        raise SightplanError("--completeness-model applies to --predict-completeness, which is not given")
    if predict_completeness:
        from ..predict.model import CompletenessModel

        model_fit = CompletenessModel.read(completeness_model)
    colour, colour_bounds = _check_report_options(html, gltf, colour_by, bounds)
    the_camera = cli_camera((camera or "p4p") if plan is None else camera, focal_mm)
    settings = EvaluationSettings(engine=engine, scale=scale, d_max=d_max, feature_density=feature_density,
                                  feature_seed=seed, threads=threads,
                                  metric=MetricParams(omega=omega, k=k, min_track=min_track, min_features=min_features))
    scene, load_report = load_with_progress(console, model, cache, mesh_elements, mesh_scale, patch_area)
    console.print(f"model: {scene.source or model} — {int(scene.targets.sum())} target elements, "
                  f"{len(scene.faces):,} triangles"
                  + (f", {len(load_report.skipped)} products without geometry (see `sightplan info`)"
                     if getattr(load_report, "skipped", None) else ""))
    scene = dated_scene(console, scene, model, schedule, rules, prefer_actual, date, date_basis, unscheduled)
    scene = with_reality(console, scene, reality)
    if plan is None:
        assert the_camera is not None
        the_plan = ring_plan(scene, the_camera, n_frames=ring_frames, distance_m=ring_distance)
        plan_label = f"ring of {ring_frames} frames ({camera or 'p4p'})"
    else:
        the_plan = load_plan(plan, camera=the_camera, transform=transform,
                             **georef_kwargs(scene))
        plan_label = plan
        refuse_if_far(scene, the_plan)
        print_warnings(console, the_plan.parameters.get("warnings", []))
    planned = None
    if as_flown:
        planned, the_plan = the_plan, flown_plan(console, plan, the_plan, scene, autopilot)
        plan_label = f"{plan} as flown"
    elif autopilot is not None:
        raise SightplanError("--autopilot is for --as-flown")
    if save_plan is not None:
        from ..plan.format import write_plan

        write_plan(the_plan, save_plan)
    feature_set = FeatureSet.load(features) if features is not None else None
    if save_features is not None:
        from ..evaluate import scene_features

        feature_set = feature_set or scene_features(scene, settings, None, cache=cache)
        feature_set.save(save_features)
    with StageDisplay(console, EVALUATION_STAGES, transient=False) as display:
        if cluster is not None:
            from ..distributed import evaluate_distributed

            display("features", 0, 0)
            ev = evaluate_distributed(scene, the_plan, settings, cluster=cluster, batch_frames=batch_frames,
                                      features=feature_set, feature_cache=cache,
                                      progress=lambda i, n: display("frames", i, n))
        else:
            ev = run_evaluation(scene, the_plan, settings, features=feature_set,
                                cache_dir=None if cache else False, stages=display)
        prediction = None
        if model_fit is not None:
            display("predict", 0, 0)
            prediction = completeness_prediction(scene, the_plan, ev, settings, feature_set, cache, model_fit)
        display("report", 0, 0)
        paths = write_report(ev, scene, the_plan, out, model_path=str(model), plan_path=str(plan or ""),
                             prediction=prediction)
    robust = None
    if pose_error is not None:
        from ..robustness import evaluate_under_error, write_robustness

        with StageDisplay(console, {"draws": "casting the draws"}, transient=False) as display:
            display("draws", 0, n_draws)
            robust = evaluate_under_error(scene, the_plan, settings, pose_error, n_draws,
                                          seed if draw_seed is None else draw_seed, pool=n_pool, nominal=ev,
                                          features=feature_set, cache_dir=None if cache else False,
                                          progress=lambda i, n: display("draws", int(n_draws * i / n), n_draws))
        paths.update(write_robustness(robust, scene, out))
    if picture:
        from ..engines.views import picture_views
        from ..report.overview import draw_overview, draw_storeys, visibility_colours

        vc = ev.metrics.plan.VC
        title = f"{Path(str(model)).name} — {plan_label}: VC {cell(None if vc is None else 100 * vc, '.1f')} %"
        with step(console, "drawing the overview"):  # its views from the views cache, else cast (and cached)
            view, storeys, _ = picture_views(scene, the_plan.C_world, ev.engine, threads,
                                             cache_dir=None if cache else False)
            colours = visibility_colours(ev.metrics.elements)
            paths["overview"] = draw_overview(view, colours, Path(out) / "overview.png", the_plan.C_world, title=title)
            storeys_png = draw_storeys(storeys, colours, Path(out) / "storeys.png", title=f"{title} — storey cutaways")
        if storeys_png is not None:
            paths["storeys"] = storeys_png
    if gltf is not None:
        from ..report.gltf import write_gltf

        with step(console, "writing the glTF"):
            paths["gltf"] = write_gltf(scene, ev.metrics, gltf, colour, colour_bounds)
    if html is not None:
        from ..report.html import write_html

        with step(console, "writing the HTML report"):
            paths["html"] = write_html(ev, scene, the_plan, html, model_label=str(model), plan_label=plan_label,
                                       colour_by=colour, bounds=colour_bounds)
    console.print(summary_table(ev, f"{Path(str(model)).name} × {plan_label} — engine {ev.engine}, "
                                    f"{ev.n_features:,} features, {ev.cache_hits} frames from cache"))
    if planned is not None:
        base = run_evaluation(scene, planned, settings, features=feature_set, cache_dir=None if cache else False)
        console.print(comparison_table(base, ev, f"the file's frames and the photos as flown ({plan})"))
        paths["as_flown"] = write_comparison(base, ev, planned, the_plan, Path(out) / "as_flown.json")
    if robust is not None:
        console.print(robustness_table(robust))
    if prediction is not None:
        console.print(prediction_table(prediction, scene))
    console.print("wrote " + ", ".join(str(p) for p in paths.values()))
