"""``optimize``: the plan with the fewest views, minutes and batteries that meets the user's targets.

1. Candidates (:mod:`.candidates`) are cast once, through the per-frame cache, at ``scale``: a second run with other
   targets or budgets casts nothing.
2. The lazy-greedy selection (:mod:`.select`) chooses views under the frame budget, then drops redundant ones.
3. Each chosen view is grown into a run of Y views sharing ≥ Λ features (:func:`~.select.stable_runs`: chosen views
   first, then candidates), so that flown in one stretch every frame registers (ν_f ≥ Λ). A chosen view no run can
   be formed around is set aside and the selection made again, as long as that meets as much.
4. The views are ordered (:mod:`.route`, each run in one stretch), split into missions and checked by the flight
   checks.
5. Under a budget of frames, minutes or batteries, the longest prefix of the greedy order whose grown, flown plan fits
   is kept (bisection with one-run tours: the plan grows with the prefix), then routed again in earnest.
6. Frames that would still not register (ν_f < Λ along the flown order) are reported.
"""

from __future__ import annotations

import time
from collections.abc import Callable
from contextlib import ExitStack
from dataclasses import dataclass, replace
from typing import TYPE_CHECKING

import numpy as np
from numpy.typing import NDArray

from ..camera.models import Camera, PinholeCamera
from ..distributed import connect, evaluate_distributed
from ..errors import PlanError
from ..evaluate import EvaluationSettings, evaluate
from ..metrics import MetricParams, frame_metrics
from ..model.scene import Scene
from ..observations.table import Observations
from ..plan.checks.battery import Aircraft
from ..plan.checks.feasibility import FeasibilityReport, FlightSettings, corner_stations, plan_flights
from ..plan.checks.gate import record_checks
from ..plan.checks.safety import CHECK_TOLERANCE_M, placement
from ..plan.site import with_site
from ..plan.types import Mission, Plan
from .budget import Budget, longest_prefix
from .candidates import CandidateSet, aimed_views, candidate_views
from .result import OptimizeResult
from .route import LegMemo, order_views, ordered_plan
from .select import CoverageTable, FeatureIndex, refine, stable_runs, stable_selection
from .targets import SSD_SLACK, ElementTargets, Targets

if TYPE_CHECKING:
    from distributed import Client

Progress = Callable[[str, int, int], None]
#: the stages ``optimize`` reports to its ``progress(stage, i, n)``, in order
STAGES = (CASTING, CASTING_AIMED, SELECTING, ROUTING) = ("casting candidates", "casting aimed views", "selecting",
                                                         "routing")
AIM_FROM = 6  # views aimed at a target that is seen but not met: from near this many of those that see it
REFINE_FACTOR = 4  # under a budget of minutes or batteries, up to this many times the views the targets need


@dataclass(frozen=True)
class OptimizeSettings:
    """How candidates are made and cast: ``scale`` of the cast (default 0.25), ``engine``, candidate ``spacing_m``
    and ``distances_m`` (defaults in :mod:`.candidates`), ``oblique_deg``, ``cache_dir`` of the per-frame cache
    (None: the default one, False: none), LKH ``runs``; ``template_views``: the facade, orbit and lawn-mower views
    (70 % overlap) are candidates too; ``aimed_views``: targets some candidate sees but none meets get views aimed at
    them (:func:`~.candidates.aimed_views`), cast in a second round; ``cluster``: cast on a dask cluster instead (a
    scheduler address ``tcp://host:8786``, ``local:N`` for N local worker processes, or a ``distributed.Client``),
    ``batch_frames`` frames per task, connected once for both rounds; the frames in the per-frame cache are read
    here, only the others go to the cluster, and what it casts is stored in the cache."""

    scale: float = 0.25
    engine: str = "auto"
    spacing_m: float | None = None
    distances_m: tuple[float, ...] | None = None
    oblique_deg: float = 30.0
    threads: int | None = None
    cache_dir: object = None
    runs: int = 4
    template_views: bool = True
    aimed_views: bool = True
    cluster: str | Client | None = None
    batch_frames: int = 64


def default_ssd(camera: Camera, safety_distance_m: float) -> float:
    """The default SSD bound: the camera's head-on SSD at the safety distance × 1.5 (m/px)."""
    return safety_distance_m / camera.sampling_focal_px * SSD_SLACK


@dataclass(frozen=True)
class Flown:
    """A routing of ``given`` views: its flight ``report``, the ``views`` in flown order (with those ``added`` for
    stability, when ``grown``), and the legs forbidden for passing too near the model."""

    report: FeasibilityReport
    views: NDArray[np.int64]
    forbidden: int
    added: int
    given: NDArray[np.int64]
    grown: bool = True


