"""Property tests of the metrics (METRICS.md §3–5) on random small Observations.

Every oracle here is a plain Python loop over the frames as generated (lists of
per-frame rows), never the package's own numpy helpers, so that the vectorised
implementation is checked against the definitions as the spec words them.
"""

from __future__ import annotations

import math
import tempfile
from dataclasses import dataclass
from pathlib import Path

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from sightplan.metrics import MetricParams, compute_metrics
from sightplan.observations.table import FrameObservation, Observations

SETTINGS = settings(max_examples=100, deadline=None, suppress_health_check=[HealthCheck.too_slow])
N_FEATURE_IDS = 40
DEFAULT = MetricParams(omega=625.0, k=3, min_track=5, min_features=50)


@dataclass
class Case:
    """The raw generated plan and the Observations built from it.

    frames[f] is a list of (element, count, depth_mean, angle_mean) rows, sorted by element;
    features[f] a sorted list of feature ids; scale[f], focal[f] per frame.
    """

    frames: list[list[tuple[int, int, float, float]]]
    features: list[list[int]]
    scale: list[float]
    focal: list[float]
    is_target: list[bool]
    present: list[bool]
    obs: Observations

    @property
    def n(self) -> int:
        return len(self.frames)

    @property
    def z_all(self) -> int:
        return len(self.is_target)


def _frame_obs(rows, features, scale, focal) -> FrameObservation:
    return FrameObservation(
        element=np.array([r[0] for r in rows], np.int32),
        count=np.array([r[1] for r in rows], np.int64),
        depth_mean=np.array([r[2] for r in rows], np.float64),
        angle_mean=np.array([r[3] for r in rows], np.float64),
        features=np.array(features, np.int32),
        pixel_scale=float(scale),
        sampling_focal_px=float(focal),
    )


# Counts near Ω at every pixel scale (625 = Ω at scale 1; 156·4 = 624, 157·4 = 628; 39·16 = 624, 40·16 = 640)
# mixed with the full range, so the ≥ Ω boundary is exercised after the scale conversion.
counts = st.one_of(st.integers(1, 3000), st.sampled_from([1, 39, 40, 156, 157, 624, 625, 626]))
# A few shared values make ties in ρ and θ̄ likely.
depths = st.one_of(st.floats(0.1, 500.0, allow_nan=False, allow_infinity=False), st.sampled_from([1.0, 2.0, 10.0]))
angles = st.one_of(st.floats(0.0, 90.0, allow_nan=False, allow_infinity=False), st.sampled_from([0.0, 30.0, 90.0]))
focals = st.one_of(st.floats(100.0, 5000.0, allow_nan=False, allow_infinity=False), st.sampled_from([500.0, 1000.0]))


@st.composite
def cases(draw, min_frames: int = 1, max_frames: int = 8) -> Case:
    z_all = draw(st.integers(1, 10))
    is_target = draw(st.lists(st.booleans(), min_size=z_all, max_size=z_all))
    # targets are present by definition; occluders may or may not be
    present = [t or draw(st.booleans()) for t in is_target]
    n = draw(st.integers(min_frames, max_frames))
    frames, features, scale, focal = [], [], [], []
    for _ in range(n):
        elements = sorted(draw(st.sets(st.integers(0, z_all - 1), max_size=z_all)))
        frames.append([(e, draw(counts), draw(depths), draw(angles)) for e in elements])
        features.append(sorted(draw(st.sets(st.integers(0, N_FEATURE_IDS - 1), max_size=30))))
        scale.append(draw(st.sampled_from([1.0, 4.0, 16.0])))
        focal.append(draw(focals))
    obs = Observations.from_frames(
        [_frame_obs(r, q, s, fo) for r, q, s, fo in zip(frames, features, scale, focal)],
        np.array(is_target, bool), np.array(present, bool), N_FEATURE_IDS)
    return Case(frames, features, scale, focal, is_target, present, obs)


params_st = st.builds(
    MetricParams,
    omega=st.sampled_from([1.0, 100.0, 625.0, 624.0, 2000.0]),
    k=st.integers(1, 5),
    min_track=st.integers(1, 6),
    min_features=st.integers(0, 30),
)


# ------------------------------------------------------------------ oracles
def qualifying(case: Case, i: int, omega: float) -> list[tuple[float, float]]:
    """(ρ, θ̄) of the frames where |γ_{i,f}| ≥ Ω, |γ| in full-resolution pixels."""
    out = []
    for f in range(case.n):
        for e, c, d, a in case.frames[f]:
            if e == i and c * case.scale[f] >= omega:
                out.append((d / case.focal[f], a))
    return out


def observed_oracle(case: Case, i: int) -> bool:
    return any(e == i and c >= 1 for rows in case.frames for e, c, _, _ in rows)


