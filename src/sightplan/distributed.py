"""Evaluate a plan on a dask cluster: consecutive batches of frames cast on the workers.

The scene and the feature set go to each worker once; each worker process keeps one
engine per scene and settings, so the BVH is built once per worker, not per batch.
The merged observations and metrics equal those of a local :func:`~sightplan.evaluate.evaluate`
with the same settings and features (the engines must use the same number of threads,
which ``settings.threads`` fixes; left at None it is the machine's core count).
With a per-frame cache, the frames found in it are read here and only the others are cast
on the cluster; what the workers cast is then stored in the cache.
"""

from __future__ import annotations

import threading
import time
from collections import OrderedDict
from contextlib import ExitStack
from dataclasses import replace
from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np

from .engines import make_engine
from .engines.base import Engine
from .engines.registry import best_engine
from .errors import SightplanError
from .evaluate import (
    Evaluation,
    EvaluationSettings,
    ProgressCallback,
    frame_context,
    observation_meta,
    scene_features,
)
from .extras import require
from .metrics import compute_metrics
from .model.scene import Scene
from .observations.cache import FrameCache
from .observations.features import FeatureSet
from .observations.table import FrameObservation, Observations
from .plan.types import Plan

if TYPE_CHECKING:
    from distributed import Client

CONNECT_TIMEOUT_S = 5.0
_ENGINE_CACHE_SIZE = 2
_engines: OrderedDict[tuple, Engine] = OrderedDict()
_engines_lock = threading.Lock()


def _worker_engine(scene: Scene, features: FeatureSet, key: tuple, settings: EvaluationSettings) -> Engine:
    """This process's engine for ``key`` (scene, features, engine settings), built on first use."""
    with _engines_lock:
        engine = _engines.get(key)
        if engine is None:
            engine = make_engine(settings.engine, scene, features, d_max=settings.d_max, threads=settings.threads)
            _engines[key] = engine
            while len(_engines) > _ENGINE_CACHE_SIZE:
                _engines.popitem(last=False)[1].close()
        _engines.move_to_end(key)
        return engine


def observe_frames(scene: Scene, features: FeatureSet, plan: Plan, settings: EvaluationSettings,
                   scene_key: str, features_key: str) -> tuple[list[FrameObservation], str, float]:
    """Cast the frames of ``plan`` with this worker's cached engine: each frame's observation (what the per-frame
    cache stores), the engine's name and the cast seconds."""
    key = (scene_key, features_key, settings.engine, settings.d_max, settings.threads)
    engine = _worker_engine(scene, features, key, settings)
    t0 = time.perf_counter()
    frames = [engine.observe(plan.camera_of(i), plan.R_world_camera[i], plan.C_world[i], settings.scale)
              for i in range(len(plan))]
    return frames, engine.name, time.perf_counter() - t0


def observe_batch(scene: Scene, features: FeatureSet, plan: Plan, settings: EvaluationSettings,
                  scene_key: str, features_key: str) -> tuple[Observations, float]:
    """Cast the frames of ``plan`` with this worker's cached engine: its Observations and cast seconds."""
    frames, engine, cast_s = observe_frames(scene, features, plan, settings, scene_key, features_key)
    meta = observation_meta(engine, settings, scene_key, features_key, features.params)
    return Observations.from_frames(frames, scene.targets, scene.present, len(features), meta), cast_s


def connect(cluster: str, stack: ExitStack) -> Client:
    """A client for ``cluster``: ``local:N`` starts a LocalCluster of N worker processes (closed with ``stack``)."""
    require("cluster", "--cluster")
    from distributed import Client, LocalCluster

    if cluster == "local" or cluster.startswith("local:"):
        n_text = cluster.partition(":")[2] or "2"
        try:
            n = int(n_text)
        except ValueError:
            n = 0
        if n < 1:
            raise SightplanError(f"--cluster local:N needs N ≥ 1 worker processes, got {cluster!r}")
        lc = stack.enter_context(LocalCluster(n_workers=n, threads_per_worker=1, processes=True,
                                              dashboard_address=None))
        return stack.enter_context(Client(lc))
    try:
        return stack.enter_context(Client(cluster, timeout=CONNECT_TIMEOUT_S))
    except (OSError, TimeoutError, ValueError) as exc:
        raise SightplanError(f"cannot reach the dask scheduler at {cluster} within {CONNECT_TIMEOUT_S:g} s "
                             f"({type(exc).__name__}: {exc})") from None