def optimize(scene: Scene, camera: Camera, targets: Targets | None = None, budget: Budget | None = None, *,
             flight: FlightSettings | None = None, settings: OptimizeSettings | None = None,
             start: Plan | None = None, progress: Progress | None = None) -> OptimizeResult:
    """The plan that meets the most ``targets`` (weighted) within ``budget`` with the fewest views (see the module
    docstring). ``flight``: the safety distance, line of sight, aircraft, limits the plan must keep (default: a
    drone's, 10 m from the model). ``start``: a plan to improve — its frames are candidates chosen first, and any
    that prove redundant are removed."""
    if not isinstance(camera, PinholeCamera):  # a 360° camera: a walked indoor plan (.indoor refuses any other)
        from .indoor import optimize_indoor

        return optimize_indoor(scene, camera, targets, budget, flight=flight, settings=settings, start=start,
                               progress=progress)
    targets = targets or Targets()
    budget = budget or Budget()
    flight = flight or FlightSettings(safety_distance_m=10.0)
    settings = settings or OptimizeSettings()
    timings: dict[str, float] = {}
    g = flight.safety_distance_m
    et = targets.resolve(scene, default_ssd(camera, g))
    if et.n_active == 0:
        raise PlanError("no element is a target of the optimisation: check the targets' rules")

    t0 = time.perf_counter()
    g_place, low = _placement(flight)
    cands = candidate_views(scene, camera, g_place, distances_m=list(settings.distances_m) if settings.distances_m else None,
                            max_ssd_m_px=float(np.median(et.max_ssd_m_px[et.active])), spacing_m=settings.spacing_m,
                            oblique_deg=settings.oblique_deg, min_height_m=low,
                            altitude_limit_m=flight.altitude_limit_m)
    pool, n_start = _with_start(cands, start)
    if settings.template_views:
        pool = _with_template_views(pool, scene, camera, flight)
    timings["candidates_s"] = time.perf_counter() - t0

    t0 = time.perf_counter()
    metric = targets.metric()
    cast_settings = EvaluationSettings(engine=settings.engine, scale=settings.scale,  # type: ignore[arg-type]
                                       threads=settings.threads, metric=metric)

    def cast(views: Plan, what: str) -> Observations:
        report = None if progress is None else (lambda i, n: progress(what, i, n))
        if client is None:
            return evaluate(scene, views, cast_settings, cache_dir=settings.cache_dir, progress=report).observations
        return evaluate_distributed(scene, views, cast_settings, cluster=client, batch_frames=settings.batch_frames,
                                    cache_dir=settings.cache_dir, progress=report).observations

    with ExitStack() as stack:  # a cluster named by its address or local:N: connected once, closed after the casts
        client = connect(settings.cluster, stack) if isinstance(settings.cluster, str) else settings.cluster
        obs = cast(pool, CASTING)
        table = CoverageTable.build(obs, et)
        if settings.aimed_views:  # targets seen but not met: views aimed at them from near those that see them
            aimed = _aimed(scene, camera, pool, obs, table, et, flight, cands.plan.parameters["spacing_m"])
            if aimed is not None:  # only the aimed views are cast: the pool's frames follow them unchanged
                pool = _concatenated([pool, aimed], pool.parameters)
                obs = Observations.concatenate([obs, cast(aimed, CASTING_AIMED)])
                table = CoverageTable.build(obs, et)
    timings["cast_s"] = time.perf_counter() - t0

    t0 = time.perf_counter()
    blind = int((np.diff(table.seen_ptr)[n_start:] == 0).sum())  # candidates that see no target
    start_views = np.arange(n_start) if n_start else None
    can_add = np.diff(table.seen_ptr) > 0  # views added for stability must see a target (no waste)
    features = FeatureIndex.build(obs)  # read by every growth of runs below
    sel = stable_selection(table, features, targets.min_track, targets.min_features, budget.frames, start=start_views,
                           allowed=can_add)
    timings["select_s"] = time.perf_counter() - t0
    if progress is not None:
        progress(SELECTING, 1, 1)

    t0 = time.perf_counter()
    takeoff = (flight.ground_stations[0] if flight.ground_stations is not None
               else corner_stations(scene, pool.subset(sel.views) if len(sel.views) else pool,
                                    safety_m=flight.safety_distance_m, error_m=flight.error)[0])

    memo = LegMemo()  # legs measured once for every routing below
    stability = {"s": 0.0}

    def flown(views: NDArray, runs: int, grow: bool = True) -> Flown:
        """``views`` grown into runs that register (:func:`~.select.stable_runs`; not when ``grow`` is False),
        ordered with each run flown in one stretch, split into missions and checked."""
        t = time.perf_counter()
        grown = stable_runs(features, views, targets.min_track, targets.min_features if grow else 0,
                            allowed=can_add, table=table)
        stability["s"] += time.perf_counter() - t
        order, cuts, forbidden = order_views(scene, pool.C_world[grown.views], takeoff, g_place, _aircraft(flight), runs,
                                             ids=grown.views, memo=memo, groups=grown.groups)
        report = plan_flights(scene, ordered_plan(pool, grown.views[order], cuts), flight)
        near = unsafe_legs(report, flight)
        if len(near):  # a leg the checks find too near at the worst of the position error: the aircraft lands there
            cuts = np.union1d(cuts, near + 1)
            report = plan_flights(scene, ordered_plan(pool, grown.views[order], cuts), flight)
        return Flown(report, grown.views[order], forbidden, grown.added, views, grow)

    views = sel.views
    if budget.limited:
        # a budget the targets did not use up buys finer views: added best first, the fitting prefix kept below
        cap = budget.frames if budget.frames is not None else REFINE_FACTOR * max(len(views), 1)
        views = np.concatenate([views, refine(table, views, cap)])
    if not len(views):
        raise PlanError("no candidate view serves any target: lower the targets or the safety distance")
    if not budget.limited:
        best = flown(views, settings.runs)
    else:  # the longest prefix of the greedy order that fits, found with one-run tours, then solved in earnest
        best = flown(views, 1)

        def fits(f: Flown) -> bool:
            return budget.admits(len(f.views), f.report)

        if not fits(best):
            found = longest_prefix(views, lambda v, grow: flown(v, 1, grow), fits)
            if found is None:
                raise PlanError("not even one view fits the budget of frames, minutes or batteries")
            best = found[1]
        if settings.runs > 1:
            again = flown(best.given, settings.runs, best.grown)
            best = again if fits(again) else best
    timings["route_s"] = time.perf_counter() - t0 - stability["s"]
    timings["stability_s"] = stability["s"]
    if progress is not None:
        progress(ROUTING, 1, 1)
    report, views, forbidden = best.report, best.views, best.forbidden
    frames = frame_metrics(obs.select_frames(views), metric)  # along the flown order
    unstable = int((~frames.stable).sum())
    blind_frames = int((frames.pixels_on_targets <= 0).sum())  # the waste: frames that see no target at all
    met = table.met(views)
    params = {"template": "optimised", "safety_distance_m": g, "targets": targets.record(et),
              "budget": budget.record(),
              "candidates": len(pool), "met": int(met.sum()), "scale": settings.scale}
    plan = record_checks(report.plan, report, flight)
    plan = with_site(replace(plan, parameters={**plan.parameters, **params}), scene, replace_takeoff=True)
    report = replace(report, plan=plan)
    return OptimizeResult(plan, report, et, met, len(cands.plan), cands.dropped, blind, len(sel.removed), forbidden,
                          unstable, blind_frames, stability_views=best.added, timings=timings)


