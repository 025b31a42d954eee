"""The validation itself: :func:`validate` and its :class:`Validation` result."""

from __future__ import annotations

import csv
import json
import math
import os
import time
from collections.abc import Callable
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np
from numpy.typing import NDArray

from ..engines import make_engine
from ..engines.registry import ray_engine_name
from ..errors import ModelError, SightplanError
from ..evaluate import Evaluation, EvaluationSettings, evaluate
from ..model.pointcloud import PointCloud, check_points
from ..model.scene import Scene
from ..plan.types import Plan
from .caster import FrameCaster
from .distances import OUTLIER_MADS, CloudDistances, cloud_distances
from .splat import MAX_SPLAT_PX, point_spacing
from .surface import CT_DENSITY_PER_M2, CT_MAX_SAMPLES, CT_MIN_SAMPLES, n_samples, points_near_mesh, sample_surface

LAMBDA_PER_E = 1.2

#: Far-pixel share above which Ψ looks misregistered or in another unit.
FAR_SHARE_WARNING = 0.5

#: Share of Γ's bounding box that Ψ's box must cover before the overlap warning is silent.
OVERLAP_WARNING = 0.5

_UNITS = ((1000.0, "Ψ in millimetres?"), (100.0, "Ψ in centimetres?"), (39.37, "Ψ in inches?"), (3.281, "Ψ in feet?"),
          (0.001, "Γ in millimetres, or Ψ in kilometres?"), (0.01, "Γ in centimetres?"), (0.0254, "Γ in inches?"),
          (0.3048, "Γ in feet?"))

ProgressCallback = Callable[[int, int], None]

Reality = Scene | PointCloud | NDArray

# =========================================================================== result
@dataclass(frozen=True)
class Validation:
    """Plan-level quality of a reconstruction, per element and overall (METRICS.md §7).

    Plan numbers are None where undefined. A point cloud Ψ also gives ``A_median`` and ``A_p90``, the median and
    90th percentile distance of its points to Γ (metres, outliers excluded), and ``outliers``, the points it
    excluded as too far from every surface (:mod:`.distances`). Per-element arrays have shape (z_all,), indexed
    like the scene's element table: ``c`` (0 where never back-projected), ``A_i`` (metres, NaN
    where no pixel has both distances), ``pixels`` back-projected pixels as cast (at scale s),
    ``pixels_complete``, ``pixels_both``, ``VR``, ``visible``, ``is_target``. ``counts``:
    pixel and sample totals; ``parameters``: what determined the numbers.
    """

    registration_error_m: float
    lam: float
    A: float | None
    Ce: float | None
    Cv: float | None
    Ct: float | None
    precision: float | None
    recall: float | None
    F: float | None
    z: int
    n_visible: int
    n_frames: int
    reality_kind: str
    c: NDArray[np.float64]
    A_i: NDArray[np.float64]
    pixels: NDArray[np.int64]
    pixels_complete: NDArray[np.int64]
    pixels_both: NDArray[np.int64]
    VR: NDArray[np.int64]
    visible: NDArray[np.bool_]
    is_target: NDArray[np.bool_]
    global_id: NDArray[np.object_]
    name: NDArray[np.object_]
    ifc_class: NDArray[np.object_]
    counts: dict
    parameters: dict
    warnings: tuple[str, ...] = ()
    timings: dict = field(default_factory=dict)
    A_median: float | None = None
    A_p90: float | None = None
    outliers: int = 0

    def plan_metrics(self) -> dict:
        return {"A_m": self.A, "Ce": self.Ce, "Cv": self.Cv, "Ct": self.Ct, "precision": self.precision,
                "recall": self.recall, "F": self.F, "z": self.z, "visible": self.n_visible, "frames": self.n_frames,
                "A_median_m": self.A_median, "A_p90_m": self.A_p90, "outliers": self.outliers}

    def element_rows(self) -> list[dict]:
        """One row per target element, in element order: global_id, name, ifc_class, c_i, A_i (m), pixels."""
        return [{"global_id": str(self.global_id[i]), "name": str(self.name[i]), "ifc_class": str(self.ifc_class[i]),
                 "c_i": float(self.c[i]), "A_i": _num(self.A_i[i]), "pixels": int(self.pixels[i])}
                for i in np.flatnonzero(self.is_target)]

    def to_dict(self) -> dict:
        """JSON-ready: null for undefined numbers, never NaN."""
        return {"format": "sightplan-validation", "version": 1, "metrics": self.plan_metrics(),
                "registration_error_m": self.registration_error_m, "lambda_m": self.lam, "reality": self.reality_kind,
                "parameters": dict(self.parameters), "counts": dict(self.counts), "warnings": list(self.warnings),
                "timings": dict(self.timings), "elements": self.element_rows()}

    def write_json(self, path: str | Path, **extra) -> Path:
        """:meth:`to_dict` with the ``extra`` entries after it (``inputs``, say), as JSON."""
        path = Path(path)
        path.write_text(json.dumps({**self.to_dict(), **extra}, indent=1, allow_nan=False, ensure_ascii=False,
                                   default=str), encoding="utf-8")
        return path

    def write_csv(self, path: str | Path) -> Path:
        """The element rows as CSV (empty cell for an undefined A_i)."""
        path = Path(path)
        rows = self.element_rows()
        with open(path, "w", newline="", encoding="utf-8") as fh:
            w = csv.DictWriter(fh, fieldnames=["global_id", "name", "ifc_class", "c_i", "A_i", "pixels"])
            w.writeheader()
            for r in rows:
                w.writerow({k: "" if v is None else (f"{v:.6g}" if isinstance(v, float) else v) for k, v in r.items()})
        return path

