"""Choosing views: a lazy-greedy submodular selection over the candidates' Observations, then a removal pass.

The objective for a set S of views is

    F(S) = Σ_i w_i · min(k_i, q_i(S)) / k_i  +  ε · Σ_i w_i · [s_i(S) > 0]

where q_i(S) counts the views of S that *serve* element i (:mod:`.targets`: ≥ Ω px, SSD and angle within bounds)
and s_i(S) those that see it by ≥ Ω px at all; ε = 0.1 rewards seeing an element before it can be met. Both terms are
monotone and submodular (concave functions of counts), so the greedy choice is within 1 − 1/e of the best set of its
size, and lazy evaluation (a gain only ever falls as S grows) keeps it cheap. Every gain is a sum over the sparse
Observations rows of one view: no ray is cast again. Selection stops at the budget or when no view adds anything;
the removal pass then drops, latest first, every view whose loss leaves F unchanged.
"""

from __future__ import annotations

import heapq
from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from ..observations.table import Observations
from .targets import ElementTargets

SEEN_WEIGHT = 0.1  # ε


@dataclass(frozen=True)
class CoverageTable:
    """Per view, the elements it serves and those it sees (CSR: ``serve_ptr[f]:serve_ptr[f + 1]`` into
    ``serve_el``), with the targets' per-element values."""

    n_views: int
    serve_ptr: NDArray[np.int64]
    serve_el: NDArray[np.int64]
    serve_ssd: NDArray[np.float64]
    seen_ptr: NDArray[np.int64]
    seen_el: NDArray[np.int64]
    k: NDArray[np.int64]
    weight: NDArray[np.float64]

    @classmethod
    def build(cls, obs: Observations, targets: ElementTargets) -> CoverageTable:
        e = obs.element.astype(np.int64)
        f = obs.frame.astype(np.int64)
        seen = targets.sees(obs)
        serve = targets.serves(obs)

        def csr(mask: NDArray) -> tuple[NDArray, NDArray, NDArray]:
            order = np.argsort(f[mask], kind="stable")
            ptr = np.zeros(obs.n_frames + 1, np.int64)
            np.cumsum(np.bincount(f[mask], minlength=obs.n_frames), out=ptr[1:])
            return ptr, e[mask][order], obs.ssd[mask][order]

        sp, se, ss = csr(serve)
        vp, ve, _ = csr(seen)
        return cls(obs.n_frames, sp, se, ss, vp, ve, targets.k.astype(np.int64), targets.weight.astype(np.float64))

    def serves(self, f: int) -> NDArray[np.int64]:
        return self.serve_el[self.serve_ptr[f]:self.serve_ptr[f + 1]]

    def sees(self, f: int) -> NDArray[np.int64]:
        return self.seen_el[self.seen_ptr[f]:self.seen_ptr[f + 1]]

    def counts(self, views: NDArray) -> tuple[NDArray[np.int64], NDArray[np.int64]]:
        """q_i and s_i of the set ``views``, from scratch."""
        z = len(self.k)
        views = np.asarray(views, np.int64)
        return (np.bincount(self.serve_el[_rows(self.serve_ptr, views)], minlength=z),
                np.bincount(self.seen_el[_rows(self.seen_ptr, views)], minlength=z))

    def value(self, views: NDArray) -> float:
        """F of the set ``views``, from scratch."""
        q, s = self.counts(views)
        return float((self.weight * np.minimum(self.k, q) / self.k).sum() + SEEN_WEIGHT * (self.weight * (s > 0)).sum())

    def met(self, views: NDArray) -> NDArray[np.bool_]:
        """(z,) elements with weight whose k_i views the set ``views`` provides."""
        q, _ = self.counts(views)
        return (q >= self.k) & (self.weight > 0)

    def gain(self, f: int, q: NDArray, s: NDArray) -> float:
        """F(S ∪ {f}) − F(S) for the counts ``q``, ``s`` of S."""
        a = self.serves(f)
        b = self.sees(f)
        short = q[a] < self.k[a]
        return float((self.weight[a][short] / self.k[a][short]).sum()
                     + SEEN_WEIGHT * self.weight[b][s[b] == 0].sum())


    def gains(self, views: NDArray, q: NDArray, s: NDArray) -> NDArray[np.float64]:
        """:meth:`gain` of each of ``views`` at once."""
        views = np.asarray(views, np.int64)
        out = np.zeros(len(views))
        for ptr, el, weight, short in ((self.serve_ptr, self.serve_el, self.weight / self.k, q < self.k),
                                       (self.seen_ptr, self.seen_el, SEEN_WEIGHT * self.weight, s == 0)):
            e = el[_rows(ptr, views)]
            owner = np.repeat(np.arange(len(views)), ptr[views + 1] - ptr[views])
            hit = short[e]
            out += np.bincount(owner[hit], weights=weight[e[hit]], minlength=len(views))
        return out


