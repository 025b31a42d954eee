"""The closed loop in one call: render the plan's photographs, reconstruct them with structure from motion,
validate the plan against the reconstruction, measure it per element and per frame, and study the predictions
against the measures.

The plan that is evaluated is the plan as photographed: its cameras at the renders' scale (a render at scale
0.5 has a quarter of the pixels, so VR_i, R_i and the pixel counts are those of the images the SfM ran on).

``out_dir`` receives ``images/`` (the renders), ``recon/`` (the reconstruction), ``validation.json`` and
``validation_elements.csv`` (A, Ce, Cv, Ct with the reconstruction as Ψ), ``measures.json``, the study's
``study.json``, ``elements.csv``, ``frames.csv``, ``correlations.csv`` and plots, ``report.html`` (the
evaluation report, where the page's 3D viewer can be built) and ``index.html`` (the loop's page).
"""

from __future__ import annotations

import json
import time
from collections.abc import Callable
from dataclasses import dataclass, field, replace
from pathlib import Path

from ..engines import make_engine
from ..engines.registry import ray_engine_name
from ..engines.views import overview_view
from ..errors import ReportError, SightplanError
from ..evaluate import Evaluation, EvaluationSettings, evaluate
from ..model.scene import Scene
from ..plan.types import Plan
from ..study import Study
from ..validate import Validation
from .estimate import default_scale
from .files import Reconstruction, read_reconstruction
from .measure import ReconstructionMeasures, measure_reconstruction, validate_reconstruction
from .page import write_loop_page
from .photo import PhotoOptions
from .study import LoopStudy, loop_study

#: progress(stage, done, total); stages: render, reconstruct, evaluate, validate, measure, study.
StageProgress = Callable[[str, int, int], None]
STAGES = ("render", "reconstruct", "evaluate", "validate", "measure", "study")


@dataclass(frozen=True)
class LoopResult:
    """Everything one loop made, and where it wrote it."""

    out_dir: Path
    plan: Plan
    reconstruction: Reconstruction
    evaluation: Evaluation
    validation: Validation
    measures: ReconstructionMeasures
    study: LoopStudy
    paths: dict[str, Path]
    timings: dict[str, float] = field(default_factory=dict)
    renders: object | None = None


def photographed_plan(plan: Plan, scale: float) -> Plan:
    """The plan with every camera at resolution scale ``scale``, as the renders photograph it."""
    if not 0 < scale <= 1:
        raise SightplanError(f"the render scale must be in (0, 1], got {scale!r}")
    if scale == 1:
        return plan
    return replace(plan, cameras={k: c.scaled(scale) for k, c in plan.cameras.items()})


def _stage(progress: StageProgress | None, stage: str):
    """A callback for a stage's own progress: (done, total), or (description, done, total)."""
    def callback(*args) -> None:
        if progress is not None and len(args) >= 2:
            progress(stage, int(args[-2]), int(args[-1]))
    return callback