def mean_k_smallest(values: list[float], k: int) -> float:
    if not values:
        return math.nan
    best = sorted(values)[: min(k, len(values))]
    return sum(best) / len(best)


def nu_oracle(features: list[list[int]], min_track: int) -> list[int]:
    n = len(features)
    nu = [0] * n
    for u in range(N_FEATURE_IDS):
        f = 0
        while f < n:
            if u not in features[f]:
                f += 1
                continue
            start = f
            while f < n and u in features[f]:
                f += 1
            if f - start >= min_track:
                for g in range(start, f):
                    nu[g] += 1
    return nu


def assert_close_or_nan(actual, expected, rel=1e-9) -> None:
    if math.isnan(expected):
        assert math.isnan(actual)
    else:
        assert actual == pytest.approx(expected, rel=rel, abs=1e-15)


def assert_plan_close(a, b) -> None:
    """Plan scalars equal; R and O within float summation order."""
    da, db = a.to_dict(), b.to_dict()
    for key in da:
        if da[key] is None or db[key] is None:
            assert da[key] is None and db[key] is None, key
        elif key in ("R", "O"):
            assert da[key] == pytest.approx(db[key], rel=1e-12), key
        else:
            assert da[key] == db[key], key


# ------------------------------------------------------------------ 1. ranges and nulls
@SETTINGS
@given(case=cases(), params=params_st)
def test_ranges_and_undefined(case: Case, params: MetricParams) -> None:
    m = compute_metrics(case.obs, params)
    p = m.plan
    z = sum(case.is_target)
    V = sum(1 for i in range(case.z_all) if case.is_target[i] and qualifying(case, i, params.omega))
    n_obs = sum(1 for i in range(case.z_all) if case.is_target[i] and observed_oracle(case, i))
    assert (p.z, p.n_visible, p.n_observed, p.n_frames) == (z, V, n_obs, case.n)
    assert p.n_visible <= p.n_observed <= p.z

    assert (p.VC is None) == (z == 0)
    assert (p.VC_bar is None) == (n_obs == 0)
    for key in ("VR", "R", "O"):
        assert (getattr(p, key) is None) == (V == 0), key
    assert p.T is not None  # n ≥ 1 here
    if p.VC is not None:
        assert 0.0 <= p.VC <= 1.0
        assert p.VC == pytest.approx(V / z)
    if p.VC_bar is not None:
        assert 0.0 <= p.VC_bar <= 1.0
        assert p.VC_bar == pytest.approx(V / n_obs)
    if p.VC is not None and p.VC_bar is not None:
        assert p.VC <= p.VC_bar
    if V:
        assert p.VR >= 1.0
        assert 0.0 <= p.O <= 90.0
        assert p.R > 0.0
    for value in p.to_dict().values():
        assert value is None or not (isinstance(value, float) and math.isnan(value))

    # Occluders never count: not visible, not observed, VR 0, no R/O.
    el = m.elements
    for i in range(case.z_all):
        if not case.is_target[i]:
            assert el.VR[i] == 0
            assert not el.visible[i]
            assert not el.observed[i]
            assert math.isnan(el.R[i]) and math.isnan(el.O[i])
            assert el.pixels_total[i] == 0
            assert el.frames_observed[i] == 0
    # per-frame counts agree with the raw rows
    for f in range(case.n):
        on_targets = [(c * case.scale[f]) for e, c, _, _ in case.frames[f] if case.is_target[e]]
        assert m.frames.elements_visible[f] == sum(1 for px in on_targets if px >= params.omega)
        assert m.frames.pixels_on_targets[f] == pytest.approx(sum(on_targets))
        assert m.frames.features_observed[f] == len(case.features[f])


def test_no_frames_gives_null_T() -> None:
    obs = Observations.from_frames([], np.array([True, False]), np.array([True, True]), N_FEATURE_IDS)
    p = compute_metrics(obs, DEFAULT).plan
    assert p.n_frames == 0
    assert p.T is None and p.stable_share is None
    assert p.VC == 0.0 and p.VC_bar is None
    assert p.VR is None and p.R is None and p.O is None