def _rows(ptr: NDArray[np.int64], views: NDArray[np.int64]) -> NDArray[np.int64]:
    """The entries ``ptr[f]:ptr[f + 1]`` of each of ``views``, one after the other."""
    start, length = ptr[views], ptr[views + 1] - ptr[views]
    offset = np.repeat(np.cumsum(length) - length, length)
    return np.repeat(start, length) + np.arange(int(length.sum())) - offset


@dataclass(frozen=True)
class Selection:
    """The chosen views in the order chosen, each one's gain when chosen, and those the removal pass dropped."""

    views: NDArray[np.int64]
    gains: NDArray[np.float64]
    removed: NDArray[np.int64]


def greedy(table: CoverageTable, max_views: int | None = None, start: NDArray | None = None,
           allowed: NDArray | None = None) -> Selection:
    """Lazy greedy from the views ``start`` (chosen first), adding the view of largest gain among ``allowed``
    (default: all) until ``max_views`` are chosen (counting ``start``) or nothing adds anything; then the removal
    pass, which may drop start views too when they prove redundant."""
    z = len(table.k)
    q = np.zeros(z, np.int64)
    s = np.zeros(z, np.int64)
    chosen: list[int] = []
    gains: list[float] = []
    for f in (np.asarray(start, np.int64) if start is not None else ()):
        gains.append(table.gain(int(f), q, s))
        q[table.serves(int(f))] += 1
        s[table.sees(int(f))] += 1
        chosen.append(int(f))
    taken = np.zeros(table.n_views, bool)
    taken[chosen] = True
    pool = np.flatnonzero(~taken if allowed is None else (~taken & np.asarray(allowed, bool)))
    heap = [(-table.gain(int(f), q, s), int(f)) for f in pool]
    heap = [h for h in heap if h[0] < 0]
    heapq.heapify(heap)
    limit = max_views if max_views is not None else table.n_views
    while heap and len(chosen) < limit:
        bound, f = heapq.heappop(heap)
        g = table.gain(f, q, s)
        if g <= 0:
            continue
        if heap and -g > heap[0][0] + 1e-12:  # no longer the best: back in with its true gain
            heapq.heappush(heap, (-g, f))
            continue
        chosen.append(f)
        gains.append(g)
        q[table.serves(f)] += 1
        s[table.sees(f)] += 1
    views = np.array(chosen, np.int64)
    keep, removed = remove_redundant(table, views, q, s)  # a start plan's frames too, when redundant
    return Selection(keep, np.array(gains)[np.isin(views, keep)], removed)


def remove_redundant(table: CoverageTable, views: NDArray, q: NDArray | None = None, s: NDArray | None = None,
                     protect: int = 0) -> tuple[NDArray[np.int64], NDArray[np.int64]]:
    """``views`` without those whose loss leaves F unchanged (latest first; the first ``protect`` stay), and the
    dropped ones."""
    if q is None or s is None:
        q, s = table.counts(views)
    q, s = q.copy(), s.copy()
    keep = np.ones(len(views), bool)
    for j in range(len(views) - 1, protect - 1, -1):
        f = int(views[j])
        a, b = table.serves(f), table.sees(f)
        if (q[a] > table.k[a]).all() and (s[b] > 1).all():
            keep[j] = False
            q[a] -= 1
            s[b] -= 1
    return views[keep], views[~keep]