def _aimed(scene: Scene, camera: Camera, pool: Plan, obs: Observations, table: CoverageTable, et: ElementTargets,
           flight: FlightSettings, spacing_m: float) -> Plan | None:
    """Views aimed at the targets that the pool sees (≥ Ω px) but cannot meet, from near ``AIM_FROM`` of the views
    that see each: half those that come nearest to serving it (the larger of SSD and angle, each over its bound,
    least), half spread over the rest."""
    q, s = table.counts(np.arange(table.n_views))
    short = (q < table.k) & (table.weight > 0) & (s > 0)
    if not short.any():
        return None
    e = obs.element.astype(np.int64)
    rows = np.flatnonzero(short[e] & et.sees(obs))
    e = e[rows]
    shortfall = np.maximum(obs.ssd[rows] / et.max_ssd_m_px[e], obs.angle_mean[rows] / et.max_angle_deg[e])
    order = np.lexsort((shortfall, e))  # per element, the nearest to serving first
    e, frame = e[order], obs.frame[rows][order].astype(np.int64)
    elements, first = np.unique(e, return_index=True)
    ends = np.append(first[1:], len(e))
    near = AIM_FROM // 2
    seen_from = []
    for a, b in zip(first, ends):
        rest = frame[a + near:b]
        spread = rest[np.unique(np.linspace(0, len(rest) - 1, min(AIM_FROM - near, len(rest))).round().astype(int))]
        seen_from.append(pool.C_world[np.concatenate([frame[a:min(b, a + near)], spread])])
    g_place, low = _placement(flight)
    return aimed_views(scene, camera, g_place, elements, seen_from, spacing_m,
                       min_height_m=low, altitude_limit_m=flight.altitude_limit_m)


