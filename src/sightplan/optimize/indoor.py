"""Indoor 360° plans: positions in each storey's free space, chosen as outdoors, walked storey by storey.

*Storeys.* Each storey named in the element table stands on its floor level: the height with the largest area of
upward, horizontal faces among its slabs (``IfcSlab``), to the centimetre; a storey without a slab (foundations)
has no floor, unless no storey has one (then all its elements' upward faces count). A model without storey names
(a mesh) takes a level at every height with at least ``MIN_FLOOR_AREA_M2`` of upward faces. Levels within
``LEVEL_MERGE_M`` of each other are one level (the storey with the larger floor keeps it).

*Candidates* (:func:`indoor_candidates`): a square grid of ``spacing_m`` over each storey's extent, ``height_m``
above its floor level. A position is kept when it is

- inside: a ray straight up meets the model, a ray straight down meets it within ``height_m`` + ``FLOOR_SLACK_M``
  (the floor, or something standing on it), and of ``HORIZONTAL_RAYS`` level rays all round at most
  ``MAX_ESCAPES`` leave the model (an open door, a gap) — Embree rays;
- in free space: at least ``clearance_m`` from every triangle but the terrain's (exact point–triangle distances, the
  walked checks' own test).

One frame per position: a 360° frame sees all round (its heading only places the panorama's seam).

*Selection* (:func:`optimize_indoor`): the candidates cast once through the per-frame cache, then the lazy greedy of
:mod:`.select`, as outdoors (:func:`~.run.optimize`). Surface sampling is bounded by default at the camera's
head-on SSD at ``SSD_DISTANCE_M`` × 1.5.

*Walk.* Per storey, the chosen positions are ordered by LKH (``elkai``) as an open path over walking distances:
straight legs, where a leg that passes within ``clearance_m`` of the model (a wall, a door leaf, a column: exact
segment–triangle distances after an Embree pre-test) is forbidden. Where even the best path needs a forbidden leg,
the walk stops there and a new one starts (the walker goes round, through a door, with the camera off): one mission
per storey, or per part of a storey whose positions no clear leg joins. The walker's checks
(:func:`~sightplan.plan.checks.feasibility.plan_flights` with a :class:`~sightplan.plan.checks.battery.Rover`) then
split a walk that outlasts a battery and check every frame and leg.
"""

from __future__ import annotations

import math
import time
from collections.abc import Callable
from dataclasses import dataclass, replace
from typing import Protocol

import numpy as np
from numpy.typing import NDArray

from ..camera.models import Camera, EquirectangularCamera
from ..engines import make_engine
from ..errors import PlanError
from ..evaluate import EvaluationSettings, evaluate
from ..geometry.poses import R_from_gimbal
from ..metrics import frame_metrics
from ..model.scene import Scene
from ..plan.checks.battery import ROVERS, Rover
from ..plan.checks.feasibility import FeasibilityReport, FlightSettings, plan_flights
from ..plan.checks.gate import record_checks
from ..plan.checks.safety import point_distances, segment_distances
from ..plan.domain import check_work
from ..plan.ground import without_terrain
from ..plan.site import with_site
from ..plan.types import Mission, Plan
from .budget import Budget, longest_prefix
from .candidates import MAX_CANDIDATES, MAX_SCREENED
from .result import OptimizeResult
from .route import LKH_MAX_COST, blocked_legs, lkh_tour
from .select import CoverageTable, FeatureIndex, stable_runs, stable_selection
from .targets import SSD_SLACK, Targets