def refine(table: CoverageTable, views: NDArray, max_views: int) -> NDArray[np.int64]:
    """Views to add after ``views``, best first, up to ``max_views`` in all, each the one that most lowers the met
    elements' R_i (the mean SSD of their k_i finest serving views), weighted and relative:
    Σ_i w_i · (R_i − R_i') / R_i. For spending a budget of minutes or frames that the targets did not need; stops
    when no view makes any element finer."""
    z = len(table.k)
    kmax = int(table.k.max()) if z else 1
    best = np.full((z, kmax), np.inf)  # each element's finest serving SSDs, ascending
    for f in views:
        for i, v in zip(table.serves(int(f)).tolist(), table.serve_ssd[table.serve_ptr[f]:table.serve_ptr[f + 1]]):
            row = best[i]
            if v < row[-1]:
                row[-1] = v
                row.sort()
    chosen = np.zeros(table.n_views, bool)
    chosen[np.asarray(views, np.int64)] = True
    frame_of = np.repeat(np.arange(table.n_views), np.diff(table.serve_ptr))
    added: list[int] = []
    while len(views) + len(added) < max_views:
        kth = best[np.arange(z), table.k - 1]
        with np.errstate(invalid="ignore"):
            R = np.where(np.arange(kmax)[None, :] < table.k[:, None], best, 0.0).sum(axis=1) / table.k
        e, v = table.serve_el, table.serve_ssd
        better = np.isfinite(R[e]) & (v < kth[e]) & ~chosen[frame_of]
        gain = np.zeros(table.n_views)
        np.add.at(gain, frame_of[better], table.weight[e[better]] * (kth[e[better]] - v[better]) / table.k[e[better]]
                  / R[e[better]])
        f = int(np.argmax(gain))
        if gain[f] <= 0:
            break
        added.append(f)
        chosen[f] = True
        for i, x in zip(table.serves(f).tolist(), table.serve_ssd[table.serve_ptr[f]:table.serve_ptr[f + 1]]):
            row = best[i]
            if x < row[-1]:
                row[-1] = x
                row.sort()
    return np.array(added, np.int64)


PREFER_CHOSEN = 3.0  # a chosen view's shared features count this many times over a new view's when runs are formed


@dataclass(frozen=True)
class Runs:
    """Views grouped into runs that structure-from-motion can chain: ``views`` (the given ones, then those added),
    ``groups`` (positions into ``views``, one array per run of ``min_track`` views that share at least
    ``min_features`` features), ``alone``: given views for which no such run could be formed, and how many views
    were ``added``."""

    views: NDArray[np.int64]
    groups: list[NDArray[np.int64]]
    alone: NDArray[np.int64]
    added: int = 0


@dataclass(frozen=True)
class FeatureIndex:
    """The features of an Observations table both ways: the frames that see each feature (``f_ptr`` into
    ``f_frame``) and the features each frame sees (``v_ptr`` into ``v_feature``). Built once, read by every
    :func:`stable_runs` of an optimisation."""

    n_frames: int
    f_ptr: NDArray[np.int64]
    f_frame: NDArray[np.int64]
    v_ptr: NDArray[np.int64]
    v_feature: NDArray[np.int64]

    @classmethod
    def build(cls, obs: Observations) -> FeatureIndex:
        n, nf = obs.n_frames, max(obs.n_features, 1)
        order = np.lexsort((obs.feature_frame, obs.feature_id))  # per feature, the frames that see it
        f_ptr = np.zeros(nf + 1, np.int64)
        np.cumsum(np.bincount(obs.feature_id, minlength=nf), out=f_ptr[1:])
        v_ptr = np.zeros(n + 1, np.int64)
        np.cumsum(np.bincount(obs.feature_frame, minlength=n), out=v_ptr[1:])
        by_frame = np.argsort(obs.feature_frame, kind="stable")
        return cls(n, f_ptr, obs.feature_frame[order].astype(np.int64), v_ptr,
                   obs.feature_id[by_frame].astype(np.int64))


