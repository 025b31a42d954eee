"""Flying the chosen views: their order, by LKH (``elkai``), then missions by the flight checks' own split.

The views and the take-off point are the cities of a closed tour whose edge costs are the aircraft's flight times
(:func:`~sightplan.plan.checks.battery.legs_time`: horizontal and vertical speeds with acceleration, given to LKH in
hundredths of a second). A leg that passes nearer the model than the safety distance (exact segment–triangle
distances) cannot be flown: it costs what landing between its two views costs (back to the take-off point, a relaunch,
out again), and the tour is solved again until every leg of it is measured. Views grouped to be flown in one stretch
(runs that structure-from-motion chains) pay a surcharge for each entry into or exit from their group. The tour, cut
at the take-off point and at each leg too near, is then split into missions that keep line of sight and fit a
battery by :func:`~sightplan.plan.checks.feasibility.plan_flights`, exactly as a template's frames are.
"""

from __future__ import annotations

import math
from dataclasses import replace

import numpy as np
from numpy.typing import NDArray

from ..engines import make_engine
from ..model.scene import Scene
from ..plan.checks.battery import AIRCRAFT, Aircraft, legs_time
from ..plan.checks.safety import segment_distances
from ..plan.ground import without_terrain
from ..plan.types import Mission, Plan

RELAUNCH_S = 60.0  # landing and taking off again, on top of flying back to the take-off point and out again
MAX_SURCHARGE_S = 1e4
LKH_MAX_COST = (2**31 - 1) // 100 // 4  # LKH multiplies each cost by its precision (100) in 32-bit integers
TICKS_PER_S = 100  # LKH takes whole numbers: costs are given to it in hundredths of a second
GROUP_ENTRY_S = 60.0  # least cost of entering or leaving a group of views flown together (grows when one is split)
MAX_ROUNDS = 60
NEIGHBOURS = 6  # legs to each view's nearest views, measured before the first tour
TUBE_RAYS = 7  # rays per leg in the pre-test: the axis and six lines around it at the safety distance
UNKNOWN_SURCHARGE = 0.25  # share added to the time of a leg whose distance to the model is not yet measured


def blocked_legs(scene: Scene, P: NDArray, radius_m: float) -> NDArray[np.bool_]:
    """(n, n) legs between the (n, 3) points ``P`` that certainly come within ``radius_m`` of the model: the
    segment, or one of six parallel lines ``radius_m`` around it, hits a triangle (Embree occlusion rays). A leg
    this passes may still come too near between the lines: the tour's legs are then measured exactly."""
    n = len(P)
    i, j = np.triu_indices(n, 1)
    out = np.zeros((n, n), bool)
    if not len(i) or not len(scene.faces):
        return out
    d = P[j] - P[i]
    length = np.linalg.norm(d, axis=1)
    u = d / np.maximum(length, 1e-12)[:, None]
    helper = np.where(np.abs(u[:, 2:3]) < 0.9, np.array([[0.0, 0.0, 1.0]]), np.array([[1.0, 0.0, 0.0]]))
    a = np.cross(u, helper)
    a /= np.maximum(np.linalg.norm(a, axis=1, keepdims=True), 1e-12)  # a zero-length leg: only its axis ray, empty
    b = np.cross(u, a)
    offsets = [np.zeros_like(a)] + [radius_m * (math.cos(t) * a + math.sin(t) * b)
                                    for t in np.linspace(0, 2 * math.pi, TUBE_RAYS - 1, endpoint=False)]
    with make_engine("embree", scene, threads=1) as engine:
        hit = np.zeros(len(i), bool)
        for o in offsets:
            origin = (P[i] + o - engine.centre).astype(np.float32)
            hit |= ~engine.unoccluded_rays(origin, u.astype(np.float32), length.astype(np.float32))
    out[i[hit], j[hit]] = out[j[hit], i[hit]] = True
    return out


def lkh_tour(cost: NDArray, runs: int) -> list[int]:
    """The closed tour of least total cost over the (n, n) symmetric matrix ``cost`` of whole numbers (each at most
    ``LKH_MAX_COST``), by LKH (``elkai``) with ``runs`` runs: each city once, from city 0's place in LKH's answer."""
    import elkai

    n = len(cost)
    if n <= 3:
        return list(range(n))
    tour = elkai.DistanceMatrix(np.asarray(cost, np.int64).tolist()).solve_tsp(runs=runs)
    return tour[:-1] if tour[-1] == tour[0] else tour