SPACING_M = 1.0  # on the Duplex: 1.5 m meets 82 targets with 45 frames, 1.0 m 105 with 51, 0.75 m 114 with 57
HEIGHT_M = 1.6  # a 360° camera on a pole, held at eye height
CLEARANCE_M = 0.3  # the walked checks' distance to the model
GROUP_ENTRY_CM = 300  # least cost of entering or leaving a group of positions walked together (3 m of walking)
SSD_DISTANCE_M = 3.0  # the default SSD bound: the camera's head-on SSD at this distance × 1.5
FLOOR_SLACK_M = 0.3
HORIZONTAL_RAYS = 8
MAX_ESCAPES = 2
MIN_FLOOR_AREA_M2 = 4.0
LEVEL_MERGE_M = 0.5
SLAB_CLASSES = ("IfcSlab",)
UP_NZ = 0.99  # a face whose normal's z exceeds this faces up
TEMPLATE_NAME = "optimised_indoor"  # a walked plan to the checks (plan.checks.gate.WALKED_TEMPLATES)
#: the stages ``optimize_indoor`` reports to its ``progress(stage, i, n)``: those of :func:`~.run.optimize`
STAGES = (CASTING, SELECTING, ROUTING) = ("casting candidates", "selecting", "routing")

Progress = Callable[[str, int, int], None]


@dataclass(frozen=True)
class Storey:
    """A storey's name and floor level (model z, m)."""

    name: str
    floor_z: float


@dataclass(frozen=True)
class IndoorCandidates:
    """The candidate positions as a plan (one frame each, one mission per storey, in storey order), the storey of
    each frame (index into ``storeys``), and how many grid positions each test removed (reason → count)."""

    plan: Plan
    storey: NDArray[np.int64]
    storeys: tuple[Storey, ...]
    dropped: dict[str, int]


def _up_faces(scene: Scene) -> tuple[NDArray[np.int64], NDArray[np.float64], NDArray[np.float64]]:
    """Faces facing straight up: their indices, heights (cm-rounded, m) and areas (m²)."""
    if not len(scene.faces):
        return np.zeros(0, np.int64), np.zeros(0), np.zeros(0)
    up = np.flatnonzero(scene.face_normals()[:, 2] > UP_NZ)
    z = np.round(scene.vertices[scene.faces[up]][:, :, 2].mean(axis=1), 2)
    return up, z, scene.face_areas()[up]


def _largest_level(z: NDArray, area: NDArray) -> tuple[float, float]:
    """The height with the largest total area, and that area."""
    levels, inverse = np.unique(z, return_inverse=True)
    total = np.bincount(inverse, weights=area)
    k = int(np.argmax(total))
    return float(levels[k]), float(total[k])


def storey_levels(scene: Scene) -> list[Storey]:
    """The storeys of ``scene`` and their floor levels, lowest first (see the module docstring)."""
    up, z, area = _up_faces(scene)
    if not len(up):
        return []
    element = scene.face_element[up]
    names = scene.elements.storey
    slab = np.isin(scene.elements.ifc_class.astype(str), SLAB_CLASSES)
    found: list[tuple[str, float, float]] = []  # name, level, floor area
    named = sorted({str(n) for n in names[scene.present]} - {""})
    any_slab = bool(slab[element].any())
    for name in named:
        pick = (names[element] == name) & (slab[element] | (not any_slab))
        if pick.any():
            found.append((name, *_largest_level(z[pick], area[pick])))
    if not named:  # a mesh: every level with a floor's area of upward faces
        levels, inverse = np.unique(z, return_inverse=True)
        total = np.bincount(inverse, weights=area)
        found = [(f"level {lv:+.2f} m", float(lv), float(a)) for lv, a in zip(levels, total) if a >= MIN_FLOOR_AREA_M2]
    kept: list[tuple[str, float, float]] = []
    for name, level, a in sorted(found, key=lambda s: -s[2]):  # the larger floor keeps a level
        if all(abs(level - k[1]) >= LEVEL_MERGE_M for k in kept):
            kept.append((name, level, a))
    return [Storey(name, level) for name, level, _ in sorted(kept, key=lambda s: s[1])]