def stable_runs(obs: Observations | FeatureIndex, views: NDArray, min_track: int, min_features: int,
                allowed: NDArray | None = None, prefer: float = PREFER_CHOSEN,
                table: CoverageTable | None = None, label: NDArray | None = None) -> Runs:
    """Groups of ``min_track`` views sharing ≥ ``min_features`` features, so that each view of ``views`` (in
    order: the most useful first) lies in one. A feature on a run of Y consecutive frames is stable in each of them
    (ν_f, :func:`~sightplan.metrics.stable_feature_counts`); a group flown consecutively therefore makes each of its
    frames stable. A group grows from a view not yet grouped by the frame that keeps the most of the features the
    group has in common — a view already chosen counted ``prefer`` times, one not chosen (among ``allowed``, default
    all) up to twice as its gain in the objective of ``table`` (if given) is near the best such gain — and a view not
    chosen is added to the plan; a group that cannot keep ``min_features`` leaves its first view alone. Groups are
    disjoint; with ``label`` (one per view, e.g. its storey) a group keeps to its first view's label."""
    views = np.asarray(views, np.int64)
    if min_track <= 1 or min_features <= 0 or not len(views):
        return Runs(views, [], np.zeros(0, np.int64))
    index = obs if isinstance(obs, FeatureIndex) else FeatureIndex.build(obs)
    n, f_ptr, ffr, v_ptr, v_feat = index.n_frames, index.f_ptr, index.f_frame, index.v_ptr, index.v_feature
    chosen = np.zeros(n, bool)
    chosen[views] = True
    usable = np.ones(n, bool) if allowed is None else np.asarray(allowed, bool).copy()
    grouped = np.zeros(n, bool)
    weight = np.where(chosen, prefer, 1.0)
    if table is not None:
        q, s = table.counts(views)
    groups: list[list[int]] = []
    alone: list[int] = []
    def grow(f: int, plain: bool) -> tuple[list[int], NDArray]:
        """A group from ``f``: ``plain`` keeps the most shared features at each step, with no preference."""
        common = v_feat[v_ptr[f]:v_ptr[f + 1]]
        members = [f]
        while len(members) < min_track and len(common) >= min_features:
            shared = np.bincount(ffr[_rows(f_ptr, common)], minlength=n).astype(float)
            shared[grouped | ~(usable | chosen)] = 0
            shared[members] = 0
            if label is not None:
                shared[label != label[f]] = 0
            shared[shared < min_features] = 0  # a frame sharing fewer cannot keep the group's floor
            score = shared * (1.0 if plain else weight)
            new = np.flatnonzero((shared > 0) & ~chosen)
            if table is not None and len(new) and not plain:
                gain = table.gains(new, q, s)
                if gain.max() > 0:
                    score[new] *= 1 + gain / gain.max()
            g = int(np.argmax(score))
            if shared[g] <= 0:
                break
            members.append(g)
            common = np.intersect1d(common, v_feat[v_ptr[g]:v_ptr[g + 1]])
        return members, common

    for f in views.tolist():
        if grouped[f]:
            continue
        for plain in (False, True):  # the preferred views first; failing that, the views that keep most in common
            members, common = grow(f, plain)
            if len(members) == min_track and len(common) >= min_features:
                break
        else:
            alone.append(f)
            continue
        groups.append(members)
        grouped[members] = True
        if table is not None:
            new = [g for g in members if not chosen[g]]
            for g in new:
                q[table.serves(g)] += 1
                s[table.sees(g)] += 1
    alone = [f for f in alone if not grouped[f]]  # a view no group could grow from may have joined a later one
    extra = np.array(sorted({g for m in groups for g in m} - set(views.tolist())), np.int64)
    out = np.concatenate([views, extra])
    where = {int(v): k for k, v in enumerate(out.tolist())}
    return Runs(out, [np.array([where[g] for g in m], np.int64) for m in groups], np.array(alone, np.int64),
                len(extra))


RESELECT_ROUNDS = 3


def stable_selection(table: CoverageTable, obs: Observations | FeatureIndex, min_track: int, min_features: int,
                     max_views: int | None = None, start: NDArray | None = None, allowed: NDArray | None = None,
                     label: NDArray | None = None, rounds: int = RESELECT_ROUNDS) -> Selection:
    """:func:`greedy`, then again without the chosen views that no run can be formed around
    (:func:`stable_runs`'s ``alone``, with ``allowed`` the views runs may add and ``label`` their groups' bound;
    ``start`` views are kept), up to ``rounds`` times, as long as the weighted targets met do not fall: a target one
    of them serves is then served by views that can register."""
    sel = greedy(table, max_views, start=start)
    if min_track <= 1 or min_features <= 0:
        return sel
    banned = np.zeros(table.n_views, bool)
    met = (table.weight * table.met(sel.views)).sum()
    index = obs if isinstance(obs, FeatureIndex) else FeatureIndex.build(obs)
    for _ in range(rounds):
        alone = stable_runs(index, sel.views, min_track, min_features, allowed=allowed, table=table, label=label).alone
        alone = alone[~np.isin(alone, start)] if start is not None else alone
        if not len(alone) or banned[alone].all():
            break
        banned[alone] = True
        other = greedy(table, max_views, start=start, allowed=~banned)
        if (table.weight * table.met(other.views)).sum() < met:
            break
        sel = other
    return sel