def loop(
    scene: Scene,
    plan: Plan,
    out_dir: str | Path,
    *,
    scale: float | None = None,
    matcher: str = "auto",
    render_engine: str = "embree",
    settings: EvaluationSettings | None = None,
    threads: int | None = None,
    registration_error_m: float | None = None,
    tolerance_m: float | None = None,
    radius_m: float | None = None,
    threshold: float | None = None,
    paper_table: str | Path | Study | bool | None = None,
    reconstruction: str | Path | None = None,
    labels: dict[str, str] | None = None,
    progress: StageProgress | None = None,
    photo_options: PhotoOptions | None = None,
) -> LoopResult:
    """Render, reconstruct, validate, measure and study ``plan`` on ``scene`` into ``out_dir`` (module docstring).

    scale: the renders' resolution scale (default: :func:`.estimate.default_scale`, about 0.2 Mpx a photograph;
    with ``reconstruction``, the scale its run records as ``render_scale``, else 1). matcher: the SfM's matcher
    (``reconstruct``). settings: the evaluation's (its scale is the evaluation's ray scale, independent of the
    renders'). registration_error_m: e for the validation (default: the reconstruction's residual). tolerance_m,
    radius_m: the measures' τ and r (default: :mod:`.measure`'s). paper_table: the paper's Table 2 CSV to set beside
    the correlations (default: the bundled table; False: none). reconstruction: an existing reconstruction folder of
    this plan's renders: render and reconstruct are skipped.
    labels: ``model`` and ``plan`` names for the page. photo_options: how photograph-like the renders are
    (:func:`.photo.photo_options`; None: the procedural element noise); the preset goes into the study.
    """
    out = Path(out_dir)
    out.mkdir(parents=True, exist_ok=True)
    settings = settings or EvaluationSettings()
    timings: dict[str, float] = {}
    renders = None
    rec = read_reconstruction(reconstruction) if reconstruction is not None else None
    if scale is None:
        scale = float(rec.info.get("render_scale", 1.0)) if rec is not None else default_scale(plan)
    photo = photographed_plan(plan, scale)
    t0 = time.perf_counter()
    if rec is None:
        from .reconstruct import reconstruct
        from .render import render_plan

        renders = render_plan(scene, plan, out / "images", scale=scale, engine=render_engine,
                              progress=_stage(progress, "render"), photo_options=photo_options)
        timings["render_s"] = time.perf_counter() - t0
        t0 = time.perf_counter()
        rec = reconstruct(renders.directory, out / "recon", matcher=matcher, threads=threads,
                          progress=_stage(progress, "reconstruct"))
        timings["reconstruct_s"] = time.perf_counter() - t0
    if len(rec.frame_names) != len(plan):
        raise SightplanError(f"the reconstruction has {len(rec.frame_names)} frames and the plan {len(plan)}")

    t0 = time.perf_counter()
    ev = evaluate(scene, photo, settings, cache_dir=False, progress=_stage(progress, "evaluate"))
    timings["evaluate_s"] = time.perf_counter() - t0
    t0 = time.perf_counter()
    v = validate_reconstruction(scene, photo, rec, registration_error_m, settings, ev,
                                progress=_stage(progress, "validate"))
    timings["validate_s"] = time.perf_counter() - t0
    paths: dict[str, Path] = {}
    paths["validation"] = v.write_json(out / "validation.json", inputs={
        **(labels or {}), "render_scale": scale, "reconstruction": str(reconstruction or out / "recon")})
    paths["validation_elements"] = v.write_csv(out / "validation_elements.csv")

    t0 = time.perf_counter()
    m = measure_reconstruction(scene, photo, rec, ev, settings=settings, tolerance_m=tolerance_m, radius_m=radius_m,
                               progress=_stage(progress, "measure"))
    timings["measure_s"] = time.perf_counter() - t0
    paths["measures"] = out / "measures.json"
    paths["measures"].write_text(json.dumps(m.to_dict(), indent=1, allow_nan=False, ensure_ascii=False),
                                 encoding="utf-8")

    t0 = time.perf_counter()
    study_kwargs = {} if threshold is None else {"threshold": threshold}
    info = {**(labels or {}), "frames": len(plan), "render_scale": scale, "matcher": rec.info.get("matcher", matcher),
            "photo_realism": rec.info.get("photo_realism", ""), "photo_seed": rec.info.get("photo_seed"),
            "validation": v.plan_metrics()}
    study = loop_study(ev, m, paper_table=paper_table, info=info, **study_kwargs)
    paths.update(study.write(out))
    links = {"validation.json": "validation.json", "elements.csv": "elements.csv", "frames.csv": "frames.csv",
             "study.json": "study.json"}
    try:
        from ..report.html import write_html

        paths["report"] = write_html(ev, scene, photo, out / "report.html", model_label=(labels or {}).get("model", ""),
                                     plan_label=(labels or {}).get("plan", ""))
        links = {"the evaluation's report (3D)": "report.html", **links}
    except ReportError:
        pass  # no three.js here: the page keeps its pictures
    with make_engine(ray_engine_name(settings.engine), scene, threads=settings.threads) as engine:
        view = overview_view(engine)
    facts = {"validation": "A {} m, Ce {}, Cv {}, Ct {} (λ = {:.4g} m); points to the model: median {} m, 90th "
             "percentile {} m, {:,} outliers left out".format(
                 *(("—" if x is None else f"{x:.4g}") for x in (v.A, v.Ce, v.Cv, v.Ct)), v.lam,
                 *(("—" if x is None else f"{x:.4g}") for x in (v.A_median, v.A_p90)), v.outliers)}
    title = " × ".join(x for x in ((labels or {}).get("model"), (labels or {}).get("plan")) if x)
    paths["page"] = write_loop_page(
        out / "index.html", study, m, view=view, em=ev.metrics.elements, facts=facts, links=links,
        title=f"sightplan loop — {title}" if title else "",
        images={"each predictor against the measured completeness": paths["scatter_completeness"],
                "pixels against points, R_i against density": paths["scatter_points"],
                "ν_f per frame, registered or not": paths["frames_plot"]})
    timings["study_s"] = time.perf_counter() - t0
    if progress is not None:
        progress("study", 1, 1)
    return LoopResult(out, photo, rec, ev, v, m, study, paths, timings, renders)