def _storey_extent(scene: Scene, storey: Storey, named: bool) -> tuple[NDArray, NDArray]:
    """(2,) low and high x, y of the storey's elements (of the whole model for a mesh)."""
    if named:
        mine = scene.elements.storey[scene.face_element] == storey.name
        if mine.any():
            v = scene.vertices[scene.faces[mine]].reshape(-1, 3)
            return v[:, :2].min(axis=0), v[:, :2].max(axis=0)
    lo, hi = scene.bounds()
    return lo[:2], hi[:2]


def _grid(lo: NDArray, hi: NDArray, spacing: float) -> NDArray[np.float64]:
    """(n, 2) a square grid of ``spacing`` centred on the box ``lo``…``hi``."""
    axes = []
    for a, b in zip(lo, hi):
        n = max(int(math.floor((b - a) / spacing)) + 1, 1)
        start = (a + b) / 2 - (n - 1) * spacing / 2
        axes.append(start + spacing * np.arange(n))
    gx, gy = np.meshgrid(*axes, indexing="ij")
    return np.stack([gx.ravel(), gy.ravel()], axis=1)


def inside_model(scene: Scene, points: NDArray, height_m: float) -> tuple[NDArray[np.bool_], NDArray[np.bool_]]:
    """For (n, 3) points: (n,) whether each is enclosed (a ray up meets the model and at most ``MAX_ESCAPES`` of
    ``HORIZONTAL_RAYS`` level rays leave it), and (n,) whether it stands over a floor (a ray down meets the model
    within ``height_m`` + ``FLOOR_SLACK_M``)."""
    P = np.asarray(points, np.float64).reshape(-1, 3)
    n = len(P)
    if not n or not len(scene.faces):
        return np.zeros(n, bool), np.zeros(n, bool)
    t = np.linspace(0, 2 * math.pi, HORIZONTAL_RAYS, endpoint=False)
    dirs = np.concatenate([[[0.0, 0.0, 1.0], [0.0, 0.0, -1.0]], np.stack([np.sin(t), np.cos(t), 0 * t], 1)])
    with make_engine("embree", scene, threads=1) as engine:
        origin = (P - engine.centre).astype(np.float32)
        d = np.stack([engine.hit_distance(origin, np.broadcast_to(u.astype(np.float32), origin.shape).copy())
                      for u in dirs], axis=1)  # (n, 2 + rays)
    enclosed = np.isfinite(d[:, 0]) & ((~np.isfinite(d[:, 2:])).sum(axis=1) <= MAX_ESCAPES)
    over_floor = d[:, 1] <= height_m + FLOOR_SLACK_M
    return enclosed, over_floor