def evaluate_distributed(
    scene: Scene,
    plan: Plan,
    settings: EvaluationSettings | None = None,
    *,
    cluster: str | Client,
    batch_frames: int = 64,
    features: FeatureSet | None = None,
    cache_dir: str | Path | None | bool = False,
    progress: ProgressCallback | None = None,
    feature_cache: bool = True,
) -> Evaluation:
    """Evaluate ``plan`` against ``scene`` on a dask cluster, ``batch_frames`` frames per task.

    cluster: a scheduler address (``tcp://host:8786``), ``local:N`` for a LocalCluster of N worker
    processes started and closed here, or a :class:`distributed.Client` used as is.
    cache_dir: a directory for the per-frame cache, None for the default one, False (the default) for
    none. With a cache, ``auto`` is resolved to a worker's best engine before anything is cast (the
    cache is keyed by the engine), the cached frames are read here, only the others go to the cluster
    (which is contacted only to resolve ``auto`` when every frame is cached), and what it casts is stored.
    progress: called with (frames done, frames) after the cache is read and as batches complete.
    feature_cache: read and write the feature cache when the features are sampled here.
    """
    settings = settings or EvaluationSettings()
    if len(plan) == 0:
        raise SightplanError("the plan has no frames")
    if batch_frames < 1:
        raise SightplanError(f"frames per batch must be ≥ 1, got {batch_frames}")
    if not scene.targets.any():
        raise SightplanError("the model has no target elements to evaluate")
    cache = None if cache_dir is False else FrameCache(None if cache_dir is None else cache_dir)
    timings: dict[str, float] = {}
    t_start = time.perf_counter()
    scene_key = scene.key
    features = scene_features(scene, settings, features, cache=feature_cache)
    timings["features_s"] = time.perf_counter() - t_start
    with ExitStack() as stack:
        reached: list[Client] = []

        def reach() -> Client:
            """The cluster's client, connected on first need (not at all when every frame is cached)."""
            if not reached:
                reached.append(cluster if not isinstance(cluster, str) else connect(cluster, stack))
            return reached[0]

        n = len(plan)
        frames: list[FrameObservation | None] = [None] * n
        engines: set[str] = set()
        keys: list[str] = []
        context = ""
        if cache is not None:
            # the workers' own best engine: a GPU here does not make CPU workers cast with OpenGL
            name = reach().submit(best_engine, pure=False).result() if settings.engine == "auto" else str(settings.engine)
            settings = replace(settings, engine=name)  # type: ignore[arg-type]
            engines.add(name)
            context = frame_context(scene, settings, features.key, name)
            keys = plan.frame_keys()
            frames = [cache.get(context, key) for key in keys]
        todo = np.flatnonzero([fo is None for fo in frames])
        if progress is not None and len(todo) < n:
            progress(n - len(todo), n)
        batches = [todo[a:a + batch_frames] for a in range(0, len(todo), batch_frames)]
        timings["cast_s"] = timings["worker_cast_s"] = 0.0
        timings["workers"] = 0
        if batches:
            client = reach()
            from distributed import as_completed

            t0 = time.perf_counter()
            scene_f = client.scatter(scene, broadcast=True, hash=False)
            features_f = client.scatter(features, broadcast=True, hash=False)
            futures = [client.submit(observe_frames, scene_f, features_f, plan.subset(batch), settings, scene_key,
                                     features.key, pure=False) for batch in batches]
            index = {f.key: i for i, f in enumerate(futures)}
            done = n - len(todo)
            for fut in as_completed(futures):
                batch = batches[index[fut.key]]
                cast, name, cast_s = fut.result()
                engines.add(name)
                timings["worker_cast_s"] += cast_s
                for i, fo in zip(batch, cast):
                    frames[i] = fo
                    if cache is not None:
                        cache.put(context, keys[i], fo)
                done += len(batch)
                if progress is not None:
                    progress(done, n)
            timings["cast_s"] = time.perf_counter() - t0
            timings["workers"] = len(client.nthreads())
            del scene_f, features_f, futures
    if len(engines) != 1:
        raise SightplanError(f"the workers cast with different engines ({', '.join(sorted(engines))}): name one with "
                             "the engine setting")
    engine = engines.pop()
    obs = Observations.from_frames(frames, scene.targets, scene.present, len(features),  # type: ignore[arg-type]
                                   observation_meta(engine, settings, scene_key, features.key, features.params))
    t0 = time.perf_counter()
    metrics = compute_metrics(obs, settings.metric)
    timings["metrics_s"] = time.perf_counter() - t0
    timings["total_s"] = time.perf_counter() - t_start
    timings["frames_cast"] = len(todo)
    timings["s_per_frame"] = timings["cast_s"] / len(todo) if len(todo) else 0.0
    timings["frames"] = n
    timings["batches"] = len(batches)
    return Evaluation(obs, metrics, settings, engine, obs.n_features, timings, cache.hits if cache is not None else 0)
