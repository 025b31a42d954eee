"""``sightplan validate MODEL PLAN REALITY --registration-error E`` (or ``--reconstruction FOLDER``): a plan against
the reconstruction it produced."""

from __future__ import annotations

import math
from pathlib import Path
from typing import Annotated

import typer
from rich.table import Table

from ..engines.base import EngineName
from ..errors import SightplanError
from .base import ENGINE_HELP, app, console
from .camera_opts import FocalOpt, PlanCameraOpt, cli_camera
from .errors import cell, friendly_errors
from .evaluate_cmd import EVALUATION_STAGES
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
from .loading import georef_kwargs, load_with_progress, print_warnings
from .stages import StageDisplay, step

#: a validation's stages as the progress lines name them: the plan's evaluation's, then its own
VALIDATION_STAGES = {**EVALUATION_STAGES, "distances": "measuring the points' distances to the model",
                     "index": "indexing the points", "comparing": "comparing with the reality",
                     "completeness": "sampling the model's surfaces (Ct)", "precision": "sampling the reality (precision)"}


def validation_table(v, title: str) -> Table:
    """A, Ce, Cv, Ct, precision, recall and F, one per row."""
    pct = lambda x: None if x is None else 100 * x  # noqa: E731
    n = v.counts
    t = Table("metric", "value", "unit", "meaning", title=title, title_justify="left")
    rows = [
        ("A", cell(v.A, ".4f"), "m", "accuracy: VR-weighted mean |dΓ − dΨ| over pixels where both are hit"),
        *([("A median", cell(v.A_median, ".4f"), "m", "median distance from Ψ's points to Γ (outliers excluded)"),
           ("A p90", cell(v.A_p90, ".4f"), "m", "90th percentile of that distance"),
           ("outliers", f"{v.outliers:,}", "points", "farther from every surface than "
            f"{cell(n['distances']['outlier_bound_m'], '.3g')} m: left out of A, Ce, Cv, Ct")]
          if "distances" in n else []),
        ("Ce", cell(pct(v.Ce), ".2f"), "%", f"completeness per element: mean c_i over {v.z} elements"),
        ("Cv", cell(pct(v.Cv), ".2f"), "%", f"completeness per visible element: mean c_i over {v.n_visible}"),
        ("Ct", cell(pct(v.Ct), ".2f"), "%", f"overall completeness: {n['ct_samples']:,} points on Γ with Ψ within "
         + ("λ" if v.parameters["ct_radius_m"] == v.lam else f"{v.parameters['ct_radius_m']:.3g} m (its spacing)")),
        ("precision", cell(pct(v.precision), ".2f"), "%",
         f"{n['precision_samples']:,} points of Ψ in Γ's box with Γ within λ"),
        ("recall", cell(pct(v.recall), ".2f"), "%", "= Ct"),
        ("F", cell(pct(v.F), ".2f"), "%", "F-score at λ: 2PR/(P + R)"),
        ("λ", f"{v.lam:.4f}", "m", f"1.2 × registration error {v.registration_error_m:g} m"),
        ("time", f"{v.timings['total_s']:.1f}", "s", f"{v.n_frames} frames, reality: {v.reality_kind}"),
    ]
    for row in rows:
        t.add_row(*row)
    return t


def registration_summary(rec) -> dict:
    """Frames registered, pose errors and the residual of a reconstruction, JSON-ready."""
    from ..loop.files import pose_error_summary

    return {"frames": len(rec.frame_names), "frames_registered": rec.n_registered,
            "unregistered": [n for n, ok in zip(rec.frame_names, rec.registered, strict=True) if not ok],
            **pose_error_summary(rec.registered, rec.position_error_m, rec.rotation_error_deg),
            "residual_m": rec.residual_m, "scene_size_m": rec.scene_size_m,
            "residual_share": rec.residual_share if math.isfinite(rec.residual_share) else None,
            "points": len(rec.points)}