def unsafe_legs(report: FeasibilityReport, flight: FlightSettings) -> NDArray[np.int64]:
    """The legs i→i+1 within a mission of ``report``'s plan that its safety check fails (nearer the model than the
    safety distance at the worst of the position error). The router keeps every leg it flies at the placement
    distance (nominal), so there are none unless a later split joined two views across a leg it had cut."""
    seg = report.safety.segment_worst_m
    if seg is None or not len(seg):
        return np.zeros(0, np.int64)
    with np.errstate(invalid="ignore"):  # NaN: between two missions, not flown
        return np.flatnonzero(seg < flight.safety_distance_m - CHECK_TOLERANCE_M).astype(np.int64)


def _placement(flight: FlightSettings) -> tuple[float, float | None]:
    """How far from the model, and how high above the ground at least, views are placed (and legs kept) so that
    they pass the flight checks at the position error in force, as the templates place their frames."""
    return placement(flight.safety_distance_m, flight.min_height_m, flight.error)


def _aircraft(flight: FlightSettings) -> Aircraft | None:
    return flight.aircraft if isinstance(flight.aircraft, Aircraft) else None


def _concatenated(plans: list[Plan], parameters: dict) -> Plan:
    """The frames of ``plans`` one after the other, as one mission of candidates with ``parameters``. A camera id
    that an earlier plan gives another camera is renamed (``"p4p (2)"``): each frame keeps its own camera."""
    n = sum(len(p) for p in plans)
    cameras: dict = {}
    frame_camera = []
    for p in plans:
        rename = {}
        for k, cam in p.cameras.items():
            new, m = k, 2
            while new in cameras and cameras[new] != cam:
                new, m = f"{k} ({m})", m + 1
            cameras[new], rename[k] = cam, new
        fc = p.frame_camera
        if any(k != v for k, v in rename.items()):
            fc = np.array([rename[c] for c in fc] + [None], dtype=object)[:-1]
        frame_camera.append(fc)
    return Plan(cameras=cameras, frame_camera=np.concatenate(frame_camera),
                R_world_camera=np.concatenate([p.R_world_camera for p in plans]),
                C_world=np.concatenate([p.C_world for p in plans]),
                frame_names=np.concatenate([p.frame_names for p in plans]),
                capture_time=np.concatenate([p.capture_time for p in plans]),
                missions=(Mission("candidates", 0, n),), parameters=dict(parameters))


def _with_start(cands: CandidateSet, start: Plan | None) -> tuple[Plan, int]:
    """The candidates, after the frames of ``start`` (if any): one plan to cast."""
    if start is None:
        return cands.plan, 0
    return _concatenated([start, cands.plan], cands.plan.parameters), len(start)


def _with_template_views(pool: Plan, scene: Scene, camera: Camera, flight: FlightSettings) -> Plan:
    """The candidates and the views of the facade, orbit and lawn-mower templates at 70 % overlap (the lawn-mower
    the safety distance above the targets' top): whatever a template could choose, the selection can choose too."""
    from ..plan.templates.registry import build_template

    extra = []
    for name, params in (("facade", {"overlap": 0.7}), ("orbit", {"overlap": 0.7}),
                         ("lawnmower", {"overlap": 0.7, "side_overlap": 0.7})):  # the lawn-mower over the top by g
        try:
            extra.append(build_template(name, scene, camera, params, flight.safety_distance_m, flight.min_height_m,
                                        flight.error))
        except PlanError:  # a template that cannot be made here (a model too small for a grid, too high to fly over)
            continue
    return _concatenated([pool, *extra], pool.parameters)



@dataclass(frozen=True)
class PlanScore:
    """A plan scored against the optimiser's targets from its own evaluation: per element (z,) ``met``; VC; the median
    R_i (m/px) over the visible targets; targets with VR_i ≥ k_i; frames below the stability floor."""

    met: NDArray[np.bool_]
    VC: float | None
    median_R_m_px: float | None
    VR_ge_k: int
    unstable_frames: int


def score_plan(scene: Scene, plan: Plan, targets: ElementTargets, *, scale: float, engine: str = "auto",
               cache_dir: object = None) -> PlanScore:
    """Evaluate ``plan`` (default metric parameters, at ``scale``) and score it against ``targets``: how the
    optimiser's plans and the templates are compared, on the command line and in the benchmark."""
    ev = evaluate(scene, plan, EvaluationSettings(engine=engine, scale=scale, metric=MetricParams()),  # type: ignore[arg-type]
                  cache_dir=cache_dir)
    em = ev.metrics.elements
    met = CoverageTable.build(ev.observations, targets).met(np.arange(len(plan)))
    R = em.R[em.visible & targets.active]
    return PlanScore(met, ev.metrics.plan.VC, float(np.median(R)) if len(R) else None,
                     int(((em.VR >= targets.k) & targets.active).sum()), int((~ev.metrics.frames.stable).sum()))