def _num(x: float) -> float | None:
    x = float(x)
    return x if math.isfinite(x) else None

# =========================================================================== validation
def _reality_arrays(reality: Reality) -> tuple[Scene | None, NDArray | None]:
    if isinstance(reality, Scene):
        if len(reality.faces) == 0:
            raise ModelError("the reality model has no triangles")
        return reality, None
    pts = reality.points if isinstance(reality, PointCloud) else reality
    return None, check_points(pts, "the reality point cloud")

def _unit_hint(ratio: float) -> str:
    if not (ratio > 0 and math.isfinite(ratio)):
        return ""
    for value, label in _UNITS:
        if abs(math.log(ratio / value)) < math.log(1.1):
            return f" (≈ {value:g}: {label})"
    return ""

def _overlap_share(a: NDArray, b: NDArray, margin: float) -> float:
    """Share of box a (grown by margin) covered by box b (grown by margin), per-axis lengths multiplied."""
    lo = np.maximum(a[0], b[0]) - margin
    hi = np.minimum(a[1], b[1]) + margin
    return float(np.prod(np.clip(hi - lo, 0, None) / (a[1] - a[0] + 2 * margin)))

@dataclass
class PixelSums:
    """Per-element and overall pixel counts of the cast frames (METRICS.md §7): back-projected (``back``), complete
    within λ, hit on both models (``both``) with the sum of |dΓ − dΨ| over them; totals of model, both and far pixels;
    samples of the differences and ratios for the sanity checks."""

    back: NDArray[np.int64]
    complete: NDArray[np.int64]
    both: NDArray[np.int64]
    diff_sum: NDArray[np.float64]
    n_model: int = 0
    n_both: int = 0
    n_far: int = 0
    diffs: list = field(default_factory=list)
    ratios: list = field(default_factory=list)

    @classmethod
    def zeros(cls, z: int) -> PixelSums:
        return cls(np.zeros(z, np.int64), np.zeros(z, np.int64), np.zeros(z, np.int64), np.zeros(z, np.float64))

    def add(self, part: tuple) -> None:
        """Add one chunk of :meth:`FrameCaster.frame`."""
        self.back += part[0]
        self.complete += part[1]
        self.both += part[2]
        self.diff_sum += part[3]
        self.n_model += part[4]
        self.n_both += part[5]
        self.n_far += part[6]
        self.diffs += part[7]
        self.ratios += part[8]

    def medians(self) -> tuple[float | None, float | None]:
        """Median |dΓ − dΨ| and median dΨ/dΓ over the sampled pixels hit on both models."""
        d = np.concatenate(self.diffs) if self.diffs else np.zeros(0)
        r = np.concatenate(self.ratios) if self.ratios else np.zeros(0)
        return (float(np.median(d)) if len(d) else None), (float(np.median(r)) if len(r) else None)