def registration_table(rec) -> Table:
    """Frames registered, pose errors and the registration residual, one per row."""
    s = registration_summary(rec)
    t = Table("registration", "value", "unit", title="the reconstruction", title_justify="left")
    t.add_row("frames registered", f"{s['frames_registered']} of {s['frames']}", "", "")
    t.add_row("position error", cell(s["position_error_m_mean"], ".4f"), "m",
              f"mean; max {cell(s['position_error_m_max'], '.4f')} m")
    t.add_row("rotation error", cell(s["rotation_error_deg_mean"], ".3f"), "°",
              f"mean; max {cell(s['rotation_error_deg_max'], '.3f')}°")
    t.add_row("residual", f"{s['residual_m']:.4f}", "m",
              f"{100 * (s['residual_share'] or 0):.3f} % of the scene's size {s['scene_size_m']:.2f} m")
    t.add_row("points", f"{s['points']:,}", "", "triangulated")
    return t


def load_reality_input(path: Path, scale: float, cache: bool):
    """A point cloud file as its points (scaled), a mesh file as a Scene (load_reality)."""
    from ..errors import ModelError
    from ..model.pointcloud import PointCloud, is_point_cloud, read_point_cloud
    from ..model.reality import load_reality

    path = Path(path).expanduser()
    if not path.is_file():
        raise ModelError(f"reality model file not found: {path}")
    if is_point_cloud(path):
        cloud = read_point_cloud(path)
        return PointCloud(cloud.points * scale, cloud.normals)
    return load_reality(path, scale=scale, cache=cache)