def _tour(cost: NDArray, runs: int) -> list[int]:
    """:func:`lkh_tour` over ``cost`` in seconds, given to LKH in hundredths."""
    return lkh_tour(np.minimum(np.rint(cost * TICKS_PER_S), LKH_MAX_COST), runs)


def _split_groups(tour: list[int], label: NDArray) -> int:
    """Groups (``label`` ≥ 0 per city) the closed ``tour`` does not fly in one stretch."""
    lab = label[tour]
    stretches = np.bincount(lab[(lab >= 0) & (lab != np.roll(lab, 1))], minlength=int(label.max()) + 1)
    return int((stretches > 1).sum())


class LegMemo:
    """What is known of the legs between views that keep their identity across routings (the same candidate
    pool): ``(a, b) → too near``, keyed by the views' ids (−1: the take-off). Routing a set of views that grew or
    shrank by a few then measures only the legs it has not seen."""

    def __init__(self) -> None:
        self.near: dict[tuple[int, int], bool] = {}

    def __len__(self) -> int:
        return len(self.near)


def order_views(scene: Scene, C: NDArray, takeoff: NDArray, safety_distance_m: float,
                aircraft: Aircraft | None = None, runs: int = 4, *, ids: NDArray | None = None,
                memo: LegMemo | None = None,
                groups: list[NDArray] | None = None) -> tuple[NDArray[np.int64], NDArray[np.int64], int]:
    """The order to fly the (n, 3) view positions ``C`` in from ``takeoff`` and back; the places in that order
    where no safe leg was left (a new mission starts there: the aircraft lands and takes off again); and how many
    legs were forbidden for passing within ``safety_distance_m`` of the model.

    ``ids`` (n,) and ``memo``: the views' identities and the legs measured by earlier routings of the same pool
    (updated). The tours in between are solved with one LKH run, the last one again with ``runs``.

    ``groups``: disjoint sets of positions into ``C`` to be flown each in one stretch (views that
    structure-from-motion chains together). Entering or leaving a group costs a surcharge, larger than what splitting
    one would save (it grows when a tour still splits one).
    """
    n = len(C)
    if n == 0:
        return np.zeros(0, np.int64), np.zeros(0, np.int64), 0
    key = np.concatenate([[-1], np.arange(n) if ids is None else np.asarray(ids, np.int64)]).tolist()
    memo = memo if memo is not None else LegMemo()
    ac = aircraft or AIRCRAFT["p4p"]
    P = np.vstack([np.asarray(takeoff, float).reshape(1, 3), np.asarray(C, float)])
    i, j = np.triu_indices(n + 1, 1)
    cost = np.zeros((n + 1, n + 1))
    cost[i, j] = cost[j, i] = legs_time(P[i], P[j], ac)
    obstacles = without_terrain(scene)
    blocked = blocked_legs(obstacles, P, safety_distance_m)
    blocked[0, :] = blocked[:, 0] = False  # take-off and landing legs climb and descend: the checks skip them
    base = cost.copy()
    cost *= 1 + UNKNOWN_SURCHARGE  # a leg not yet measured costs more: the tours settle on measured legs sooner
    cost[0, :], cost[:, 0] = base[0, :], base[:, 0]
    via_takeoff = base[:, :1] + base[:1, :] + RELAUNCH_S  # a leg too near: the aircraft lands between the two
    cost[blocked] = via_takeoff[blocked]
    forbidden = int(blocked.sum() // 2)
    good: set[tuple[int, int]] = set()
    bad: set[tuple[int, int]] = set()

    def mark(legs: list[tuple[int, int]], near: NDArray) -> None:
        nonlocal forbidden
        good.update(leg for leg, x in zip(legs, near) if not x)
        bad.update(leg for leg, x in zip(legs, near) if x)
        forbidden += int(np.count_nonzero(near))
        a = np.array([p for p, _ in legs], np.int64)
        b = np.array([q for _, q in legs], np.int64)
        cost[a, b] = cost[b, a] = base[a, b]  # measured: its own time, no longer the unknown's surcharge
        cost[a[near], b[near]] = cost[b[near], a[near]] = via_takeoff[a[near], b[near]]

    def memo_key(leg: tuple[int, int]) -> tuple[int, int]:
        p, q = key[leg[0]], key[leg[1]]
        return (p, q) if p <= q else (q, p)

    def measure(new: list[tuple[int, int]]) -> None:
        """Exact distances of the legs ``new`` (those the memo knows are not measured again): those too near are
        forbidden."""
        known = [leg for leg in new if memo_key(leg) in memo.near]
        if known:
            mark(known, np.array([memo.near[memo_key(leg)] for leg in known], bool))
        new = [leg for leg in new if memo_key(leg) not in memo.near]
        if not new:
            return
        a = np.array([p for p, _ in new])
        b = np.array([q for _, q in new])
        near = segment_distances(obstacles, P[a], P[b]) < safety_distance_m  # the checks' own test
        memo.near.update((memo_key(leg), bool(x)) for leg, x in zip(new, near))
        mark(new, near)

    label = np.full(n + 1, -1)
    for k, g in enumerate(groups or ()):
        label[np.asarray(g, np.int64) + 1] = k
    inside: list[tuple[int, int]] = []  # the legs within each group
    for g in groups or ():
        g = np.sort(np.asarray(g, np.int64)) + 1
        a, b = np.triu_indices(len(g), 1)
        inside += list(zip(g[a].tolist(), g[b].tolist()))
    grouped = label >= 0
    entry = (grouped[:, None] | grouped[None, :]) & (label[:, None] != label[None, :])
    surcharge = max(GROUP_ENTRY_S, 4 * max((base[leg] for leg in inside), default=0.0))

    # a tour flies mostly between near neighbours: their legs measured at once spare most of the solves again
    view_cost = cost[1:, 1:] + np.diag(np.full(n, np.inf))
    neighbours = np.argsort(view_cost, axis=1)[:, :min(NEIGHBOURS, n - 1)] + 1
    likely = {(min(i, j), max(i, j)) for i, row in enumerate(neighbours.tolist(), start=1) for j in row}
    likely = sorted(leg for leg in likely | set(inside) if not blocked[leg])
    if likely:
        measure(likely)
    tour = list(range(n + 1))
    final = False
    for _ in range(MAX_ROUNDS):
        tour = _tour(cost + surcharge * entry, runs if final else 1)
        start = tour.index(0)
        tour = tour[start:] + tour[:start]
        legs = [(min(a, b), max(a, b)) for a, b in zip(tour[1:-1], tour[2:])]
        new = [leg for leg in legs if leg not in good and leg not in bad]
        if not new:
            if groups and _split_groups(tour, label) and surcharge < MAX_SURCHARGE_S:
                surcharge *= 4  # a group split: entering one made dearer, and solved again
                continue
            if final or runs <= 1:
                break
            final = True  # every leg of a one-run tour is known: solve again in earnest
            continue
        measure(new)
        # a view whose leg proved too near is in a tight spot: its next nearest legs measured at once, not one a tour
        trouble = {v for leg in new if leg in bad for v in leg if v > 0}
        more = set()
        for v in trouble:
            order = np.argsort(view_cost[v - 1]) + 1
            unknown = [(min(v, int(w)), max(v, int(w))) for w in order[:-1]]
            unknown = [leg for leg in unknown if leg not in good and leg not in bad and not blocked[leg]]
            more.update(unknown[:NEIGHBOURS])
        if more:
            measure(sorted(more))
    legs = [(min(a, b), max(a, b)) for a, b in zip(tour[1:-1], tour[2:])]
    cuts = np.array([k + 1 for k, leg in enumerate(legs) if leg in bad or blocked[leg]], np.int64)
    return np.array(tour[1:], np.int64) - 1, cuts, forbidden


def ordered_plan(views: Plan, order: NDArray, cuts: NDArray | None = None, name: str = "optimised") -> Plan:
    """``views`` in ``order``, one mission between consecutive ``cuts`` (the flight checks split them further),
    each frame its own waypoint."""
    p = views.subset(np.asarray(order, np.int64))
    names = [f"view_{k + 1:04d}" for k in range(len(p))]
    bounds = [0, *sorted(int(c) for c in (cuts if cuts is not None else ()) if 0 < c < len(p)), len(p)]
    parts = list(zip(bounds[:-1], bounds[1:]))
    missions = tuple(Mission(name if len(parts) == 1 else f"{name} {k + 1}", a, b) for k, (a, b) in enumerate(parts))
    return replace(p, missions=missions, waypoints=p.C_world.copy(),
                   frame_names=np.array(names + [None], dtype=object)[:-1])