# ------------------------------------------------------------------ 2. frame order
@SETTINGS
@given(case=cases(), params=params_st, data=st.data())
def test_frame_order_invariance(case: Case, params: MetricParams, data) -> None:
    perm = data.draw(st.permutations(range(case.n)))
    a = compute_metrics(case.obs, params)
    b = compute_metrics(case.obs.select_frames(np.array(perm, int)), params)
    for key in ("VC", "VC_bar", "VR", "z", "n_visible", "n_observed", "n_frames"):
        assert getattr(a.plan, key) == getattr(b.plan, key), key
    for key in ("R", "O"):
        va, vb = getattr(a.plan, key), getattr(b.plan, key)
        assert (va is None) == (vb is None)
        if va is not None:
            assert va == pytest.approx(vb, rel=1e-12)
    np.testing.assert_array_equal(a.elements.VR, b.elements.VR)
    np.testing.assert_array_equal(a.elements.visible, b.elements.visible)
    np.testing.assert_array_equal(a.elements.observed, b.elements.observed)
    np.testing.assert_array_equal(a.elements.frames_observed, b.elements.frames_observed)
    np.testing.assert_allclose(a.elements.R, b.elements.R, rtol=1e-12)
    np.testing.assert_allclose(a.elements.O, b.elements.O, rtol=1e-12)
    np.testing.assert_allclose(a.elements.pixels_total, b.elements.pixels_total, rtol=1e-12)
    # per-frame quantities that depend on the frame alone follow the permutation
    np.testing.assert_array_equal(a.frames.features_observed[perm], b.frames.features_observed)
    np.testing.assert_array_equal(a.frames.elements_visible[perm], b.frames.elements_visible)


# ------------------------------------------------------------------ 3. monotonicity in Ω and k
@SETTINGS
@given(case=cases(), omegas=st.lists(st.sampled_from([1.0, 50.0, 624.0, 625.0, 626.0, 1000.0, 5000.0]),
                                      min_size=2, max_size=2, unique=True))
def test_lower_omega_never_decreases_VR(case: Case, omegas: list[float]) -> None:
    lo, hi = sorted(omegas)
    a = compute_metrics(case.obs, MetricParams(omega=lo))
    b = compute_metrics(case.obs, MetricParams(omega=hi))
    assert np.all(a.elements.VR >= b.elements.VR)
    assert np.all(a.elements.visible >= b.elements.visible)
    np.testing.assert_array_equal(a.elements.observed, b.elements.observed)  # Ω does not enter "observed"
    assert a.plan.n_visible >= b.plan.n_visible
    assert np.all(a.frames.elements_visible >= b.frames.elements_visible)


@SETTINGS
@given(case=cases(), omega=st.sampled_from([1.0, 625.0, 1500.0]))
def test_raising_k_only_includes_more(case: Case, omega: float) -> None:
    by_k = {k: compute_metrics(case.obs, MetricParams(omega=omega, k=k)).elements for k in range(1, 10)}
    for i in range(case.z_all):
        q = qualifying(case, i, omega) if case.is_target[i] else []
        rho = [r for r, _ in q]
        theta = [t for _, t in q]
        if not q:
            for el in by_k.values():
                assert math.isnan(el.R[i]) and math.isnan(el.O[i])
            continue
        # k = 1: the best frame
        assert by_k[1].R[i] == min(rho)
        assert by_k[1].O[i] == min(theta)
        # k ≥ VR_i: all qualifying frames
        assert_close_or_nan(by_k[9].R[i], sum(rho) / len(rho))
        assert_close_or_nan(by_k[9].O[i], sum(theta) / len(theta))
        for k in range(1, 9):
            lo, hi = by_k[k], by_k[k + 1]
            # the mean of more of the smallest values never decreases ...
            assert hi.R[i] >= lo.R[i] * (1 - 1e-12)
            assert hi.O[i] >= lo.O[i] * (1 - 1e-12) - 1e-12
            # ... and the extra term is exactly the next value in sorted order (or nothing)
            ki, kj = min(k, len(q)), min(k + 1, len(q))
            extra_r = hi.R[i] * kj - lo.R[i] * ki
            extra_t = hi.O[i] * kj - lo.O[i] * ki
            if kj == ki:
                assert hi.R[i] == lo.R[i] and hi.O[i] == lo.O[i]
            else:
                assert extra_r == pytest.approx(sorted(rho)[ki], rel=1e-9, abs=1e-12)
                assert extra_t == pytest.approx(sorted(theta)[ki], rel=1e-9, abs=1e-9)