def _checked_numbers(registration_error_m: float, ct_density_per_m2: float) -> float:
    e = float(registration_error_m)
    if not (e >= 0 and math.isfinite(e)):
        raise SightplanError(f"the registration error must be a number of metres ≥ 0, got {registration_error_m!r}")
    if not (ct_density_per_m2 > 0 and math.isfinite(ct_density_per_m2)):
        raise SightplanError(f"the Ct sampling density must be a positive number per m², got {ct_density_per_m2!r}")
    return e


def _cloud_index(cloud: NDArray | None, point_spacing_m: float | None, lam: float, seed: int,
                 warnings: list[str]) -> tuple[object | None, float]:
    """The cloud's k-d tree and its spacing (given or estimated), with a note when it is coarser than λ."""
    if cloud is None:
        return None, 0.0
    from scipy.spatial import cKDTree

    tree = cKDTree(cloud)
    spacing = float(point_spacing_m) if point_spacing_m is not None else point_spacing(cloud, tree, seed=seed)
    if not (spacing >= 0 and math.isfinite(spacing)):
        raise SightplanError(f"point spacing must be a number of metres ≥ 0, got {point_spacing_m!r}")
    if spacing > lam:
        warnings.append(f"the point cloud's spacing ({spacing:.3g} m) exceeds λ = {lam:.3g} m: Ct (recall) counts a "
                        "surface point as covered with a point of Ψ within that spacing rather than within λ")
    return tree, spacing


def _cast(scene: Scene, plan: Plan, psi_scene: Scene | None, cloud: NDArray | None, spacing: float,
          is_target: NDArray, lam: float, settings: EvaluationSettings, threads: int,
          progress: ProgressCallback | None) -> tuple[PixelSums, str]:
    """Every frame cast on Γ and on Ψ (mesh rays or splatted points), summed; and the ray engine's name."""
    sums = PixelSums.zeros(scene.n_elements)
    rays = ray_engine_name(settings.engine)  # the validation casts its own rays: a ray caster, never a rasteriser
    gamma = make_engine(rays, scene, d_max=settings.d_max, threads=1)
    psi_engine = make_engine(rays, psi_scene, threads=1) if psi_scene is not None else None
    caster = FrameCaster(gamma, psi_engine, cloud, spacing, is_target, lam, threads)
    try:
        for f in range(len(plan)):
            for part in caster.frame(plan.camera_of(f), plan.R_world_camera[f], plan.C_world[f], settings.scale):
                sums.add(part)
            if progress is not None:
                progress(f + 1, len(plan))
    finally:
        caster.close()
        gamma.close()
        if psi_engine is not None:
            psi_engine.close()
    return sums, gamma.name


def _recall(scene: Scene, is_target: NDArray, psi_scene: Scene | None, tree, lam: float, density: float,
            rng: np.random.Generator) -> tuple[NDArray, NDArray]:
    """Ct: samples of Γ's target surfaces (``density`` per m²) and whether Ψ lies within ``lam`` of each."""
    tgt_faces = scene.faces[is_target[scene.face_element]]
    area = float(scene.face_areas()[is_target[scene.face_element]].sum())
    gamma_pts, _ = sample_surface(scene.vertices, tgt_faces, n_samples(area, density), rng)
    if tree is not None:
        d, _ = tree.query(gamma_pts, k=1, distance_upper_bound=np.nextafter(lam, np.inf), workers=-1)
        return gamma_pts, np.isfinite(d)
    return gamma_pts, points_near_mesh(gamma_pts, psi_scene.vertices, psi_scene.faces, lam)


