"""What a reconstruction measured, per element and per frame, set beside what the plan predicted.

Per element i (indexed like the scene's element table):

- **points**: the reconstruction's points whose nearest triangle of the model, within the tolerance τ, belongs to
  i (exact point–triangle distances, :func:`sightplan.validate.nearest_faces`); a point within τ of no triangle
  belongs to no element;
- **surface samples**: max(``MIN_SAMPLES_PER_ELEMENT``, round(area_i · density)) points drawn uniformly on i's
  triangles (seeded; ``SAMPLES_PER_M2`` per m², the density lowered for every element alike when the total would
  exceed ``MAX_SAMPLES``), each with its triangle's outward normal;
- **visible samples**: the samples that at least one *planned* frame sees unoccluded, in its image and from their
  front side: the engine's feature-visibility test (METRICS.md §5.2) with the samples as the features;
- **completeness** c_i = visible samples with one of i's points within r / visible samples (NaN when none is
  visible); **density** = points / visible area, the visible area being area_i · visible samples / samples (NaN
  when none is visible).

Defaults, from the plan's resolution ρ (the median R_i over the visible target elements, m/px, divided by the
renders' image scale) and the registration residual e: τ = 1.2·e + ``TOLERANCE_PX``·ρ (the registration error
as λ is, plus a triangulation error of three pixels' footprint) and r = max(τ, s) with s the spacing of the points
on the model (:func:`sightplan.validate.point_spacing`, 1/√density): a sparse point stands for the surface around
it as far as the cloud's own sampling reaches, as the validation's Ct counts it.

Per frame: registered or not and its position and rotation errors (from the reconstruction), with the
evaluation's ν_f and stable flag (METRICS.md §5.3–5.4).
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass, field

import numpy as np
from numpy.typing import NDArray

from ..engines import make_engine
from ..engines.registry import ray_engine_name
from ..errors import SightplanError
from ..evaluate import Evaluation, EvaluationSettings, evaluate
from ..model.pointcloud import PointCloud
from ..model.scene import Scene
from ..observations.features import FeatureSet
from ..plan.types import Plan
from ..validate import LAMBDA_PER_E, Validation, nearest_faces, point_spacing, sample_surface, validate
from .files import Reconstruction, _num, pose_error_summary

ProgressCallback = Callable[[int, int], None]

SAMPLES_PER_M2 = 100.0
MIN_SAMPLES_PER_ELEMENT = 50
MAX_SAMPLES = 1_000_000
TOLERANCE_PX = 3.0
#: Samples are lifted this far along their normal for the visibility test, as the simulated features are.
SAMPLE_OFFSET_M = 0.001


@dataclass(frozen=True)
class ReconstructionMeasures:
    """Measured per element (arrays (z,)) and per frame (arrays (n,)); see the module docstring.

    tolerance_m τ, radius_m r, resolution_m_px ρ (None when no element is visible and τ, r were given).
    point_element (points,): the element of each reconstruction point, −1 for none; point_distance_m its
    distance to that element's nearest triangle (inf for none).
    """

    tolerance_m: float
    radius_m: float
    resolution_m_px: float | None
    samples_per_m2: float
    points: NDArray[np.int64]
    samples: NDArray[np.int64]
    visible_samples: NDArray[np.int64]
    covered_samples: NDArray[np.int64]
    area_m2: NDArray[np.float64]
    is_target: NDArray[np.bool_]
    global_id: NDArray[np.object_]
    name: NDArray[np.object_]
    ifc_class: NDArray[np.object_]
    point_element: NDArray[np.int32]
    point_distance_m: NDArray[np.float64]
    frame_names: tuple[str, ...]
    registered: NDArray[np.bool_]
    position_error_m: NDArray[np.float64]
    rotation_error_deg: NDArray[np.float64]
    nu: NDArray[np.int64]
    stable: NDArray[np.bool_]
    residual_m: float
    scene_size_m: float
    warnings: tuple[str, ...] = ()
    parameters: dict = field(default_factory=dict)

    @property
    def visible_area_m2(self) -> NDArray[np.float64]:
        with np.errstate(invalid="ignore", divide="ignore"):
            return np.where(self.samples > 0, self.area_m2 * self.visible_samples / np.maximum(self.samples, 1), 0.0)

    @property
    def completeness(self) -> NDArray[np.float64]:
        """(z,) covered / visible samples; NaN where no sample is visible."""
        with np.errstate(invalid="ignore", divide="ignore"):
            return np.where(self.visible_samples > 0, self.covered_samples / np.maximum(self.visible_samples, 1),
                            np.nan)

    @property
    def density_per_m2(self) -> NDArray[np.float64]:
        """(z,) points per m² of visible surface; NaN where none is visible."""
        area = self.visible_area_m2
        with np.errstate(invalid="ignore", divide="ignore"):
            return np.where(area > 0, self.points / np.where(area > 0, area, 1.0), np.nan)

    @property
    def n_points_on_model(self) -> int:
        return int(np.count_nonzero(self.point_element >= 0))

    def summary(self) -> dict:
        """Totals: points on and off the model, frames registered, pose errors, mean completeness."""
        c = self.completeness[self.is_target]
        c = c[np.isfinite(c)]
        return {"points": int(len(self.point_element)), "points_on_model": self.n_points_on_model,
                "frames": len(self.frame_names), "frames_registered": int(self.registered.sum()),
                **pose_error_summary(self.registered, self.position_error_m, self.rotation_error_deg),
                "residual_m": self.residual_m, "residual_share": (self.residual_m / self.scene_size_m
                                                                 if self.scene_size_m > 0 else None),
                "elements_visible": int((self.visible_samples[self.is_target] > 0).sum()),
                "elements_with_points": int((self.points[self.is_target] > 0).sum()),
                "completeness_mean": float(c.mean()) if len(c) else None}

    def element_rows(self) -> list[dict]:
        """One row per target element: global_id, name, ifc_class, points, density, completeness, samples."""
        c, d, va = self.completeness, self.density_per_m2, self.visible_area_m2
        return [{"global_id": str(self.global_id[i]), "name": str(self.name[i]), "ifc_class": str(self.ifc_class[i]),
                 "points": int(self.points[i]), "density_per_m2": _num(d[i]), "completeness": _num(c[i]),
                 "visible_area_m2": float(va[i]), "samples": int(self.samples[i]),
                 "visible_samples": int(self.visible_samples[i])} for i in np.flatnonzero(self.is_target)]

    def frame_rows(self) -> list[dict]:
        """One row per planned frame: name, registered, pose errors, ν_f, stable."""
        return [{"frame": name, "registered": bool(self.registered[f]),
                 "position_error_m": _num(self.position_error_m[f]),
                 "rotation_error_deg": _num(self.rotation_error_deg[f]), "nu": int(self.nu[f]),
                 "stable": bool(self.stable[f])} for f, name in enumerate(self.frame_names)]

    def to_dict(self) -> dict:
        return {"format": "sightplan-reconstruction-measures", "version": 1, "tolerance_m": self.tolerance_m,
                "radius_m": self.radius_m, "resolution_m_px": self.resolution_m_px,
                "samples_per_m2": self.samples_per_m2, "summary": self.summary(), "parameters": dict(self.parameters),
                "warnings": list(self.warnings), "elements": self.element_rows(), "frames": self.frame_rows()}


# =========================================================================== pieces
def plan_resolution(evaluation: Evaluation) -> float | None:
    """ρ: the median R_i (m/px) over the visible target elements; None when none is visible."""
    em = evaluation.metrics.elements
    r = em.R[em.visible & em.is_target]
    r = r[np.isfinite(r)]
    return float(np.median(r)) if len(r) else None


def element_samples(scene: Scene, density: float, rng: np.random.Generator, *,
                    min_per_element: int = MIN_SAMPLES_PER_ELEMENT, max_total: int = MAX_SAMPLES
                    ) -> tuple[NDArray[np.float64], NDArray[np.float64], NDArray[np.int32], float]:
    """Samples on every element with triangles: (k, 3) points, (k, 3) outward normals (the triangles' winding
    normals), (k,) element, and the density used (lowered when the total would exceed ``max_total``)."""
    if not (density > 0 and math.isfinite(density)):
        raise SightplanError(f"the surface sampling density must be a positive number per m², got {density!r}")
    area_f = scene.face_areas()
    z = scene.n_elements
    area = np.bincount(scene.face_element, weights=area_f, minlength=z)
    has = np.bincount(scene.face_element, minlength=z) > 0

    def counts(d: float) -> NDArray[np.int64]:
        return np.where(has & (area > 0), np.maximum(min_per_element, np.round(area * d)), 0).astype(np.int64)

    n = counts(density)
    while n.sum() > max_total and density > 1e-9:
        density *= 0.8 * max_total / n.sum()
        n = counts(density)
    normals = scene.face_normals()
    order = np.argsort(scene.face_element, kind="stable")
    starts = np.searchsorted(scene.face_element[order], np.arange(z + 1))
    pts, nrm, elem = [], [], []
    for i in np.flatnonzero(n):
        faces_i = order[starts[i]:starts[i + 1]]
        p, f = sample_surface(scene.vertices, scene.faces[faces_i], int(n[i]), rng)
        pts.append(p)
        nrm.append(normals[faces_i[f]])
        elem.append(np.full(len(p), i, np.int32))
    if not pts:
        return np.zeros((0, 3)), np.zeros((0, 3)), np.zeros(0, np.int32), density
    return np.concatenate(pts), np.concatenate(nrm), np.concatenate(elem), density


def seen_samples(scene: Scene, plan: Plan, points: NDArray, normals: NDArray, settings: EvaluationSettings,
                 progress: ProgressCallback | None = None) -> NDArray[np.bool_]:
    """(k,) whether some frame of ``plan`` sees each sample (unoccluded, in the image, from its front side)."""
    seen = np.zeros(len(points), bool)
    if len(points) == 0:
        return seen
    features = FeatureSet(points + SAMPLE_OFFSET_M * normals, normals, np.ones(len(points), np.int8),
                          np.full(len(points), -1, np.int32), {"samples": "reconstruction measures"})
    engine = make_engine(ray_engine_name(settings.engine), scene, features, d_max=settings.d_max,
                         threads=settings.threads)
    with engine:
        for f in range(len(plan)):
            seen[engine.visible_features(plan.camera_of(f), plan.R_world_camera[f], plan.C_world[f])] = True
            if progress is not None:
                progress(f + 1, len(plan))
    return seen


def frame_registration(plan: Plan, rec: Reconstruction) -> tuple[NDArray, NDArray, NDArray, list[str]]:
    """The reconstruction's registered flags and pose errors in the plan's frame order, and warnings."""
    if len(rec.frame_names) != len(plan):
        raise SightplanError(f"the reconstruction has {len(rec.frame_names)} frames and the plan {len(plan)}: "
                             "reconstruct the renders of this plan")
    stem = lambda s: str(s).rsplit("/", 1)[-1].rsplit(".", 1)[0]  # noqa: E731
    warnings = []
    differ = [i for i, (a, b) in enumerate(zip(plan.frame_names, rec.frame_names, strict=True)) if stem(a) != stem(b)]
    if differ:
        i = differ[0]
        warnings.append(f"{len(differ)} frame names differ between the plan and the reconstruction (first: "
                        f"{plan.frame_names[i]!r} and {rec.frame_names[i]!r}); frames are matched in plan order")
    return rec.registered.copy(), rec.position_error_m.copy(), rec.rotation_error_deg.copy(), warnings


# =========================================================================== measures
def measure_reconstruction(
    scene: Scene,
    plan: Plan,
    reconstruction: Reconstruction,
    evaluation: Evaluation | None = None,
    *,
    settings: EvaluationSettings | None = None,
    tolerance_m: float | None = None,
    radius_m: float | None = None,
    image_scale: float = 1.0,
    samples_per_m2: float = SAMPLES_PER_M2,
    seed: int = 0,
    progress: ProgressCallback | None = None,
) -> ReconstructionMeasures:
    """Points, density and completeness per element and registration per frame (module docstring).

    evaluation: the plan's evaluation on ``scene`` (made with ``settings`` when None). image_scale: the scale the
    photographs were taken at relative to the plan's cameras (the renders' scale), for the default τ and r.
    progress(i, n): frames tested for visibility.
    """
    settings = settings or (evaluation.settings if evaluation is not None else EvaluationSettings())
    if evaluation is None:
        evaluation = evaluate(scene, plan, settings, cache_dir=False)
    if evaluation.observations.n_elements != scene.n_elements or evaluation.observations.n_frames != len(plan):
        raise SightplanError("the evaluation is of another plan or model: evaluate this plan on this model")
    if not (image_scale > 0 and math.isfinite(image_scale)):
        raise SightplanError(f"the image scale must be a positive number, got {image_scale!r}")
    registered, pos_err, rot_err, warnings = frame_registration(plan, reconstruction)
    rho = plan_resolution(evaluation)
    rho = None if rho is None else rho / image_scale
    e = float(reconstruction.residual_m) if math.isfinite(reconstruction.residual_m) else 0.0
    if tolerance_m is None:
        if rho is None:
            raise SightplanError("no element is visible from the plan: give the tolerance and the radius")
        tolerance_m = LAMBDA_PER_E * e + TOLERANCE_PX * rho
    if not (tolerance_m > 0 and math.isfinite(tolerance_m)):
        raise SightplanError(f"the tolerance must be a positive number of metres, got {tolerance_m!r}")
    z = scene.n_elements

    # ---- points on elements
    pts = reconstruction.points
    face, dist = nearest_faces(pts, scene.vertices, scene.faces, tolerance_m)
    point_element = np.where(face >= 0, scene.face_element[np.maximum(face, 0)], -1).astype(np.int32)
    n_points = np.bincount(point_element[point_element >= 0], minlength=z).astype(np.int64)
    on_model = pts[point_element >= 0]
    spacing = point_spacing(on_model, seed=seed) if len(on_model) >= 2 else None
    if radius_m is None:
        radius_m = max(tolerance_m, spacing or 0.0)
    if not (radius_m > 0 and math.isfinite(radius_m)):
        raise SightplanError(f"the radius must be a positive number of metres, got {radius_m!r}")

    # ---- visible samples and their cover
    rng = np.random.default_rng(seed)
    s_pts, s_nrm, s_elem, density = element_samples(scene, samples_per_m2, rng)
    seen = seen_samples(scene, plan, s_pts, s_nrm, settings, progress)
    samples = np.bincount(s_elem, minlength=z).astype(np.int64)
    visible = np.bincount(s_elem[seen], minlength=z).astype(np.int64)
    covered = np.zeros(z, np.int64)
    from scipy.spatial import cKDTree

    reach = np.nextafter(radius_m, np.inf)
    by_point = np.argsort(point_element, kind="stable")
    p_starts = np.searchsorted(point_element[by_point], np.arange(z + 1))
    by_sample = np.flatnonzero(seen)
    by_sample = by_sample[np.argsort(s_elem[by_sample], kind="stable")]  # the visible samples, element by element
    s_starts = np.searchsorted(s_elem[by_sample], np.arange(z + 1))
    for i in np.flatnonzero((visible > 0) & (n_points > 0)):
        mine = pts[by_point[p_starts[i]:p_starts[i + 1]]]
        vis = s_pts[by_sample[s_starts[i]:s_starts[i + 1]]]
        d, _ = cKDTree(mine).query(vis, k=1, distance_upper_bound=reach)
        covered[i] = int(np.isfinite(d).sum())

    area = np.bincount(scene.face_element, weights=scene.face_areas(), minlength=z)
    fm = evaluation.metrics.frames
    el = scene.elements
    return ReconstructionMeasures(
        tolerance_m=float(tolerance_m), radius_m=float(radius_m), resolution_m_px=rho, samples_per_m2=float(density),
        points=n_points, samples=samples, visible_samples=visible, covered_samples=covered, area_m2=area,
        is_target=scene.targets.copy(), global_id=el.global_id, name=el.name, ifc_class=el.ifc_class,
        point_element=point_element, point_distance_m=dist, frame_names=tuple(map(str, plan.frame_names)),
        registered=registered, position_error_m=pos_err, rotation_error_deg=rot_err, nu=fm.nu.copy(),
        stable=fm.stable.copy(), residual_m=float(reconstruction.residual_m),
        scene_size_m=float(reconstruction.scene_size_m), warnings=tuple(warnings),
        parameters={"tolerance_px": TOLERANCE_PX, "point_spacing_m": spacing, "image_scale": image_scale,
                    "min_samples_per_element": MIN_SAMPLES_PER_ELEMENT, "seed": seed,
                    "engine": ray_engine_name(settings.engine)})


# =========================================================================== as a reality for the validation
def reconstruction_reality(reconstruction: Reconstruction) -> PointCloud:
    """The reconstruction's points as the reality point cloud Ψ (model frame; no normals)."""
    if len(reconstruction.points) == 0:
        raise SightplanError("the reconstruction has no points: there is nothing to validate against")
    return PointCloud(np.asarray(reconstruction.points, np.float64), None)


def reconstruction_error(reconstruction: Reconstruction, registration_error_m: float | None = None) -> float:
    """The registration error e for the validation: the one given, else the reconstruction's residual."""
    if registration_error_m is not None:
        return float(registration_error_m)
    e = float(reconstruction.residual_m)
    if not (e >= 0 and math.isfinite(e)):
        raise SightplanError(f"the reconstruction's registration residual is {e!r}: give the registration error")
    return e


def validate_reconstruction(scene: Scene, plan: Plan, reconstruction: Reconstruction,
                            registration_error_m: float | None = None, settings: EvaluationSettings | None = None,
                            evaluation: Evaluation | None = None, **kwargs) -> Validation:
    """:func:`sightplan.validate.validate` with the reconstruction's points as Ψ and its residual as e (unless
    ``registration_error_m`` is given); other keyword arguments go to it."""
    e = reconstruction_error(reconstruction, registration_error_m)
    return validate(scene, plan, reconstruction_reality(reconstruction), e, settings, evaluation, **kwargs)
