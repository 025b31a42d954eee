"""The evaluation pipeline: scene at a date + plan → engine → Observations → metrics."""

from __future__ import annotations

import math
import time
from collections.abc import Callable
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from .engines import D_MAX_M, EngineName, make_engine
from .engines.base import OCCLUSION_TOLERANCE_M
from .engines.registry import resolve_engine
from .errors import SightplanError
from .metrics import MetricParams, Metrics, compute_metrics
from .model.scene import Scene
from .model.ties import TIE_TOL_M
from .observations.cache import FrameCache
from .observations.features import FeatureSet, cached_features, sample_features
from .observations.table import FrameObservation, Observations
from .plan.types import Plan
from .version import __version__

ProgressCallback = Callable[[int, int], None]
#: ``stages(name, done, total)``: which stage of an evaluation runs, and how far it is
StageCallback = Callable[[str, int, int], None]

# Bump when what a frame's observation means changes (kernels, tolerances): cached frames are then recast.
OBSERVATION_RULES = f"v3 occlusion={OCCLUSION_TOLERANCE_M} ties={TIE_TOL_M}"


@dataclass(frozen=True)
class EvaluationSettings:
    """Everything besides the scene and plan that determines an evaluation."""

    engine: EngineName = "auto"
    scale: float = 1.0
    d_max: float = D_MAX_M
    feature_density: float = 1.0
    feature_seed: int = 0
    threads: int | None = None
    metric: MetricParams = field(default_factory=MetricParams)

    def __post_init__(self) -> None:
        if not 0 < self.scale <= 1:
            raise SightplanError(f"resolution scale must be in (0, 1], got {self.scale}")
        if not (self.d_max > 0 and math.isfinite(self.d_max)):
            raise SightplanError(f"D_max must be a positive number of metres, got {self.d_max}")
        if not (self.feature_density >= 0 and math.isfinite(self.feature_density)):
            raise SightplanError(f"feature density must be a number ≥ 0 per m², got {self.feature_density}")
        if self.feature_seed < 0:
            raise SightplanError(f"the feature seed must be ≥ 0, got {self.feature_seed}")


@dataclass(frozen=True)
class Evaluation:
    """The result: observations (re-usable), metrics, and how long each stage took (s)."""

    observations: Observations
    metrics: Metrics
    settings: EvaluationSettings
    engine: str
    n_features: int
    timings: dict
    cache_hits: int = 0


def scene_features(scene: Scene, settings: EvaluationSettings, features: FeatureSet | None = None, *,
                   cache: bool = True) -> FeatureSet:
    """``features`` when they were sampled on ``scene``, or the settings' sampling of it when None (sampled once
    per scene and sampling parameters and then read from the feature cache; without ``cache``, sampled here and
    nothing read or written)."""
    if features is None:
        if not cache:
            return sample_features(scene, settings.feature_density, settings.feature_seed)
        return cached_features(scene, settings.feature_density, settings.feature_seed)
    if features.params.get("scene") not in (None, scene.key):
        raise SightplanError("the feature set was sampled on another scene (another model, options or capture date); "
                             "sample it again for this one")
    return features


def observation_meta(engine: str, settings: EvaluationSettings, scene_key: str, features_key: str,
                     feature_params: dict) -> dict:
    """What an Observations table records about how it was cast."""
    return {"engine": engine, "scale": settings.scale, "d_max": settings.d_max, "scene": scene_key,
            "features": features_key, "feature_params": feature_params}


def frame_context(scene: Scene, settings: EvaluationSettings, features_key: str, engine: str) -> str:
    """The per-frame cache's key of everything but the frame that determines a frame's observation: the version and
    observation rules, the scene, the features, the engine that casts it (its resolved name), scale and D_max."""
    return FrameCache.context_key(__version__, OBSERVATION_RULES, scene.key, len(scene.tie_pairs()), features_key,
                                  engine, settings.scale, settings.d_max)


def _stage(stages: StageCallback | None, name: str, done: int, total: int) -> None:
    if stages is not None:
        stages(name, done, total)


