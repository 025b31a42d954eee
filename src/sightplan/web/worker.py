"""The background worker: model loads and evaluations run on worker threads inside the server process, never in a
request. Progress goes to the database as it happens, so a page reload (or a new client) sees it. With a dask
cluster (:mod:`.cluster`), evaluations and optimisations cast their frames on its workers and model preparations run
there as tasks, while the job threads here write the progress and stop them when the job is cancelled.

The threads are daemon threads: when the server stops, a job that does not reach its next progress step within
the shutdown's grace period is marked failed and does not keep the process alive."""

from __future__ import annotations

import json
import logging
import queue
import threading
import time
from collections.abc import Callable, Iterator
from contextlib import contextmanager
from dataclasses import replace
from typing import TYPE_CHECKING

from sqlalchemy import select

from ..errors import SightplanError
from .db import Database
from .models import Evaluation, Job, Model, Plan, PlanVersion, Reality, Schedule, utcnow
from .scenes import evaluation_scene
from .services import (
    AS_FLOWN_KEY,
    FLIGHT_KEY,
    ROBUSTNESS_KEY,
    add_plan_version,
    evaluation_settings,
    flight_settings,
    ground_stations,
    load_scene,
    report_summary,
    save_element_dates,
)
from .storage import Storage

if TYPE_CHECKING:
    from .cluster import ServerCluster

log = logging.getLogger("sightplan.web")

#: where each stage of :func:`~sightplan.optimize.optimize` starts on its job's bar (0 to 1), in the order they run
OPTIMIZE_STAGES = {"casting candidates": 0.0, "casting aimed views": 0.6, "selecting": 0.8, "routing": 0.9}


def staged_progress(report: Callable[[float], None], stages: dict[str, float]) -> Callable[[str, int, int], None]:
    """A ``progress(stage, i, n)`` callback reporting to ``report`` the fraction done: ``i`` of ``n`` of the way from
    the stage's start to the next stage's (or 1)."""

    def progress(stage: str, i: int, n: int) -> None:
        start = stages.get(stage, 0.0)
        end = min([v for v in stages.values() if v > start], default=1.0)
        report(start + (end - start) * i / max(n, 1))

    return progress
INTERRUPTED = "interrupted: the server stopped before this job finished; start it again"
CANCELLED = "cancelled"


class JobStopped(SightplanError):
    """Raised inside a job's progress callback when the job is cancelled or the server stops."""
PROGRESS_INTERVAL_S = 0.2


def failure_message(exc: BaseException) -> str:
    if isinstance(exc, SightplanError):
        return str(exc)
    return f"internal error: {type(exc).__name__}: {exc}"


def recover_interrupted(db: Database) -> int:
    """Jobs a previous server process left queued or running can never finish: mark them failed, with their model
    or evaluation. Finished results are untouched. Returns how many."""
    with db.session() as s:
        jobs = s.scalars(select(Job).where(Job.status.in_(("queued", "running")))).all()
        for job in jobs:
            job.status, job.error, job.finished_at = "failed", INTERRUPTED, utcnow()
            if job.model_id is not None:
                model = s.get(Model, job.model_id)
                if model is not None and model.status in ("queued", "loading"):
                    model.status, model.error = "failed", INTERRUPTED
            if job.schedule_id is not None:
                schedule = s.get(Schedule, job.schedule_id)
                if schedule is not None and schedule.status in ("queued", "linking"):
                    schedule.status, schedule.error = "failed", INTERRUPTED
            if job.reality_id is not None:
                reality = s.get(Reality, job.reality_id)
                if reality is not None and reality.status in ("queued", "preparing"):
                    reality.status, reality.error = "failed", INTERRUPTED
            if job.evaluation_id is not None:
                ev = s.get(Evaluation, job.evaluation_id)
                if ev is not None and ev.status in ("queued", "running"):
                    ev.status, ev.error, ev.finished_at = "failed", INTERRUPTED, utcnow()
        return len(jobs)