def _precision(scene: Scene, psi_scene: Scene | None, cloud: NDArray | None, lam: float, density: float,
               rng: np.random.Generator) -> tuple[NDArray, NDArray]:
    """Precision: samples of Ψ within Γ's box grown by λ (the cloud's points, or its surfaces at ``density`` per m²)
    and whether Γ lies within λ of each."""
    box = scene.bounds()
    lo, hi = box[0] - lam, box[1] + lam
    if cloud is not None:
        psi_pts = cloud[((cloud >= lo) & (cloud <= hi)).all(axis=1)]
        if len(psi_pts) > CT_MAX_SAMPLES:
            psi_pts = psi_pts[np.sort(rng.choice(len(psi_pts), CT_MAX_SAMPLES, replace=False))]
    else:
        tri = psi_scene.vertices[psi_scene.faces]
        inside = (tri.max(axis=1) >= lo).all(axis=1) & (tri.min(axis=1) <= hi).all(axis=1)
        area_in = float(psi_scene.face_areas()[inside].sum())
        psi_pts, _ = sample_surface(psi_scene.vertices, psi_scene.faces[inside], n_samples(area_in, density), rng)
        psi_pts = psi_pts[((psi_pts >= lo) & (psi_pts <= hi)).all(axis=1)]
    return psi_pts, points_near_mesh(psi_pts, scene.vertices, scene.faces, lam)


def _sanity(scene: Scene, psi_scene: Scene | None, cloud: NDArray | None, sums: PixelSums, lam: float,
            warnings: list[str], distances: CloudDistances | None = None) -> dict:
    """Warnings when Ψ looks misregistered or in another unit (a point cloud: its points' median distance to Γ
    beyond λ; a mesh: most pixels hit on both farther apart than λ; no common pixel; little box overlap), and the
    numbers behind them."""
    med_diff, med_ratio = sums.medians()
    box = scene.bounds()
    psi_box = psi_scene.bounds() if psi_scene is not None else np.stack([cloud.min(axis=0), cloud.max(axis=0)])
    diag_g = float(np.linalg.norm(box[1] - box[0]))
    diag_p = float(np.linalg.norm(psi_box[1] - psi_box[0]))
    size_ratio = diag_p / diag_g if diag_g > 0 else None
    hint = _unit_hint(med_ratio) if med_ratio is not None else ""
    hint = hint or (_unit_hint(size_ratio) if size_ratio is not None else "")
    box_text = "" if size_ratio is None else f"bounding-box size ratio Ψ/Γ {size_ratio:.4g}"
    n_both, n_far, n_model = sums.n_both, sums.n_far, sums.n_model
    scale_text = (f"scale ratio estimate median(dΨ/dΓ) = {med_ratio:.4g}" if med_ratio is not None else "")
    scale_text += (", " if scale_text and box_text else "") + box_text
    if distances is not None and distances.sampled and distances.median_all_m > lam:
        far = (f"{distances.median_all_m:.3g} m" if math.isfinite(distances.median_all_m)
               else f"beyond {distances.search_m:.3g} m")
        warnings.append(f"the median distance from the {distances.sampled:,} points measured to the model is {far}, "
                        f"more than λ = {lam:.3g} m: the reality looks badly registered or in another unit"
                        + (f"; {scale_text}" if scale_text else "") + hint)
    elif distances is None and n_both and n_far > FAR_SHARE_WARNING * n_both:
        warnings.append(
            f"{n_far / n_both:.0%} of the {n_both:,} pixels where both models are hit differ by more than λ = {lam:.3g} m "
            f"(median |dΓ − dΨ| = {med_diff:.3g} m): the reality looks badly registered or in another unit; "
            f"scale ratio estimate median(dΨ/dΓ) = {med_ratio:.4g}" + (f", {box_text}" if box_text else "") + hint)
    elif n_model and not n_both:
        warnings.append(f"the reality is hit on none of the {n_model:,} pixels where the model is: is it in the model's "
                        "frame and unit?" + (f" ({box_text}{_unit_hint(size_ratio)})" if box_text else ""))
    share = _overlap_share(box, psi_box, max(lam, 0.01 * diag_g))
    if share < OVERLAP_WARNING:
        warnings.append(f"the reality's bounding box covers only {share:.0%} of the model's"
                        + (f" ({box_text}{_unit_hint(size_ratio)})" if box_text else "")
                        + ": is it registered to the model, in the same frame and unit?")
    return {"median_abs_diff_m": med_diff, "median_ratio": med_ratio, "box_size_ratio": size_ratio,
            "box_overlap_share": share}