def observe_plan(
    scene: Scene,
    plan: Plan,
    settings: EvaluationSettings,
    features: FeatureSet | None = None,
    cache: FrameCache | None = None,
    progress: ProgressCallback | None = None,
    *,
    stages: StageCallback | None = None,
    feature_cache: bool = True,
) -> tuple[Observations, str, dict]:
    """Cast every frame of ``plan`` (or take it from ``cache``) into one Observations table.

    The engine (its BVH, tie table and feature index) is built only when a frame is missing from the cache, so a
    fully cached plan builds none. ``progress(done, frames)`` hears the frames, cached ones first; ``stages(name,
    done, total)`` hears every stage by name: 'ties' (when the scene's tie pairs are not known yet), 'features',
    'engine' and 'frames'. ``feature_cache``: read and write the feature cache when sampling.
    """
    timings: dict[str, float] = {}
    if not scene.has_tie_pairs():
        t0 = time.perf_counter()
        _stage(stages, "ties", 0, 1)
        scene.tie_pairs()
        _stage(stages, "ties", 1, 1)
        timings["ties_s"] = time.perf_counter() - t0
    t0 = time.perf_counter()
    _stage(stages, "features", 0, 1)
    features = scene_features(scene, settings, features, cache=feature_cache)
    _stage(stages, "features", 1, 1)
    timings["features_s"] = time.perf_counter() - t0
    engine_name = resolve_engine(settings.engine)
    features_key = features.key
    context = frame_context(scene, settings, features_key, engine_name)
    n = len(plan)
    frames: list[FrameObservation | None] = [None] * n
    keys: list[str] = []
    t0 = time.perf_counter()
    if cache is not None:
        keys = plan.frame_keys()
        frames = [cache.get(context, key) for key in keys]
    done = sum(fo is not None for fo in frames)
    if progress is not None and done:
        progress(done, n)
    timings["cache_read_s"] = time.perf_counter() - t0
    timings["engine_build_s"] = timings["cast_s"] = 0.0
    cast = 0
    if done < n:
        t0 = time.perf_counter()
        _stage(stages, "engine", 0, 1)
        engine = make_engine(engine_name, scene, features, d_max=settings.d_max, threads=settings.threads)
        engine.feature_index  # noqa: B018  (built now, inside the stage that names it)
        _stage(stages, "engine", 1, 1)
        timings["engine_build_s"] = time.perf_counter() - t0
        _stage(stages, "frames", done, n)
        t0 = time.perf_counter()
        with engine:
            for i in range(n):
                if frames[i] is not None:
                    continue
                fo = engine.observe(plan.camera_of(i), plan.R_world_camera[i], plan.C_world[i], settings.scale)
                cast += 1
                if cache is not None:
                    cache.put(context, keys[i], fo)
                frames[i] = fo
                done += 1
                _stage(stages, "frames", done, n)
                if progress is not None:
                    progress(done, n)
        timings["cast_s"] = time.perf_counter() - t0
    else:
        _stage(stages, "frames", done, n)
    timings["frames_cast"] = cast
    obs = Observations.from_frames(frames, scene.targets, scene.present, len(features),
                                   observation_meta(engine_name, settings, scene.key, features_key, features.params))
    return obs, engine_name, timings


def evaluate(
    scene: Scene,
    plan: Plan,
    settings: EvaluationSettings | None = None,
    *,
    features: FeatureSet | None = None,
    cache_dir: str | Path | None | bool = None,
    progress: ProgressCallback | None = None,
    stages: StageCallback | None = None,
) -> Evaluation:
    """Evaluate ``plan`` against ``scene`` (already at its capture date).

    cache_dir: a directory for the per-frame cache, None for the default one, False for none (then no cache is
    read or written, the feature cache included). progress and stages: as :func:`observe_plan`.
    """
    settings = settings or EvaluationSettings()
    if len(plan) == 0:
        raise SightplanError("the plan has no frames")
    if not scene.targets.any():
        raise SightplanError("the model has no target elements to evaluate")
    cache = None if cache_dir is False else FrameCache(None if cache_dir is None else cache_dir)
    t_start = time.perf_counter()
    obs, engine_name, timings = observe_plan(scene, plan, settings, features, cache, progress, stages=stages,
                                             feature_cache=cache is not None)
    t0 = time.perf_counter()
    metrics = compute_metrics(obs, settings.metric)
    timings["metrics_s"] = time.perf_counter() - t0
    timings["total_s"] = time.perf_counter() - t_start
    n = len(plan)
    timings["s_per_frame"] = timings["cast_s"] / max(1, timings["frames_cast"]) if timings["frames_cast"] else 0.0
    timings["frames"] = n
    return Evaluation(obs, metrics, settings, engine_name, obs.n_features, timings,
                      cache.hits if cache is not None else 0)


def pixel_counts(obs: Observations) -> np.ndarray:
    """(n_frames, z) dense matrix of full-resolution pixel counts — for small plans and tests."""
    out = np.zeros((obs.n_frames, obs.n_elements))
    out[obs.frame, obs.element] = obs.pixels
    return out