SHUTDOWN_GRACE_S = 3.0  # how long a stopping server waits for its running jobs to reach a progress step
CLUSTER_BATCH_FRAMES = 16  # frames per task on a cluster: a cancelled job stops after its workers' current batches
CLUSTER_POLL_S = 0.2  # how often a job waiting on a cluster task checks for its cancellation


@contextmanager
def cluster_errors() -> Iterator[None]:
    """A task the cluster dropped or whose workers died, as one line on the job."""
    from concurrent.futures import CancelledError

    try:
        yield
    except CancelledError:
        raise SightplanError("the dask cluster dropped the job's tasks (its scheduler or workers went away)") from None
    except Exception as exc:
        if type(exc).__name__ == "KilledWorker":
            raise SightplanError(f"the dask workers running the job died: {exc}") from None
        raise


class Worker:
    """Runs jobs by id on ``workers`` daemon threads; with a ``cluster``, their casting and model preparation run on
    its workers."""

    def __init__(self, db: Database, storage: Storage, workers: int, cluster: ServerCluster | None = None) -> None:
        self.db = db
        self.storage = storage
        self.cluster = cluster
        self._queue: queue.SimpleQueue[int | None] = queue.SimpleQueue()
        self._stopping = threading.Event()
        self._cancelled: set[int] = set()
        self._running: set[int] = set()
        self._lock = threading.Lock()
        self._threads = [threading.Thread(target=self._serve, name=f"sightplan-job-{k + 1}", daemon=True)
                         for k in range(max(1, workers))]
        for thread in self._threads:
            thread.start()

    def _serve(self) -> None:
        while (job_id := self._queue.get()) is not None:
            if self._stopping.is_set():
                continue  # queued jobs never start once the server stops (the next start fails them)
            self._run(job_id)

    def cancel(self, job_id: int) -> None:
        """Stop a running job at its next progress step; a queued one never starts (the caller marks it failed)."""
        with self._lock:
            self._cancelled.add(job_id)

    def fail_if_queued(self, job_id: int, message: str) -> None:
        """Mark a job that has not started failed (with its model, schedule or evaluation, as a failure inside it
        would); a job that started meanwhile is left to stop at its next step. The check and the change are one
        step under the worker's lock, which the start of a job takes too."""
        with self._lock:
            with self.db.session() as s:
                job = s.get(Job, job_id)
                if job is None or job.status != "queued":
                    return
            self._fail(job_id, message)

    def _check(self, job_id: int) -> None:
        if self._stopping.is_set():
            raise JobStopped(INTERRUPTED)
        if job_id in self._cancelled:
            raise JobStopped(CANCELLED)

    def submit(self, job_id: int) -> None:
        self._queue.put(job_id)

    def run(self, job_id: int) -> None:
        """Run a queued job in the calling thread (failures are recorded on the job, as on the pool)."""
        self._run(job_id)

    def shutdown(self, grace_s: float = SHUTDOWN_GRACE_S) -> None:
        """Stop: queued jobs never start, running ones stop at their next progress step and are failed as
        interrupted. A job still running after ``grace_s`` seconds (inside one long step) is marked failed now; its
        daemon thread does not hold the process. Queued jobs stay queued, and the next start fails them."""
        self._stopping.set()
        for _ in self._threads:
            self._queue.put(None)
        deadline = time.monotonic() + max(0.0, grace_s)
        for thread in self._threads:
            thread.join(max(0.0, deadline - time.monotonic()))
        with self._lock:
            stuck = sorted(self._running)
        for job_id in stuck:
            log.warning("job %s did not stop within %.0f s of the shutdown: marked failed", job_id, grace_s)
            self._fail(job_id, INTERRUPTED)

    # ------------------------------------------------------------------ running
    def _progress(self, job_id: int, total: float, evaluation_id: int | None = None) -> Callable[[float], None]:
        """A callback writing ``done`` of ``total`` to the job (and evaluation) at most every 0.2 s, and at the end."""
        last = [0.0]

        def update(done: float) -> None:
            self._check(job_id)
            now = time.monotonic()
            if done < total and now - last[0] < PROGRESS_INTERVAL_S:
                return
            last[0] = now
            with self.db.session() as s:
                job = s.get(Job, job_id)
                if job is not None:
                    job.progress_done, job.progress_total = float(done), float(total)
                if evaluation_id is not None:
                    ev = s.get(Evaluation, evaluation_id)
                    if ev is not None:
                        ev.progress_done, ev.progress_total = int(done), int(total)

        return update

    def _run(self, job_id: int) -> None:
        with self._lock, self.db.session() as s:  # the lock: a cancel is either before the start or after it
            job = s.get(Job, job_id)
            if job is None or job.status != "queued":
                self._cancelled.discard(job_id)
                return
            job.status, job.started_at = "running", utcnow()
            kind = job.kind
            self._running.add(job_id)
        try:
            self._check(job_id)
            if kind == "load_model":
                self._load_model(job_id)
            elif kind == "link_schedule":
                self._link_schedule(job_id)
            elif kind == "prep_reality":
                self._prepare_reality(job_id)
            elif kind == "optimize":
                self._optimize(job_id)
            else:
                self._evaluate(job_id)
        except Exception as exc:  # every failure is recorded on the job; a bug is logged with its traceback too
            if not isinstance(exc, SightplanError):
                log.exception("job %s failed", job_id)
            self._fail(job_id, failure_message(exc))
            return
        finally:
            with self._lock:
                self._cancelled.discard(job_id)
                self._running.discard(job_id)
        with self.db.session() as s:
            job = s.get(Job, job_id)
            if job is not None and job.status == "running":  # not failed meanwhile by a shutdown
                job.status, job.finished_at, job.message = "done", utcnow(), job.message or "done"

    def _fail(self, job_id: int, message: str) -> None:
        with self.db.session() as s:
            job = s.get(Job, job_id)
            if job is None or job.status == "failed":
                return
            job.status, job.error, job.finished_at = "failed", message, utcnow()
            if job.model_id is not None and job.kind == "load_model":
                model = s.get(Model, job.model_id)
                if model is not None:
                    path = self.storage.model_path(model.stored_name)
                    message = message.replace(str(path), model.original_name).replace(model.stored_name,
                                                                                      model.original_name)
                    job.error = message
                    model.status, model.error = "failed", message
                    self.storage.remove(path)
            if job.schedule_id is not None:
                schedule = s.get(Schedule, job.schedule_id)
                if schedule is not None:
                    if schedule.stored_name:
                        message = message.replace(str(self.storage.schedule_path(schedule.stored_name)),
                                                  schedule.original_name).replace(schedule.stored_name,
                                                                                  schedule.original_name)
                    model = s.get(Model, schedule.model_id)
                    if model is not None:  # "<stored>.ifc has no work schedule" names the model as uploaded
                        message = message.replace(str(self.storage.model_path(model.stored_name)),
                                                  model.original_name).replace(model.stored_name, model.original_name)
                    job.error = message
                    schedule.status, schedule.error = "failed", message
            if job.reality_id is not None:
                reality = s.get(Reality, job.reality_id)
                if reality is not None:
                    message = message.replace(str(self.storage.reality_path(reality.stored_name)),
                                              reality.original_name).replace(reality.stored_name, reality.original_name)
                    job.error = message
                    reality.status, reality.error = "failed", message
                    self.storage.remove(self.storage.reality_path(reality.view_name),
                                        self.storage.reality_path(reality.view_name + ".glb"))
            if job.evaluation_id is not None:
                ev = s.get(Evaluation, job.evaluation_id)
                if ev is not None:
                    ev.status, ev.error, ev.finished_at = "failed", message, utcnow()
                    self.storage.remove(self.storage.evaluation_dir(ev.result_dir))

    def _load_model(self, job_id: int) -> None:
        with self.db.session() as s:
            job = s.get(Job, job_id)
            assert job is not None and job.model_id is not None
            model = s.get(Model, job.model_id)
            assert model is not None
            model.status = "loading"
            job.message = f"tessellating {model.original_name}" + (" on the dask cluster" if self.cluster else "")
            job.progress_total = 1.0
            stored = model.stored_name
            model_id = model.id
        from ..distributed import PreparedModel, prepare_model

        progress = self._progress(job_id, 1.0)
        if self.cluster is None:
            facts = PreparedModel.of(*load_scene(self.storage, stored, progress=progress))
        else:  # tessellated on a worker into the data folder's cache, which the next load here reads
            future = self.cluster.client.submit(prepare_model, str(self.storage.model_path(stored)),
                                                str(self.storage.scene_cache), key=f"prepare_model-{Storage.new_name()}",
                                                pure=False)
            facts = self._wait(job_id, future, progress)
        with self.db.session() as s:
            model = s.get(Model, model_id)
            job = s.get(Job, job_id)
            if model is None or job is None:
                return
            model.status = "ready"
            model.elements, model.targets = facts.elements, facts.targets
            model.triangles, model.skipped = facts.triangles, len(facts.report.skipped)
            model.load_report = report_summary(facts.report)
            model.georeferenced = facts.georeferenced
            job.progress_done = job.progress_total = 1.0
            job.message = f"{model.elements} elements, {model.triangles:,} triangles"

    def _wait(self, job_id: int, future, progress: Callable[[float], None] | None = None):
        """The result of a cluster task, waited for in steps that check the job's cancellation and the server's stop
        (either cancels the task) and report the progress the task sends."""
        from distributed import wait

        assert self.cluster is not None
        try:
            with cluster_errors():
                while not future.done():
                    share = self.cluster.progress_of(future.key)
                    if progress is not None and share is not None:
                        progress(share)
                    self._check(job_id)
                    try:
                        wait(future, timeout=CLUSTER_POLL_S)
                    except TimeoutError:
                        pass
                return future.result()
        except BaseException:
            future.cancel()
            raise
        finally:
            self.cluster.forget(future.key)

    def _evaluate(self, job_id: int) -> None:
        from ..evaluate import evaluate
        from ..plan.format import read_plan
        from ..report.tables import element_rows, frame_rows, report_dict

        with self.db.session() as s:
            job = s.get(Job, job_id)
            assert job is not None and job.evaluation_id is not None
            ev_row = s.get(Evaluation, job.evaluation_id)
            assert ev_row is not None
            model = s.get(Model, ev_row.model_id)
            version = s.get(PlanVersion, ev_row.plan_version_id)
            if model is None or version is None:
                raise SightplanError("the model or the plan version was deleted")
            if model.status != "ready":
                raise SightplanError(f"model {model.id} is not ready ({model.status})")
            ev_row.status, ev_row.started_at = "running", utcnow()
            job.message = f"evaluating plan version {version.number} against {model.original_name}"
            evaluation_id, stored_model, stored_plan = ev_row.id, model.stored_name, version.stored_name
            project_id = ev_row.project_id
            settings_json, result_name = dict(ev_row.settings), ev_row.result_dir
            model_label, plan_label = model.original_name, f"{version.plan.name} v{version.number}"
        settings = evaluation_settings(settings_json)
        with self.db.session() as s:
            scene = evaluation_scene(self.storage, s, stored_model, settings_json, project_id)
        plan = read_plan(self.storage.plan_path(stored_plan))
        if settings_json.get(AS_FLOWN_KEY):
            plan = self._as_flown(job_id, plan, scene, settings_json[AS_FLOWN_KEY])
        progress = self._progress(job_id, len(plan), evaluation_id)
        if self.cluster is None:
            result = evaluate(scene, plan, settings, cache_dir=self.storage.frame_cache,
                              progress=lambda i, n: progress(i))
        else:
            from ..distributed import evaluate_distributed

            with cluster_errors():
                result = evaluate_distributed(scene, plan, settings, cluster=self.cluster.client,
                                              batch_frames=CLUSTER_BATCH_FRAMES, cache_dir=self.storage.frame_cache,
                                              progress=lambda i, n: progress(i))
        out = self.storage.evaluation_dir(result_name)
        out.mkdir(parents=True, exist_ok=True)
        report = report_dict(result, scene, plan, model_path=model_label, plan_path=plan_label)
        if settings_json.get(ROBUSTNESS_KEY):
            report["metrics"]["robustness"] = self._robustness(job_id, scene, plan, result,
                                                               settings_json[ROBUSTNESS_KEY])
        (out / "report.json").write_text(json.dumps(report, indent=1, allow_nan=False), encoding="utf-8")
        (out / "elements.json").write_text(json.dumps(_jsonable(element_rows(result, scene))), encoding="utf-8")
        (out / "frames.json").write_text(json.dumps(_jsonable(frame_rows(result, plan))), encoding="utf-8")
        result.observations.save(out / "observations.npz")
        with self.db.session() as s:
            ev_row = s.get(Evaluation, evaluation_id)
            job = s.get(Job, job_id)
            if ev_row is None or job is None:
                return
            ev_row.status, ev_row.finished_at, ev_row.metrics = "done", utcnow(), report["metrics"]
            ev_row.progress_done = ev_row.progress_total = len(plan)
            vc = report["metrics"]["VC_pct"]
            job.message = (f"VC {vc:.1f} %" if vc is not None else "done") + \
                (f"; {result.cache_hits} of {len(plan)} frames unchanged, taken from the cache" if result.cache_hits else "")

    def _as_flown(self, job_id: int, plan, scene, autopilot: str):
        """The version as ``autopilot`` flies its export (:func:`~sightplan.flight.asflown.as_flown_of_plan`)."""
        from ..export.files import takeoff_point
        from ..flight.asflown import as_flown_of_plan, deviations
        from ..geo import Georeference, resolve_georeference

        self._message(job_id, f"replaying the mission as {autopilot} flies it")
        geo = resolve_georeference(plan.parameters.get("georeference"),
                                   Georeference.from_scene_metadata(scene.metadata), what="an as-flown evaluation")
        flown, replays = as_flown_of_plan(plan, geo, takeoff_point(plan, scene, hint="give the plan a model"),
                                          autopilot)
        d, a = deviations(plan, flown)
        flown.parameters["as_flown"] |= {"largest_deviation_m": round(float(d.max()), 3),
                                         "largest_deviation_deg": round(float(a.max()), 2)}
        return flown

    def _robustness(self, job_id: int, scene, plan, nominal, spec: dict) -> dict:
        """The plan metrics' spread under the position error of ``spec`` (:func:`~sightplan.robustness.
        evaluate_under_error`), as robustness.json holds it, less the timings."""
        from ..robustness import evaluate_under_error, robustness_dict

        total = spec["pool"] * len(plan)
        self._message(job_id, f"{spec['draws']} draws under {spec['label']}: casting {total} perturbed frames")
        progress = self._progress(job_id, total)  # the job's bar runs again, over the draws' frames
        result = evaluate_under_error(scene, plan, nominal.settings, tuple(spec["error"]), spec["draws"], 0,
                                      pool=spec["pool"], nominal=nominal, progress=lambda i, n: progress(i))
        doc = robustness_dict(result)
        doc.pop("timings", None)
        return doc | {"label": spec["label"]}

    def _message(self, job_id: int, text: str) -> None:
        with self.db.session() as s:
            job = s.get(Job, job_id)
            if job is not None:
                job.message = text

    def _optimize(self, job_id: int) -> None:
        """An optimised plan (``sightplan optimize``) around the job's model, saved as a new plan of one version."""
        from ..camera.catalogue import get_camera
        from ..camera.models import PinholeCamera
        from ..optimize import Budget, OptimizeSettings, Targets, optimize

        with self.db.session() as s:
            job = s.get(Job, job_id)
            assert job is not None and job.model_id is not None and job.params is not None
            model = s.get(Model, job.model_id)
            if model is None or model.status != "ready":
                raise SightplanError("the model was deleted or is not ready")
            p, stored, project_id, model_id = dict(job.params), model.stored_name, job.project_id, model.id
            job.message = f"optimising a plan around {model.original_name}"
        scene = load_scene(self.storage, stored)[0]
        flight = flight_settings(p["flight"], ground_stations(scene, p.get("ground_station"), p.get("ground_station_geo")))
        targets = Targets(k=p["k"], max_ssd_m_px=p.get("max_ssd_m_px"), max_angle_deg=p["max_angle_deg"])
        budget = Budget(frames=p.get("budget_frames"), minutes=p.get("budget_minutes"), batteries=p.get("batteries"))
        progress = staged_progress(self._progress(job_id, 1.0), OPTIMIZE_STAGES)
        camera = get_camera(p["camera"])
        # a 360° camera's indoor plan is cast here (the indoor optimiser refuses a cluster)
        cluster = self.cluster.client if self.cluster is not None and isinstance(camera, PinholeCamera) else None
        with cluster_errors():
            result = optimize(scene, camera, targets, budget, flight=flight,
                              settings=OptimizeSettings(scale=p["scale"], cache_dir=self.storage.frame_cache,
                                                        cluster=cluster, batch_frames=CLUSTER_BATCH_FRAMES),
                              progress=progress)
        summary = result.summary()
        made = replace(result.plan, parameters={**result.plan.parameters, FLIGHT_KEY: p["flight"]})  # as a template's
        path = None
        try:
            with self.db.session() as s:
                job = s.get(Job, job_id)
                if job is None:
                    return
                row = Plan(project_id=project_id, model_id=model_id,
                           name=p.get("name") or f"optimised (k = {p['k']})", source=f"optimize ({p['camera']})")
                path = add_plan_version(self.storage, s, row, made,
                                        f"optimised: {summary['met']} of {summary['targets']} targets met")
                job.plan_id = row.id
                job.progress_done = job.progress_total = 1.0
                job.message = (f"{summary['met']} of {summary['targets']} targets met with {summary['frames']} "
                               f"frames, {summary['minutes']} min")
        except BaseException:
            if path is not None:
                path.unlink(missing_ok=True)
            raise

    def _prepare_reality(self, job_id: int) -> None:
        """A point cloud → a 3D Tiles octree for the viewer; a mesh → one GLB (glTF's Y up)."""
        with self.db.session() as s:
            job = s.get(Job, job_id)
            assert job is not None and job.reality_id is not None
            row = s.get(Reality, job.reality_id)
            if row is None:
                raise SightplanError("the reality capture was deleted")
            row.status = "preparing"
            job.message, job.progress_total = f"preparing {row.original_name} for the viewer", 1.0
            source, view, kind, reality_id = (self.storage.reality_path(row.stored_name), row.view_name, row.kind,
                                              row.id)
        self._check(job_id)
        points = triangles = None
        if kind == "points":
            from ..report.pointtiles import write_point_tiles

            summary = write_point_tiles(source, self.storage.reality_path(view))
            points, (lo, hi) = summary.n_points, summary.bounds
            message = f"{points:,} points in {summary.n_tiles} tiles, {summary.depth + 1} levels"
        else:
            from ..model.load import load_model

            scene, _ = load_model(source, cache=False)
            lo, hi = (b.tolist() for b in scene.bounds())
            triangles = int(len(scene.faces))
            write_mesh_glb(scene.vertices, scene.faces, self.storage.reality_path(view + ".glb"))
            message = f"{triangles:,} triangles"
        with self.db.session() as s:
            row, job = s.get(Reality, reality_id), s.get(Job, job_id)
            if row is None or job is None:
                return
            row.status, row.points, row.triangles = "ready", points, triangles
            row.bounds = {"lo": [float(v) for v in lo], "hi": [float(v) for v in hi]}
            job.progress_done, job.message = 1.0, message

    def _link_schedule(self, job_id: int) -> None:
        from ..schedule import link_schedule, read_schedule

        with self.db.session() as s:
            job = s.get(Job, job_id)
            assert job is not None and job.schedule_id is not None
            schedule = s.get(Schedule, job.schedule_id)
            model = s.get(Model, schedule.model_id) if schedule is not None else None
            if schedule is None or model is None:
                raise SightplanError("the schedule or its model was deleted")
            if model.status != "ready":
                raise SightplanError(f"model {model.id} is not ready ({model.status})")
            schedule.status = "linking"
            job.message, job.progress_total = f"linking {schedule.original_name} to {model.original_name}", 1.0
            model_path = self.storage.model_path(model.stored_name)
            source = self.storage.schedule_path(schedule.stored_name) if schedule.stored_name else "model"
            rules = self.storage.schedule_path(schedule.rules_name) if schedule.rules_name else None
            prefer_actual, dates_name, schedule_id = schedule.prefer_actual, schedule.dates_name, schedule.id
        scene, _ = load_scene(self.storage, model.stored_name)
        ifc = model_path if model_path.suffix.lower() in (".ifc", ".ifczip") else None
        tasks = read_schedule(source, model_path=ifc)
        dated, report = link_schedule(scene, tasks, rules, model_path=ifc, prefer_actual=prefer_actual)
        save_element_dates(self.storage.schedule_path(dates_name), dated.elements.start, dated.elements.finish)
        with self.db.session() as s:
            schedule, job = s.get(Schedule, schedule_id), s.get(Job, job_id)
            if schedule is None or job is None:
                return
            schedule.status = "ready"
            schedule.first_date = str(report.first_date)[:10] if report.first_date is not None else None
            schedule.last_date = str(report.last_date)[:10] if report.last_date is not None else None
            # the lines name the files as the user knows them, not by the names the server stored them under
            names = [(str(model_path), model.original_name)]
            if schedule.stored_name:
                names += [(str(self.storage.schedule_path(schedule.stored_name)), schedule.original_name),
                          (schedule.stored_name, schedule.original_name)]
            lines, warnings = report.describe(), list(report.warnings)
            for stored, shown in names:
                lines = [line.replace(stored, shown) for line in lines]
                warnings = [w.replace(stored, shown) for w in warnings]
            schedule.report = {"lines": lines,
                               "tasks": report.n_tasks, "linked": report.linked, "unlinked": report.unlinked,
                               "targets": report.n_targets, "dated": report.dated, "warnings": warnings}
            job.progress_done = 1.0
            job.message = f"linked {report.linked} of {report.n_targets} elements to {report.n_tasks} tasks"


def write_mesh_glb(vertices, faces, path) -> None:
    """A triangle mesh as a binary glTF, Y up and centred on its box as the point tiles are, so the viewer turns
    both the same way."""
    import numpy as np

    from ..geometry.glb import primitive_glb

    v = np.asarray(vertices, float)
    centre = (v.min(axis=0) + v.max(axis=0)) / 2 if len(v) else np.zeros(3)
    tmp = path.with_suffix(".glb.part")
    tmp.write_bytes(primitive_glb(v, centre, triangles=faces))
    tmp.replace(path)


def _jsonable(rows: list[dict]) -> list[dict]:
    """Rows with NaN and inf as null and numpy numbers as Python ones."""
    import math

    import numpy as np

    def cell(v):
        if isinstance(v, np.generic):
            v = v.item()
        if isinstance(v, float) and not math.isfinite(v):
            return None
        return v

    return [{k: cell(v) for k, v in row.items()} for row in rows]