# ------------------------------------------------------------------ 4. R_i and O_i against a loop
@SETTINGS
@given(case=cases(), params=params_st)
def test_element_metrics_match_loop(case: Case, params: MetricParams) -> None:
    el = compute_metrics(case.obs, params).elements
    sum_R = sum_O = 0.0
    V = 0
    vr_total = 0
    for i in range(case.z_all):
        if not case.is_target[i]:
            continue
        q = qualifying(case, i, params.omega)
        assert el.VR[i] == len(q)
        assert bool(el.visible[i]) == (len(q) > 0)
        assert bool(el.observed[i]) == observed_oracle(case, i)
        frames_seen = sum(1 for rows in case.frames for e, _, _, _ in rows if e == i)
        pixels = sum(c * case.scale[f] for f in range(case.n) for e, c, _, _ in case.frames[f] if e == i)
        assert el.frames_observed[i] == frames_seen
        assert el.pixels_total[i] == pytest.approx(pixels)
        R = mean_k_smallest([r for r, _ in q], params.k)
        O = mean_k_smallest([t for _, t in q], params.k)
        assert_close_or_nan(el.R[i], R)
        assert_close_or_nan(el.O[i], O)
        if q:
            V += 1
            vr_total += len(q)
            sum_R += R
            sum_O += O
    p = compute_metrics(case.obs, params).plan
    if V:
        assert p.VR == pytest.approx(vr_total / V)
        assert p.R == pytest.approx(sum_R / V, rel=1e-9)
        assert p.O == pytest.approx(sum_O / V, rel=1e-9, abs=1e-12)


def test_pixel_scale_applies_before_omega() -> None:
    # 157 rendered px at scale 4 = 628 ≥ 625; 156 at scale 4 = 624 < 625; 40 at 16 = 640; 39 at 16 = 624
    frames = [
        _frame_obs([(0, 157, 10.0, 0.0), (1, 156, 10.0, 0.0)], [], 4.0, 1000.0),
        _frame_obs([(2, 40, 10.0, 0.0), (3, 39, 10.0, 0.0)], [], 16.0, 1000.0),
    ]
    obs = Observations.from_frames(frames, np.ones(4, bool), np.ones(4, bool), 0)
    el = compute_metrics(obs, DEFAULT).elements
    assert list(el.VR) == [1, 0, 1, 0]
    assert list(el.observed) == [True] * 4


# ------------------------------------------------------------------ 5. tracks
@SETTINGS
@given(case=cases(), params=params_st)
def test_tracks_match_loop(case: Case, params: MetricParams) -> None:
    m = compute_metrics(case.obs, params)
    nu = nu_oracle(case.features, params.min_track)
    assert list(m.frames.nu) == nu
    assert m.plan.T == pytest.approx(sum(nu) / case.n)
    assert list(m.frames.stable) == [v >= params.min_features for v in nu]
    assert m.plan.stable_share == pytest.approx(sum(v >= params.min_features for v in nu) / case.n)


@SETTINGS
@given(case=cases(min_frames=5, max_frames=8))
def test_tracks_default_params(case: Case) -> None:
    m = compute_metrics(case.obs, DEFAULT)
    nu = nu_oracle(case.features, 5)
    assert list(m.frames.nu) == nu
    assert not m.frames.stable.any()  # at most 30 features a frame, Λ = 50


# ------------------------------------------------------------------ 6. concatenate and save/load
def assert_metrics_equal(a, b) -> None:
    assert a.plan.to_dict() == b.plan.to_dict()
    for name in ("is_target", "VR", "visible", "observed", "R", "O", "pixels_total", "frames_observed"):
        np.testing.assert_array_equal(getattr(a.elements, name), getattr(b.elements, name), err_msg=name)
    for name in ("nu", "stable", "features_observed", "elements_visible", "pixels_on_targets"):
        np.testing.assert_array_equal(getattr(a.frames, name), getattr(b.frames, name), err_msg=name)


@SETTINGS
@given(case=cases(), params=params_st, data=st.data())
def test_concatenate_split_equals_whole(case: Case, params: MetricParams, data) -> None:
    cuts = sorted(data.draw(st.lists(st.integers(0, case.n), max_size=3)))
    bounds = [0, *cuts, case.n]
    parts = [case.obs.select_frames(np.arange(lo, hi)) for lo, hi in zip(bounds[:-1], bounds[1:])]
    merged = Observations.concatenate(parts)
    assert merged.n_frames == case.n
    for name in ("frame", "element", "count", "depth_mean", "angle_mean", "pixel_scale", "sampling_focal_px",
                 "feature_frame", "feature_id"):
        np.testing.assert_array_equal(getattr(merged, name), getattr(case.obs, name), err_msg=name)
    assert_metrics_equal(compute_metrics(merged, params), compute_metrics(case.obs, params))


@SETTINGS
@given(case=cases(), params=params_st)
def test_save_load_round_trip(case: Case, params: MetricParams) -> None:
    with tempfile.TemporaryDirectory() as tmp:
        path = Path(tmp) / "obs.npz"
        case.obs.save(path)
        loaded = Observations.load(path)
    assert loaded.n_frames == case.obs.n_frames
    assert loaded.n_features == case.obs.n_features
    np.testing.assert_array_equal(loaded.present, case.obs.present)
    assert_metrics_equal(compute_metrics(loaded, params), compute_metrics(case.obs, params))