def validate(
    scene: Scene,
    plan: Plan,
    reality: Reality,
    registration_error_m: float,
    settings: EvaluationSettings | None = None,
    evaluation: Evaluation | None = None,
    *,
    point_spacing_m: float | None = None,
    ct_density_per_m2: float = CT_DENSITY_PER_M2,
    seed: int = 0,
    cache_dir: str | Path | None | bool = None,
    progress: ProgressCallback | None = None,
    stages: Callable[[str, int, int], None] | None = None,
) -> Validation:
    """Validate ``plan`` on ``scene`` (Γ at the capture date) against ``reality`` (Ψ, in Γ's frame and unit).

    reality: a Scene (mesh) or a point cloud (:class:`PointCloud` or (n, 3) points).
    registration_error_m: e; λ = 1.2·e. evaluation: the plan's evaluation on ``scene`` (its
    VR_i are the weights); evaluated with ``settings`` when not given. point_spacing_m: the
    cloud's spacing for splatting (estimated when None). See the module docstring. progress(done, frames): after
    each frame cast on Γ and Ψ. stages(name, done, total): hears every stage by name: 'distances' (a point cloud's
    distances to Γ), the evaluation's own when it is made here, 'index' (a point cloud's k-d tree and spacing),
    'comparing' (the frames cast on Γ and Ψ), 'completeness' (Ct) and 'precision'.
    """

    def stage(name: str, done: int = 0, total: int = 0) -> None:
        if stages is not None:
            stages(name, done, total)

    t_start = time.perf_counter()
    settings = settings or EvaluationSettings()
    e = _checked_numbers(registration_error_m, ct_density_per_m2)
    lam = LAMBDA_PER_E * e
    psi_scene, cloud = _reality_arrays(reality)
    timings: dict[str, float] = {}
    distances = None
    cloud_all = cloud
    if cloud is not None:
        t0 = time.perf_counter()
        stage("distances")
        distances = cloud_distances(cloud, scene, lam, seed)
        if 0 < distances.n_outliers < len(cloud):
            cloud = cloud[~distances.outlier]
        timings["distances_s"] = time.perf_counter() - t0
    if evaluation is None:
        t0 = time.perf_counter()
        evaluation = evaluate(scene, plan, settings, cache_dir=cache_dir, stages=stages)
        timings["evaluation_s"] = time.perf_counter() - t0
    obs = evaluation.observations
    if obs.n_elements != scene.n_elements or obs.n_frames != len(plan):
        raise SightplanError(f"the evaluation has {obs.n_frames} frames and {obs.n_elements} elements; the plan and "
                             f"model have {len(plan)} and {scene.n_elements}: evaluate this plan on this model")
    em = evaluation.metrics.elements
    is_target = em.is_target & scene.present
    VR = em.VR.astype(np.int64)
    visible = em.visible & is_target
    threads = max(1, settings.threads or min(32, os.cpu_count() or 1))
    warnings: list[str] = []
    if cloud is not None:
        stage("index")
    tree, spacing = _cloud_index(cloud, point_spacing_m, lam, seed, warnings)
    ct_radius = max(lam, spacing) if cloud is not None else lam

    # ---- pixels: A, Ce, Cv
    t0 = time.perf_counter()
    stage("comparing", 0, len(plan))

    def cast_progress(done: int, frames: int) -> None:
        if progress is not None:
            progress(done, frames)
        stage("comparing", done, frames)

    sums, engine_name = _cast(scene, plan, psi_scene, cloud, spacing, is_target, lam, settings, threads, cast_progress)
    timings["cast_s"] = time.perf_counter() - t0
    back, complete, both_n, diff_sum = sums.back, sums.complete, sums.both, sums.diff_sum
    c = np.where(back > 0, complete / np.maximum(back, 1), 0.0) * is_target
    with np.errstate(invalid="ignore", divide="ignore"):
        A_i = np.where(both_n > 0, diff_sum / np.maximum(both_n, 1), np.nan)
    weight = (VR * both_n * is_target).astype(np.float64)
    A = float((VR * diff_sum * is_target).sum() / weight.sum()) if weight.sum() > 0 else None
    z_t = int(is_target.sum())
    V = int(visible.sum())
    Ce = float(c[is_target].mean()) if z_t else None
    Cv = float(c[visible].mean()) if V else None

    # ---- surfaces: Ct (recall) and precision
    rng = np.random.default_rng(seed)
    t0 = time.perf_counter()
    stage("completeness")
    gamma_pts, near = _recall(scene, is_target, psi_scene, tree, ct_radius, ct_density_per_m2, rng)
    Ct = float(near.mean()) if len(gamma_pts) else None
    timings["ct_s"] = time.perf_counter() - t0
    t0 = time.perf_counter()
    stage("precision")
    psi_pts, prec_hit = _precision(scene, psi_scene, cloud_all, lam, ct_density_per_m2, rng)
    precision = float(prec_hit.mean()) if len(psi_pts) else None
    timings["precision_s"] = time.perf_counter() - t0
    recall = Ct
    if precision is None or recall is None:
        F = None
    else:
        F = 2 * precision * recall / (precision + recall) if precision + recall > 0 else 0.0

    sanity = _sanity(scene, psi_scene, cloud_all, sums, lam, warnings, distances)
    timings["total_s"] = time.perf_counter() - t_start
    counts = {"pixels_model": sums.n_model, "pixels_targets": int(back.sum()), "pixels_both": sums.n_both,
              "pixels_both_targets": int(both_n.sum()), "pixels_far": sums.n_far, "pixels_complete": int(complete.sum()),
              **sanity, "ct_samples": int(len(gamma_pts)), "ct_hits": int(near.sum()),
              "precision_samples": int(len(psi_pts)), "precision_hits": int(prec_hit.sum()),
              **({"distances": distances.to_dict()} if distances is not None else {})}
    parameters = {"scale": settings.scale, "engine": engine_name, "d_max_m": settings.d_max,
                  "omega": evaluation.settings.metric.omega, "ct_density_per_m2": ct_density_per_m2,
                  "ct_samples_min": CT_MIN_SAMPLES, "ct_samples_max": CT_MAX_SAMPLES, "seed": seed,
                  "point_spacing_m": spacing if cloud is not None else None, "ct_radius_m": ct_radius,
                  "outlier_mads": OUTLIER_MADS if cloud is not None else None,
                  "max_splat_px": MAX_SPLAT_PX if cloud is not None else None,
                  "reality_points": int(len(cloud_all)) if cloud_all is not None else None,
                  "reality_triangles": int(len(psi_scene.faces)) if psi_scene is not None else None}
    el = scene.elements
    return Validation(
        registration_error_m=e, lam=lam, A=A, Ce=Ce, Cv=Cv, Ct=Ct, precision=precision, recall=recall, F=F,
        z=z_t, n_visible=V, n_frames=len(plan), reality_kind="mesh" if psi_scene is not None else "point cloud",
        c=c, A_i=A_i, pixels=back, pixels_complete=complete, pixels_both=both_n, VR=VR, visible=visible,
        is_target=is_target, global_id=el.global_id, name=el.name, ifc_class=el.ifc_class, counts=counts,
        parameters=parameters, warnings=tuple(warnings), timings=timings,
        A_median=distances.median_m if distances is not None else None,
        A_p90=distances.p90_m if distances is not None else None,
        outliers=distances.n_outliers if distances is not None else 0,
    )
