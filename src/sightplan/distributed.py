"""Evaluate a plan on a dask cluster: consecutive batches of frames cast on the workers.

The scene and the feature set go to each worker once; each worker process keeps one
engine per scene and settings, so the BVH is built once per worker, not per batch.
The merged observations and metrics equal those of a local :func:`~sightplan.evaluate.evaluate`
with the same settings and features (the engines must use the same number of threads,
which ``settings.threads`` fixes; left at None it is the machine's core count).
"""

from __future__ import annotations

import threading
import time
from collections import OrderedDict
from contextlib import ExitStack
from typing import TYPE_CHECKING

import numpy as np

from .engines import make_engine
from .engines.base import Engine
from .errors import SightplanError
from .evaluate import Evaluation, EvaluationSettings, ProgressCallback, observation_meta, scene_features
from .extras import require
from .metrics import compute_metrics
from .model.scene import Scene
from .observations.features import FeatureSet
from .observations.table import Observations
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


def observe_batch(scene: Scene, features: FeatureSet, plan: Plan, settings: EvaluationSettings,
                  scene_key: str, features_key: str) -> tuple[Observations, float]:
    """Cast the frames of ``plan`` with this worker's cached engine: its Observations and cast seconds."""
    key = (scene_key, features_key, settings.engine, settings.d_max, settings.threads)
    engine = _worker_engine(scene, features, key, settings)
    t0 = time.perf_counter()
    frames = [engine.observe(plan.camera_of(i), plan.R_world_camera[i], plan.C_world[i], settings.scale)
              for i in range(len(plan))]
    cast_s = time.perf_counter() - t0
    meta = observation_meta(engine.name, settings, scene_key, features_key, features.params)
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
    progress: ProgressCallback | None = None,
) -> Evaluation:
    """Evaluate ``plan`` against ``scene`` on a dask cluster, ``batch_frames`` consecutive frames per task.

    cluster: a scheduler address (``tcp://host:8786``), ``local:N`` for a LocalCluster of N worker
    processes started and closed here, or a :class:`distributed.Client` used as is.
    progress: called with (frames done, frames) as batches complete.
    """
    settings = settings or EvaluationSettings()
    if len(plan) == 0:
        raise SightplanError("the plan has no frames")
    if batch_frames < 1:
        raise SightplanError(f"frames per batch must be ≥ 1, got {batch_frames}")
    if not scene.targets.any():
        raise SightplanError("the model has no target elements to evaluate")
    timings: dict[str, float] = {}
    t_start = time.perf_counter()
    scene_key = scene.key
    features = scene_features(scene, settings, features)
    timings["features_s"] = time.perf_counter() - t_start
    n = len(plan)
    bounds = [(a, min(a + batch_frames, n)) for a in range(0, n, batch_frames)]
    with ExitStack() as stack:
        client = cluster if not isinstance(cluster, str) else connect(cluster, stack)
        from distributed import as_completed

        t0 = time.perf_counter()
        scene_f = client.scatter(scene, broadcast=True, hash=False)
        features_f = client.scatter(features, broadcast=True, hash=False)
        futures = [client.submit(observe_batch, scene_f, features_f, plan.subset(np.arange(a, b)), settings,
                                 scene_key, features.key, pure=False)
                   for a, b in bounds]
        index = {f.key: i for i, f in enumerate(futures)}
        results: list[tuple[Observations, float] | None] = [None] * len(futures)
        done = 0
        for fut in as_completed(futures):
            i = index[fut.key]
            results[i] = fut.result()
            done += bounds[i][1] - bounds[i][0]
            if progress is not None:
                progress(done, n)
        timings["cast_s"] = time.perf_counter() - t0
        timings["workers"] = len(client.nthreads())
        del scene_f, features_f, futures
    parts = [r[0] for r in results if r is not None]
    obs = Observations.concatenate(parts)
    t0 = time.perf_counter()
    metrics = compute_metrics(obs, settings.metric)
    timings["metrics_s"] = time.perf_counter() - t0
    timings["total_s"] = time.perf_counter() - t_start
    timings["worker_cast_s"] = float(sum(r[1] for r in results if r is not None))
    timings["frames_cast"] = n
    timings["s_per_frame"] = timings["cast_s"] / n
    timings["frames"] = n
    timings["batches"] = len(bounds)
    return Evaluation(obs, metrics, settings, str(obs.meta["engine"]), obs.n_features, timings, 0)
