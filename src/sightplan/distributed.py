"""Evaluate a plan on a dask cluster: consecutive batches of frames cast on the workers; prepare a model file there.

The scene and the feature set go to each worker once; each worker process keeps one
engine per scene and settings, so the BVH is built once per worker, not per batch.
The merged observations and metrics equal those of a local :func:`~sightplan.evaluate.evaluate`
with the same settings and features (the engines must use the same number of threads,
which ``settings.threads`` fixes; left at None it is the machine's core count).
With a per-frame cache, the frames found in it are read here and only the others are cast
on the cluster; what the workers cast is then stored in the cache.

:func:`prepare_model` tessellates a model file into a scene cache on a worker: the file and the cache are named by
their paths, so the worker must see them at the same paths (a shared folder).
"""

from __future__ import annotations

import socket
import threading
import time
from collections import OrderedDict
from contextlib import ExitStack
from dataclasses import dataclass, replace
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
from .model.summary import LoadReport
from .observations.cache import FrameCache
from .observations.features import FeatureSet
from .observations.table import FrameObservation, Observations
from .plan.types import Plan

if TYPE_CHECKING:
    from distributed import Client

CONNECT_TIMEOUT_S = 5.0
#: the event topic on which :func:`prepare_model` reports ``(task key, share done)``
PROGRESS_TOPIC = "sightplan-progress"
PROGRESS_EVERY_S = 0.5
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
    """A client for ``cluster``: ``local:N`` starts a LocalCluster of N worker processes; both are closed with
    ``stack``, which may be closed from another thread than this one."""
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
        lc = LocalCluster(n_workers=n, threads_per_worker=1, processes=True, dashboard_address=None)
        stack.callback(lc.close)
        client = Client(lc)
        stack.callback(client.close)  # not the client's `with`, whose exit must run in the thread that entered it
        return client
    try:
        client = Client(cluster, timeout=CONNECT_TIMEOUT_S)
    except (OSError, TimeoutError, ValueError) as exc:
        raise SightplanError(f"cannot reach the dask scheduler at {cluster} within {CONNECT_TIMEOUT_S:g} s "
                             f"({type(exc).__name__}: {exc})") from None
    stack.callback(client.close)
    return client


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
    progress: called with (frames done, frames) after the cache is read and as batches complete; what it raises
    cancels the batches not yet done on the cluster and ends the evaluation.
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
            try:
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
            except BaseException:  # a failed batch, or a progress callback that stops the run: the rest is dropped
                client.cancel(futures)
                raise
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


@dataclass(frozen=True)
class PreparedModel:
    """What the preparation of a model file found: its counts, load report and whether it is georeferenced (the
    scene itself stays in the cache)."""

    elements: int
    targets: int
    triangles: int
    report: LoadReport
    georeferenced: bool

    @classmethod
    def of(cls, scene: Scene, report: LoadReport) -> PreparedModel:
        from .geo import Georeference

        try:
            geo = Georeference.from_scene_metadata(scene.metadata) is not None
        except SightplanError:
            geo = False
        return cls(int(scene.n_elements), int(scene.targets.sum()), int(len(scene.faces)), report, geo)


class PreparationCancelled(SightplanError):
    """Raised on a worker when the task preparing a model was cancelled."""


def _task_progress():
    """A progress callback for the dask task running this (None outside one): it sends ``(key, share)`` on
    :data:`PROGRESS_TOPIC` at most every :data:`PROGRESS_EVERY_S`, and raises :class:`PreparationCancelled` once the
    task is cancelled."""
    try:
        from distributed import get_worker

        worker = get_worker()
        key = worker.get_current_task()
    except (ImportError, ValueError, AttributeError):
        return None
    last = [0.0]

    def report(share: float) -> None:
        ts = worker.state.tasks.get(key)
        if ts is None or ts.state in ("cancelled", "released", "forgotten"):
            raise PreparationCancelled("cancelled")
        now = time.monotonic()
        if now - last[0] >= PROGRESS_EVERY_S:
            last[0] = now
            worker.log_event(PROGRESS_TOPIC, (key, float(share)))

    return report


def prepare_model(path: str | Path, cache_dir: str | Path) -> PreparedModel:
    """Load (tessellate) the model file at ``path`` into the scene cache ``cache_dir``; made to run on a dask worker,
    where it reports its progress (:data:`PROGRESS_TOPIC`) and stops at its next step when cancelled. The paths are
    the server's: the worker must see its data folder at the same path."""
    from .model.formats import IFC_EXTENSIONS
    from .model.load import load_model

    path = Path(path)
    if not path.is_file():
        raise SightplanError(f"the dask worker on {socket.gethostname()} does not see the server's data folder "
                             f"{path.parent.parent}: mount it at the same path on every worker")
    progress = _task_progress() if path.suffix.lower() in IFC_EXTENSIONS else None
    scene, report = load_model(path, cache=True, cache_dir=cache_dir,
                               **({"progress": progress} if progress is not None else {}))
    return PreparedModel.of(scene, report)