def indoor_candidates(scene: Scene, camera: Camera, spacing_m: float = SPACING_M, height_m: float = HEIGHT_M,
                      clearance_m: float = CLEARANCE_M) -> IndoorCandidates:
    """Candidate 360° frames in the free space of each storey (see the module docstring)."""
    if not isinstance(camera, EquirectangularCamera):
        raise PlanError("indoor plans need a 360° (equirectangular) camera")
    for name, v in (("spacing", spacing_m), ("camera height", height_m), ("clearance", clearance_m)):
        if not (isinstance(v, (int, float)) and math.isfinite(v) and v > 0):
            raise PlanError(f"the indoor {name} must be a positive number of metres, got {v!r}")
    storeys = storey_levels(scene)
    if not storeys:
        raise PlanError("the model has no floor to stand on: no storey and no upward face")
    named = bool({str(n) for n in scene.elements.storey[scene.present]} - {""})
    extents = [_storey_extent(scene, s, named) for s in storeys]
    check_work(sum(float(np.prod((hi - lo) / spacing_m + 1)) for lo, hi in extents), MAX_SCREENED,
               f"an indoor grid of {spacing_m:g} m", "the spacing", "grid positions")
    C, which = [], []
    for k, s in enumerate(storeys):
        xy = _grid(*extents[k], spacing_m)
        C.append(np.column_stack([xy, np.full(len(xy), s.floor_z + height_m)]))
        which.append(np.full(len(xy), k, np.int64))
    C, which = np.concatenate(C), np.concatenate(which)
    dropped: dict[str, int] = {}

    def keep(mask: NDArray, why: str) -> None:
        nonlocal C, which
        dropped[why] = dropped.get(why, 0) + int((~mask).sum())
        C, which = C[mask], which[mask]

    enclosed, over_floor = inside_model(scene, C, height_m)
    keep(enclosed, "outside the building")
    keep(over_floor[enclosed], "over no floor")
    if len(C):
        keep(point_distances(without_terrain(scene), C) >= clearance_m, "nearer the model than the clearance")
    check_work(len(C), MAX_CANDIDATES, f"an indoor grid of {spacing_m:g} m", "the spacing", "candidate positions")
    if not len(C):
        reasons = ", ".join(f"{n} {why}" for why, n in dropped.items() if n)
        raise PlanError(f"no position {height_m:g} m above a floor stands inside the model and {clearance_m:g} m clear "
                        f"of it ({reasons}): the model has no free storey space to walk")
    bounds = np.searchsorted(which, np.arange(len(storeys) + 1))  # made storey by storey: already in storey order
    missions = tuple(Mission(s.name, int(bounds[k]), int(bounds[k + 1])) for k, s in enumerate(storeys)
                     if bounds[k + 1] > bounds[k])
    R = R_from_gimbal(np.zeros(len(C)), np.zeros(len(C)), 0.0)
    plan = Plan.build(camera, R, C, missions=missions, frame_names=[f"position_{i:05d}" for i in range(len(C))],
                      parameters={"template": "indoor_candidates", "spacing_m": float(spacing_m),
                                  "height_m": float(height_m), "clearance_m": float(clearance_m),
                                  "storeys": [{"name": s.name, "floor_z": s.floor_z} for s in storeys]})
    return IndoorCandidates(plan, which, tuple(storeys), dropped)


def open_path(cost: NDArray, runs: int = 4) -> list[int]:
    """The order of the cities of the (n, n) symmetric ``cost`` matrix (whole units) that visits each once at the
    least total cost, open at both ends (LKH on the matrix with one city added at no cost from any other)."""
    n = len(cost)
    if n <= 2:
        return list(range(n))
    m = np.zeros((n + 1, n + 1), np.int64)
    m[:n, :n] = cost
    tour = lkh_tour(m, runs)
    k = tour.index(n)
    return tour[k + 1:] + tour[:k]


@dataclass(frozen=True)
class Walk:
    """The order to walk positions in, where in that order a new walk starts (a leg no clear line joins), and how
    many legs were forbidden for passing within the clearance of the model."""

    order: NDArray[np.int64]
    cuts: NDArray[np.int64]
    forbidden: int