@app.command("validate")
@friendly_errors
def validate_command(
    model: Annotated[str, typer.Argument(help="IFC or mesh file; 'sample' for the bundled Duplex model")],
    plan: Annotated[str, typer.Argument(help="The plan as flown (any format `sightplan evaluate` reads)")],
    reality: Annotated[Path | None, typer.Argument(
        help="Reconstructed reality registered to the model: a mesh (OBJ, PLY, STL, glTF) or a point cloud (PLY "
             "without faces, LAS, LAZ); leave out with --reconstruction")] = None,
    registration_error: Annotated[float | None, typer.Option(
        "--registration-error", "-e", help="Registration error e of the reality (m); λ = 1.2·e. With "
                                           "--reconstruction: its registration residual unless given")] = None,
    reconstruction: Annotated[Path | None, typer.Option(
        help="A reconstruction folder (`sightplan reconstruct`): its points are the reality, its residual e, and "
             "its frames' registration and pose errors are reported")] = None,
    date: DateOpt = None,
    schedule: ScheduleOpt = None,
    rules: RulesOpt = None,
    prefer_actual: ActualOpt = False,
    date_basis: BasisOpt = "finish",
    unscheduled: UnscheduledOpt = "present",
    camera: PlanCameraOpt = None,
    focal_mm: FocalOpt = None,
    transform: Annotated[Path | None, typer.Option(help="JSON 4×4 similarity from the poses' frame to the model's")] = None,
    reality_scale: Annotated[float, typer.Option(help="Metres per reality file unit (0.001 for millimetres)")] = 1.0,
    point_spacing: Annotated[float | None, typer.Option(
        help="Point spacing of a point cloud for splatting (m); estimated when not given")] = None,
    engine: Annotated[EngineName, typer.Option(help=ENGINE_HELP)] = "auto",
    scale: Annotated[float | None, typer.Option(
        help="Resolution scale s: cast (s·W)×(s·H) rays; default 0.5, or 1 of the photographs with --reconstruction "
             "(as `sightplan loop` casts)")] = None,
    omega: Annotated[float, typer.Option(
        help="Visibility threshold Ω in pixels (of the photographs, with --reconstruction)")] = 625.0,
    d_max: Annotated[float, typer.Option(help="D_max: farthest visible surface of the model (m)")] = 1000.0,
    seed: Annotated[int, typer.Option(help="Seed of the surface sampling for Ct and precision")] = 0,
    out: Annotated[Path, typer.Option(help="Folder for validation.json and validation_elements.csv")] = Path(
        "sightplan-validate"),
    cache: Annotated[bool, typer.Option(help="Reuse the model and per-frame caches")] = True,
    threads: Annotated[int | None, typer.Option(help="Worker threads (default: all cores)")] = None,
) -> None:
    """Validate a plan against the reality model reconstructed from it: A, Ce, Cv, Ct, precision, recall, F."""
    from ..evaluate import EvaluationSettings, evaluate
    from ..metrics import MetricParams
    from ..plan.load import load_plan
    from ..validate import validate

    check_date_options(date_basis, unscheduled)
    rec = None
    if reconstruction is not None:
        from ..loop import read_reconstruction

        if reality is not None:
            raise SightplanError("give either a REALITY file or --reconstruction, not both")
        rec = read_reconstruction(reconstruction)
    elif reality is None:
        raise SightplanError("give the REALITY file (a mesh or a point cloud) or --reconstruction FOLDER")
    elif registration_error is None:
        raise SightplanError("give the reality's registration error: --registration-error E (m)")
    if scale is None:
        scale = 1.0 if rec is not None else 0.5
    settings = EvaluationSettings(engine=engine, scale=scale, d_max=d_max, threads=threads, metric=MetricParams(omega=omega))
    scene, _ = load_with_progress(console, model, cache)
    scene = dated_scene(console, scene, model, schedule, rules, prefer_actual, date, date_basis, unscheduled)
    the_plan = load_plan(plan, camera=cli_camera(camera, focal_mm), transform=transform, **georef_kwargs(scene))
    print_warnings(console, the_plan.parameters.get("warnings", []))
    if rec is not None:
        from ..loop.measure import reconstruction_error, reconstruction_reality
        from ..loop.run import photographed_plan

        # the plan as photographed: Ω and the pixels in the photographs' own pixels, as `sightplan loop` counts them
        render_scale = float(rec.info.get("render_scale", 1.0))
        the_plan = photographed_plan(the_plan, render_scale)
        psi = reconstruction_reality(rec)
        registration_error = reconstruction_error(rec, registration_error)
        source = reconstruction
        if len(rec.frame_names) != len(the_plan):
            raise SightplanError(f"the reconstruction has {len(rec.frame_names)} frames and the plan "
                                 f"{len(the_plan)}: reconstruct the photographs of this plan")
    else:
        with step(console, f"loading the reality {reality.name}"):
            psi = load_reality_input(reality, reality_scale, cache)
        source = reality
    what = (f"{len(psi.faces):,} triangles" if hasattr(psi, "faces") else f"{len(psi.points):,} points")
    console.print(f"model: {scene.source or model} — {int(scene.targets.sum())} target elements; "
                  f"reality {source.name}: {what}", highlight=False)
    if rec is not None:
        console.print(registration_table(rec))
    with StageDisplay(console, VALIDATION_STAGES) as display:
        ev = evaluate(scene, the_plan, settings, cache_dir=None if cache else False, stages=display)
        v = validate(scene, the_plan, psi, registration_error, settings, ev, point_spacing_m=point_spacing, seed=seed,
                     stages=display)
    print_warnings(console, v.warnings)
    console.print(validation_table(v, f"{Path(str(model)).name} × {Path(plan).name} × {source.name}"))
    out.mkdir(parents=True, exist_ok=True)
    inputs = {"model": str(model), "plan": str(plan), "reality": str(source),
              "reality_scale": reality_scale if rec is None else 1.0,
              **({} if rec is None else {"render_scale": render_scale}),
              "date": None if scene.date is None else str(scene.date)}
    extra = {} if rec is None else {"reconstruction": registration_summary(rec)}
    json_path = v.write_json(out / "validation.json", inputs=inputs, **extra)
    csv_path = v.write_csv(out / "validation_elements.csv")
    console.print(f"wrote {json_path}, {csv_path}", highlight=False)