def walk_order(scene: Scene, P: NDArray, clearance_m: float, runs: int = 4,
               groups: list[NDArray] | None = None) -> Walk:
    """An open walk through the (n, 3) positions ``P`` (see the module docstring): straight legs, those within
    ``clearance_m`` of ``scene`` forbidden, LKH over their lengths in centimetres (coarser on a walk so long that
    its costs would pass what LKH takes). ``groups``: disjoint sets of positions walked each in one stretch (runs
    that structure-from-motion chains): entering or leaving one costs a surcharge, which grows fourfold while a walk
    still splits one, up to a forbidden leg's cost."""
    P = np.asarray(P, np.float64).reshape(-1, 3)
    n = len(P)
    if n <= 1:
        return Walk(np.arange(n, dtype=np.int64), np.zeros(0, np.int64), 0)
    near = blocked_legs(scene, P, clearance_m)  # certainly too near: a line of the tube meets a triangle
    i, j = np.triu_indices(n, 1)
    todo = ~near[i, j]
    if todo.any():  # the rest measured exactly
        d = segment_distances(scene, P[i[todo]], P[j[todo]])
        bad = d < clearance_m
        near[i[todo][bad], j[todo][bad]] = near[j[todo][bad], i[todo][bad]] = True
    metres = np.linalg.norm(P[:, None] - P[None], axis=2)
    # centimetres, or coarser where a forbidden leg's cost (more than any walk) and a surcharge as large would pass
    # the largest cost LKH takes
    unit_cm = max(1.0, float(np.ceil(metres.max() * 100 * n / (LKH_MAX_COST // 2 - 1))))
    length = np.rint(metres * 100 / unit_cm).astype(np.int64)
    forbidden_cost = int(length.max()) * n + 1  # more than any walk of allowed legs
    cost = np.where(near, forbidden_cost, length)
    label = np.full(n, -1)
    for k, g in enumerate(groups or ()):
        label[np.asarray(g, np.int64)] = k
    grouped = label >= 0
    entry = (grouped[:, None] | grouped[None, :]) & (label[:, None] != label[None, :])
    inner = ~entry & grouped[:, None] & ~near
    surcharge = min(max(int(GROUP_ENTRY_CM / unit_cm), 4 * int(length[inner].max(initial=0))), forbidden_cost)
    while True:
        order = np.array(open_path(cost + surcharge * entry, runs), np.int64)
        lab = label[order]
        starts = lab[(lab >= 0) & (lab != np.concatenate([[-1], lab[:-1]]))]
        if not len(starts) or np.bincount(starts).max() <= 1 or surcharge >= forbidden_cost:
            break  # a group left split (the surcharge at its cap) shows in the frames below the stability floor
        surcharge = min(4 * surcharge, forbidden_cost)  # a group walked in two stretches: entering one made dearer
    cuts = np.flatnonzero(near[order[:-1], order[1:]]) + 1
    return Walk(order, cuts.astype(np.int64), int(near[i, j].sum()))


def walker_settings(clearance_m: float = CLEARANCE_M) -> FlightSettings:
    """The checks of a walk: ``clearance_m`` from the model, a 360° camera walker's battery, no line of sight,
    altitude limit or minimum height (the defaults of ``sightplan check`` for a walked route)."""
    return FlightSettings(safety_distance_m=clearance_m, vlos_radius_m=None, altitude_limit_m=None,
                          aircraft=ROVERS["walker-360"], min_height_m=None)


class CastSettings(Protocol):
    """What an indoor plan reads of the optimiser's settings (an :class:`~.run.OptimizeSettings`)."""

    scale: float
    engine: str
    threads: int | None
    cache_dir: object
    runs: int
    spacing_m: float | None
    cluster: object


@dataclass(frozen=True)
class IndoorSettings:
    """Where the candidates stand: grid ``spacing_m``, camera ``height_m`` above each floor, ``clearance_m`` from the
    model (None: the walk's checks' safety distance, else ``CLEARANCE_M``); how they are cast (``scale``,
    ``engine``, ``threads``, ``cache_dir``: None the default per-frame cache, False none); LKH ``runs``."""

    spacing_m: float | None = SPACING_M
    height_m: float = HEIGHT_M
    clearance_m: float | None = None
    scale: float = 0.25
    engine: str = "auto"
    threads: int | None = None
    cache_dir: object = None
    runs: int = 4

    @classmethod
    def like(cls, settings: CastSettings) -> IndoorSettings:
        """The optimiser's settings as indoor ones: its cast, its runs, its spacing (when given) for the grid. An
        indoor plan is cast on this machine: a cluster is refused."""
        if settings.cluster is not None:
            raise PlanError("indoor 360° plans are cast on this machine: drop the cluster (--cluster)")
        return cls(spacing_m=settings.spacing_m or SPACING_M, scale=settings.scale, engine=settings.engine,
                   threads=settings.threads, cache_dir=settings.cache_dir, runs=settings.runs)


@dataclass(frozen=True)
class IndoorResult(OptimizeResult):
    """An :class:`~.result.OptimizeResult` of a walk: ``candidates_dropped`` says why grid positions were dropped,
    and ``storeys`` are the storeys walked."""

    storeys: tuple[Storey, ...] = ()

    def summary(self) -> dict:
        """The keys of :meth:`~.result.OptimizeResult.summary` (minutes and batteries of walking), the storeys walked
        and the walks (missions before any battery split)."""
        return {**super().summary(), "storeys": [s.name for s in self.storeys],
                "walks": int(self.plan.parameters.get("walks", 0)), "candidates_dropped": dict(self.candidates_dropped)}


def optimize_indoor(scene: Scene, camera: Camera, targets: Targets | None = None, budget: Budget | None = None, *,
                    flight: FlightSettings | None = None, settings: IndoorSettings | CastSettings | None = None,
                    start: Plan | None = None, progress: Progress | None = None) -> IndoorResult:
    """The walked 360° plan that meets the most ``targets`` within ``budget`` with the
    fewest frames (see the module docstring). ``flight``: the walk's checks (default :func:`walker_settings`; a
    :class:`Rover` walks it; its safety distance is the clearance unless ``settings`` gives one). ``settings``:
    :class:`IndoorSettings`, or the optimiser's (:class:`~.run.OptimizeSettings`: its cast, runs and spacing).
    ``start`` is refused: an indoor plan is made afresh."""
    if start is not None:
        raise PlanError("improving a plan (--from) is for perspective plans; an indoor plan is made afresh")
    targets = targets or Targets()
    budget = budget or Budget()
    s = settings if isinstance(settings, IndoorSettings) else (
        IndoorSettings() if settings is None else IndoorSettings.like(settings))
    clearance = s.clearance_m or (flight.safety_distance_m if flight is not None else CLEARANCE_M)
    flight = replace(flight or walker_settings(clearance), safety_distance_m=clearance)
    if not isinstance(flight.aircraft, Rover):
        raise PlanError("an indoor plan is walked: its checks need a walker or rover (e.g. walker-360), not an aircraft")
    timings: dict[str, float] = {}
    et = targets.resolve(scene, SSD_DISTANCE_M / camera.sampling_focal_px * SSD_SLACK)
    if et.n_active == 0:
        raise PlanError("no element is a target of the optimisation: check the targets' rules")

    t0 = time.perf_counter()
    cands = indoor_candidates(scene, camera, s.spacing_m or SPACING_M, s.height_m, clearance)
    pool = cands.plan
    timings["candidates_s"] = time.perf_counter() - t0

    t0 = time.perf_counter()
    metric = targets.metric()
    cast_settings = EvaluationSettings(engine=s.engine, scale=s.scale,  # type: ignore[arg-type]
                                       threads=s.threads, metric=metric)
    obs = evaluate(scene, pool, cast_settings, cache_dir=s.cache_dir,  # type: ignore[arg-type]
                   progress=None if progress is None else (lambda i, n: progress(CASTING, i, n))).observations
    table = CoverageTable.build(obs, et)
    timings["cast_s"] = time.perf_counter() - t0

    t0 = time.perf_counter()
    blind = int((np.diff(table.seen_ptr) == 0).sum())  # candidates that see no target
    can_add = np.diff(table.seen_ptr) > 0  # positions added for stability must see a target (no waste)
    features = FeatureIndex.build(obs)  # read by every growth of runs below
    sel = stable_selection(table, features, targets.min_track, targets.min_features, budget.frames, allowed=can_add,
                           label=cands.storey)
    if not len(sel.views):
        raise PlanError("no candidate position sees any target: lower the targets")
    timings["select_s"] = time.perf_counter() - t0
    if progress is not None:
        progress(SELECTING, 1, 1)

    t0 = time.perf_counter()
    obstacles = without_terrain(scene)

    def fits(walk: tuple[FeasibilityReport, NDArray, int, int]) -> bool:
        return budget.admits(len(walk[1]), walk[0])

    def walked(views: NDArray, grow: bool = True) -> tuple[FeasibilityReport, NDArray, int, int]:
        """``views`` grown into runs that register (:func:`~.select.stable_runs`, each within its storey; not when
        ``grow`` is False), walked."""
        grown = stable_runs(features, views, targets.min_track, targets.min_features if grow else 0,
                            allowed=can_add, table=table, label=cands.storey)
        group_of = np.full(table.n_views, -1)
        for k, g in enumerate(grown.groups):
            group_of[grown.views[g]] = k
        return _walk_plan(obstacles, scene, pool, cands, np.sort(grown.views), flight, s.runs, group_of)

    views = sel.views
    walk = walked(views)
    report, walked_views, forbidden, walks = walk
    if not fits(walk):
        found = longest_prefix(views, walked, fits)
        if found is None:
            raise PlanError("not even one position fits the budget of frames, minutes or batteries")
        views = views[:found[0]]
        report, walked_views, forbidden, walks = found[1]
    timings["route_s"] = time.perf_counter() - t0
    if progress is not None:
        progress(ROUTING, 1, 1)

    along = frame_metrics(obs.select_frames(walked_views), metric)
    met = table.met(walked_views)
    params = {"template": TEMPLATE_NAME, "safety_distance_m": clearance, "spacing_m": s.spacing_m or SPACING_M,
              "height_m": s.height_m, "clearance_m": clearance, "walks": walks,
              "storeys": [{"name": st.name, "floor_z": st.floor_z} for st in cands.storeys],
              "targets": targets.record(et), "budget": budget.record(),
              "candidates": len(pool), "met": int(met.sum()), "scale": s.scale}
    plan = record_checks(report.plan, report, flight)
    plan = with_site(replace(plan, parameters={**plan.parameters, **params}), scene, replace_takeoff=True)
    report = replace(report, plan=plan)
    storeys = tuple(cands.storeys[k] for k in np.unique(cands.storey[walked_views]))
    return IndoorResult(plan, report, et, met, len(pool), cands.dropped, blind, len(sel.removed), forbidden,
                        int((~along.stable).sum()), int((along.pixels_on_targets <= 0).sum()),
                        stability_views=len(walked_views) - len(views), timings=timings, storeys=storeys)


def _walk_plan(obstacles: Scene, scene: Scene, pool: Plan, cands: IndoorCandidates, views: NDArray,
               flight: FlightSettings, runs: int,
               group_of: NDArray | None = None) -> tuple[FeasibilityReport, NDArray[np.int64], int, int]:
    """The pool's ``views`` walked storey by storey (a mission each, more where no clear leg goes on), each group of
    ``group_of`` (per pool view, −1: none) in one stretch, split and checked by the walker's checks; the walked order
    (pool indices), the legs forbidden and the walks."""
    order: list[NDArray] = []
    missions: list[Mission] = []
    forbidden = 0
    for k, storey in enumerate(cands.storeys):
        mine = views[cands.storey[views] == k]
        if not len(mine):
            continue
        gm = group_of[mine] if group_of is not None else np.full(len(mine), -1)
        groups = [np.flatnonzero(gm == g) for g in np.unique(gm[gm >= 0])]
        w = walk_order(obstacles, pool.C_world[mine], flight.safety_distance_m, runs, groups)
        forbidden += w.forbidden
        bounds = [0, *w.cuts.tolist(), len(mine)]
        base = sum(len(o) for o in order)
        parts = list(zip(bounds[:-1], bounds[1:]))
        for p, (a, b) in enumerate(parts):
            name = storey.name if len(parts) == 1 else f"{storey.name}, walk {p + 1}"
            missions.append(Mission(name, base + a, base + b))
        order.append(mine[w.order])
    walked = np.concatenate(order)
    p = pool.subset(walked)
    names = [f"pano_{i + 1:04d}" for i in range(len(p))]
    p = replace(p, missions=tuple(missions), waypoints=p.C_world.copy(),
                frame_names=np.array(names + [None], dtype=object)[:-1])
    return plan_flights(scene, p, flight), walked, forbidden, len(missions)
