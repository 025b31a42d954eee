"""Plan metrics against arithmetic done by hand from METRICS.md §2–5.

Observations are written out frame by frame with chosen numbers; every expected value
below is spelled out as arithmetic on those numbers.
"""

from __future__ import annotations

import math

import numpy as np
import pytest

from sightplan.camera.models import PinholeCamera
from sightplan.engines import make_engine
from sightplan.engines.registry import available_engines
from sightplan.metrics import MetricParams, compute_metrics
from sightplan.model.scene import ElementTable, Scene
from sightplan.observations.table import FrameObservation, Observations


def frame(rows, features=(), pixel_scale=1.0, focal=1000.0) -> FrameObservation:
    """rows: list of (element, count, depth_mean, angle_mean)."""
    rows = sorted(rows)
    return FrameObservation(
        element=np.array([r[0] for r in rows], np.int32),
        count=np.array([r[1] for r in rows], np.int64),
        depth_mean=np.array([r[2] for r in rows], np.float64),
        angle_mean=np.array([r[3] for r in rows], np.float64),
        features=np.array(sorted(features), np.int32),
        pixel_scale=float(pixel_scale),
        sampling_focal_px=float(focal),
    )


# Elements: 0..3 targets, 4 an occluder (is_target False), 5 a target never seen.
IS_TARGET = np.array([True, True, True, True, False, True])
PRESENT = np.ones(6, bool)

FRAMES = [
    # f0: f_px 1000
    frame([(0, 1000, 10.0, 5.0), (1, 700, 20.0, 40.0), (2, 300, 8.0, 10.0), (4, 5000, 5.0, 0.0)], focal=1000.0),
    # f1: f_px 2000; element 1 has 624 px, one short of Ω
    frame([(0, 800, 30.0, 20.0), (1, 624, 10.0, 1.0)], focal=2000.0),
    # f2: rendered at scale ½ (4 full-resolution pixels per rendered pixel)
    frame([(0, 200, 15.0, 30.0), (2, 156, 5.0, 0.0), (3, 1, 7.0, 0.0)], pixel_scale=4.0, focal=1000.0),
    # f3: f_px 500; element 0 exactly at Ω
    frame([(0, 625, 2.0, 60.0), (1, 2000, 50.0, 3.0)], focal=500.0),
    # f4: only the occluder, far above Ω
    frame([(4, 10000, 1.0, 0.0)], focal=1000.0),
]


@pytest.fixture
def metrics():
    obs = Observations.from_frames(FRAMES, IS_TARGET, PRESENT, n_features=0)
    return compute_metrics(obs, MetricParams(omega=625.0, k=3, min_track=5, min_features=50))


def test_per_element_by_hand(metrics):
    el = metrics.elements
    # element 0: |γ| ≥ Ω in f0 (1000), f1 (800), f2 (200·4 = 800 — only after the pixel-scale conversion),
    # f3 (625 = Ω, counts). ρ = d̄/f: f0 10/1000 = 0.01, f1 30/2000 = 0.015, f2 15/1000 = 0.015, f3 2/500 = 0.004
    # θ̄: 5, 20, 30, 60. k_0 = min(3, 4) = 3.
    # element 1: f0 700 ≥ Ω (ρ 20/1000 = 0.02, θ 40); f1 624 < Ω; f3 2000 (ρ 50/500 = 0.1, θ 3). k_1 = min(3, 2) = 2
    # element 2: f0 300 < Ω, f2 156·4 = 624 < Ω → observed, not visible
    # element 3: f2 1 px → observed, not visible
    # element 4 (occluder): f0 5000, f4 10000 → excluded from plan metrics (its per-element VR is not
    # part of the contract: it is not one of the z elements)
    # element 5: never seen
    assert list(el.VR[IS_TARGET]) == [4, 2, 0, 0, 0]
    assert list(el.visible[IS_TARGET]) == [True, True, False, False, False]
    assert list(el.observed[IS_TARGET]) == [True, True, True, True, False]
    expected_R0 = (0.004 + 0.01 + 0.015) / 3  # the three smallest ρ: f3, f0, f1 or f2
    expected_O0 = (5.0 + 20.0 + 30.0) / 3  # the three smallest θ̄: f0, f1, f2 (R_0 used f3; O_0 does not)
    expected_R1 = (0.02 + 0.1) / 2  # k_1 = 2 < k
    expected_O1 = (40.0 + 3.0) / 2
    assert el.R[0] == pytest.approx(expected_R0)
    assert el.O[0] == pytest.approx(expected_O0)
    assert el.R[1] == pytest.approx(expected_R1)
    assert el.O[1] == pytest.approx(expected_O1)
    for i in (2, 3, 5):
        assert math.isnan(el.R[i]) and math.isnan(el.O[i])
    # pixels in full-resolution pixels
    assert el.pixels_total[0] == pytest.approx(1000 + 800 + 200 * 4 + 625)
    assert el.pixels_total[2] == pytest.approx(300 + 156 * 4)
    assert el.pixels_total[3] == pytest.approx(1 * 4)
    assert list(el.frames_observed[IS_TARGET]) == [4, 3, 2, 1, 0]
    assert list(el.is_target) == list(IS_TARGET)


def test_plan_by_hand(metrics):
    p = metrics.plan
    z = 5  # targets 0, 1, 2, 3, 5 (the occluder 4 is left out)
    V = 2  # elements 0 and 1
    n_observed = 4  # elements 0, 1, 2, 3
    assert (p.z, p.n_visible, p.n_observed, p.n_frames) == (z, V, n_observed, 5)
    assert p.VC == pytest.approx(V / z)  # 0.4
    assert p.VC_bar == pytest.approx(V / n_observed)  # 0.5
    assert p.VR == pytest.approx((4 + 2) / V)  # 3.0
    R0 = (0.004 + 0.01 + 0.015) / 3
    R1 = (0.02 + 0.1) / 2
    O0 = (5.0 + 20.0 + 30.0) / 3
    O1 = (40.0 + 3.0) / 2
    assert p.R == pytest.approx((R0 + R1) / V)
    assert p.O == pytest.approx((O0 + O1) / V)
    assert p.T == pytest.approx(0.0)  # frames exist, no feature observed anywhere


def test_frames_by_hand(metrics):
    fr = metrics.frames
    # elements_visible: target elements with |γ| ≥ Ω per frame
    assert list(fr.elements_visible) == [2, 1, 1, 2, 0]
    # pixels on targets, full resolution
    assert fr.pixels_on_targets[0] == pytest.approx(1000 + 700 + 300)
    assert fr.pixels_on_targets[2] == pytest.approx((200 + 156 + 1) * 4)
    assert fr.pixels_on_targets[4] == pytest.approx(0)


def test_k_equal_one_and_large_k():
    obs = Observations.from_frames(FRAMES, IS_TARGET, PRESENT, n_features=0)
    m1 = compute_metrics(obs, MetricParams(omega=625.0, k=1))
    assert m1.elements.R[0] == pytest.approx(0.004)  # the single best ρ: f3
    assert m1.elements.O[0] == pytest.approx(5.0)  # the single best θ̄: f0
    assert m1.elements.R[1] == pytest.approx(0.02)
    assert m1.elements.O[1] == pytest.approx(3.0)
    m9 = compute_metrics(obs, MetricParams(omega=625.0, k=9))
    assert m9.elements.R[0] == pytest.approx((0.01 + 0.015 + 0.015 + 0.004) / 4)
    assert m9.elements.O[0] == pytest.approx((5 + 20 + 30 + 60) / 4)


def test_omega_changes_visibility():
    obs = Observations.from_frames(FRAMES, IS_TARGET, PRESENT, n_features=0)
    # Ω = 624: element 1 in f1 (624) and element 2 in f2 (156·4 = 624) now count; element 2 in f0 (300) does not
    m = compute_metrics(obs, MetricParams(omega=624.0))
    assert list(m.elements.VR[IS_TARGET]) == [4, 3, 1, 0, 0]
    assert m.plan.VC == pytest.approx(3 / 5)
    assert m.plan.VC_bar == pytest.approx(3 / 4)
    assert m.plan.VR == pytest.approx((4 + 3 + 1) / 3)
    R1 = (0.02 + 10.0 / 2000 + 0.1) / 3  # ρ f0 0.02, f1 0.005, f3 0.1
    R2 = 5.0 / 1000
    R0 = (0.004 + 0.01 + 0.015) / 3
    assert m.elements.R[1] == pytest.approx(R1)
    assert m.elements.O[1] == pytest.approx((40 + 1 + 3) / 3)
    assert m.plan.R == pytest.approx((R0 + R1 + R2) / 3)
    assert m.plan.O == pytest.approx(((5 + 20 + 30) / 3 + (40 + 1 + 3) / 3 + 0.0) / 3)
    # Ω = 1001: only element 1 in f3 (2000) remains among targets
    m = compute_metrics(obs, MetricParams(omega=1001.0))
    assert list(m.elements.VR[IS_TARGET]) == [0, 1, 0, 0, 0]
    assert m.plan.R == pytest.approx(0.1)
    assert m.plan.O == pytest.approx(3.0)


def test_no_visible_element():
    frames = [frame([(0, 10, 5.0, 1.0)]), frame([(4, 5000, 5.0, 1.0)])]
    obs = Observations.from_frames(frames, IS_TARGET, PRESENT, n_features=0)
    p = compute_metrics(obs, MetricParams()).plan
    assert p.n_visible == 0 and p.n_observed == 1
    assert p.VC == 0.0
    assert p.VC_bar == 0.0  # 0 visible / 1 observed
    assert p.VR is None and p.R is None and p.O is None


def test_nothing_observed():
    frames = [frame([(4, 5000, 5.0, 1.0)]), frame([])]  # only the occluder is seen
    obs = Observations.from_frames(frames, IS_TARGET, PRESENT, n_features=0)
    p = compute_metrics(obs, MetricParams()).plan
    assert p.VC == 0.0
    assert p.VC_bar is None
    assert p.VR is None and p.R is None and p.O is None
    assert p.T == 0.0
    assert p.stable_share == 0.0


def test_zero_frames():
    obs = Observations.from_frames([], IS_TARGET, PRESENT, n_features=0)
    p = compute_metrics(obs, MetricParams()).plan
    assert p.n_frames == 0
    assert p.T is None
    assert p.stable_share is None
    assert p.VC == 0.0
    assert p.VC_bar is None


def test_no_target_elements():
    obs = Observations.from_frames([frame([(0, 5000, 5.0, 1.0)])], np.array([False]), np.array([True]), 0)
    p = compute_metrics(obs, MetricParams()).plan
    assert p.z == 0
    assert p.VC is None


# --------------------------------------------------------------------------- stability (§5)
def feature_frames(tracks: dict[int, list[int]], n_frames: int, split: int | None = None):
    """FrameObservations in which feature u is observed in the frames tracks[u]."""
    frames = []
    for f in range(n_frames):
        feats = [u for u, fs in tracks.items() if f in fs]
        frames.append(frame([(0, 1000, 10.0, 0.0)], features=feats))
    return frames


TRACKS = {
    0: [0, 1, 2, 4, 5, 6, 7, 8],  # run 0..2 (3, too short), run 4..8 (5 = Y): stable in 4..8 only
    1: list(range(9)),  # stable in every frame
    2: [3, 4, 5, 6],  # run of 4 < Y: never stable
    3: [1, 2, 3, 4, 5],  # run of exactly 5: stable in 1..5
    4: [0, 2, 4, 6, 8],  # never two consecutive frames
}
# ν_f by hand:       f0  f1  f2  f3  f4  f5  f6  f7  f8
EXPECTED_NU = [1, 2, 2, 2, 3, 3, 2, 2, 2]
#   f0: {1}; f1–f3: {1, 3}; f4, f5: {0, 1, 3}; f6–f8: {0, 1}


def test_stability_by_hand():
    frames = feature_frames(TRACKS, 9)
    obs = Observations.from_frames(frames, np.array([True]), np.array([True]), n_features=5)
    m = compute_metrics(obs, MetricParams(omega=625.0, min_track=5, min_features=3))
    assert list(m.frames.nu) == EXPECTED_NU
    assert m.plan.T == pytest.approx((1 + 2 + 2 + 2 + 3 + 3 + 2 + 2 + 2) / 9)  # 19 / 9
    # Λ = 3: only f4 and f5 are stable
    assert list(m.frames.stable) == [False] * 4 + [True, True] + [False] * 3
    assert m.plan.stable_share == pytest.approx(2 / 9)
    # features observed per frame (stable or not)
    assert list(m.frames.features_observed) == [3, 3, 4, 3, 5, 4, 4, 2, 3]
    # Λ = 2: every frame but f0
    m2 = compute_metrics(obs, MetricParams(omega=625.0, min_track=5, min_features=2))
    assert m2.plan.stable_share == pytest.approx(8 / 9)
    # Y = 3: feature 0 also stable in 0..2, feature 2 in 3..6
    m3 = compute_metrics(obs, MetricParams(omega=625.0, min_track=3, min_features=50))
    nu3 = [2, 3, 3, 3, 4, 4, 3, 2, 2]
    #   f0 {0,1}; f1 {0,1,3}; f2 {0,1,3}; f3 {1,2,3}; f4 {0,1,2,3}; f5 {0,1,2,3}; f6 {0,1,2}; f7 {0,1}; f8 {0,1}
    assert list(m3.frames.nu) == nu3
    assert m3.plan.T == pytest.approx(sum(nu3) / 9)
    assert m3.plan.stable_share == pytest.approx(0.0)
    # Y = 1: every observation is stable: ν_f = features observed
    m1 = compute_metrics(obs, MetricParams(omega=625.0, min_track=1, min_features=50))
    assert list(m1.frames.nu) == [3, 3, 4, 3, 5, 4, 4, 2, 3]


def test_tracks_cross_mission_boundaries():
    """Plan order is the concatenation of missions: a run that spans the boundary is one run."""
    tracks = {0: [1, 2, 3, 4, 5], 1: [0, 1, 2], 2: [3, 4, 5, 6]}
    frames = feature_frames(tracks, 7)
    is_t, pres = np.array([True]), np.array([True])
    # mission A = frames 0..2, mission B = frames 3..6
    a = Observations.from_frames(frames[:3], is_t, pres, n_features=3)
    b = Observations.from_frames(frames[3:], is_t, pres, n_features=3)
    params = MetricParams(omega=625.0, min_track=5, min_features=1)
    for obs in (Observations.concatenate([a, b]), Observations.from_frames(frames, is_t, pres, n_features=3)):
        m = compute_metrics(obs, params)
        # only feature 0 (frames 1..5, crossing the boundary) has a run of 5
        assert list(m.frames.nu) == [0, 1, 1, 1, 1, 1, 0]
        assert m.plan.T == pytest.approx(5 / 7)
        assert m.plan.stable_share == pytest.approx(5 / 7)
    # each mission alone has no run of 5
    assert compute_metrics(a, params).plan.T == 0.0
    assert compute_metrics(b, params).plan.T == 0.0


def test_stability_with_gap_frame_without_features():
    """A frame that sees no feature at all breaks every run."""
    seen = [0, 1, 2, 3, 4, 6, 7, 8, 9, 10]  # frame 5 sees nothing
    frames = feature_frames({0: seen, 1: seen}, 11)
    obs = Observations.from_frames(frames, np.array([True]), np.array([True]), n_features=2)
    m = compute_metrics(obs, MetricParams(min_track=5, min_features=50))
    assert list(m.frames.nu) == [2, 2, 2, 2, 2, 0, 2, 2, 2, 2, 2]
    assert m.plan.T == pytest.approx(20 / 11)
    m6 = compute_metrics(obs, MetricParams(min_track=6, min_features=50))
    assert m6.plan.T == 0.0  # both runs are 5 long


# --------------------------------------------------------------------------- end to end
R_NORTH = np.array([[1.0, 0.0, 0.0], [0.0, 0.0, 1.0], [0.0, -1.0, 0.0]])
CAM = PinholeCamera(160, 120, 100.0, 100.0, 80.0, 60.0)


def wall(y, x0, x1, z0, z1):
    v = np.array([[x0, y, z0], [x1, y, z0], [x1, y, z1], [x0, y, z1]], float)
    return v, np.array([[0, 1, 2], [0, 2, 3]])


def count_and_mean_distance(C, y, x0, x1, z0, z1, occluders=()):
    """Pixels of a y = const wall seen by CAM looking north from C; occluders are (y, x0, x1, z0, z1) nearer."""
    u = np.arange(CAM.width) + 0.5
    v = np.arange(CAM.height) + 0.5
    dx, dz = np.meshgrid((u - CAM.cx) / CAM.fx, -(v - CAM.cy) / CAM.fy)

    def hits(y_, a0, a1, b0, b1):
        t = y_ - C[1]
        X, Z = C[0] + t * dx, C[2] + t * dz
        return (X >= a0) & (X <= a1) & (Z >= b0) & (Z <= b1)

    m = hits(y, x0, x1, z0, z1)
    for o in occluders:
        m &= ~hits(*o)
    t = y - C[1]
    dist = t * np.sqrt(dx**2 + dz**2 + 1)
    return int(m.sum()), float(dist[m].mean()) if m.any() else math.nan


@pytest.mark.parametrize("engine", [pytest.param(e, marks=pytest.mark.skipif(e not in available_engines(), reason=e))
                                    for e in ("embree", "trimesh")])
def test_end_to_end(engine):
    # walls (element: y, x0, x1, z0, z1); element 3 is an occluder in front of wall 0
    walls = {
        0: (10.0, -6.03, -2.02, -1.51, 1.53),
        1: (10.0, -0.97, 0.98, -0.49, 0.52),
        2: (12.0, 2.03, 6.04, -3.51, 3.48),
        3: (6.0, -3.13, -2.04, -0.73, 0.26),
    }
    vs, fs, fe = [], [], []
    for e, w in walls.items():
        v, f = wall(*w)
        fs.append(f + 4 * len(vs))
        vs.append(v)
        fe += [e, e]
    els = ElementTable.build(["A", "B", "C", "OCC"], is_target=[True, True, True, False])
    scene = Scene.from_arrays(np.concatenate(vs), np.concatenate(fs), np.array(fe), els)
    poses = [np.array([0.0, 0.0, 0.0]), np.array([1.0, -10.0, 0.3])]
    eng = make_engine(engine, scene)
    fos = [eng.observe(CAM, R_NORTH, C) for C in poses]
    obs = Observations.from_frames(fos, scene.targets, scene.present, n_features=0)
    omega = 250.0  # wall 0 has 912 and 258 px, wall 1 200 and 50, wall 2 1914 and 558
    m = compute_metrics(obs, MetricParams(omega=omega, k=3))

    exp = {}
    for f, C in enumerate(poses):
        for e in (0, 1, 2):
            occ = [walls[3]] if e == 0 else []
            exp[e, f] = count_and_mean_distance(C, *walls[e], occluders=occ)
    # the engine must see exactly these counts
    for f in range(2):
        for e in (0, 1, 2):
            idx = np.flatnonzero(fos[f].element == e)
            got = int(fos[f].count[idx[0]]) if len(idx) else 0
            assert got == exp[e, f][0], (e, f)
    # by hand: VR_i counts frames with ≥ Ω; R_i = mean of the k_i smallest d̄/f (f = 100 px)
    VR = {e: sum(exp[e, f][0] >= omega for f in range(2)) for e in (0, 1, 2)}
    visible = [e for e in (0, 1, 2) if VR[e] > 0]
    observed = [e for e in (0, 1, 2) if any(exp[e, f][0] >= 1 for f in range(2))]
    Ri = {e: np.mean([exp[e, f][1] / 100.0 for f in range(2) if exp[e, f][0] >= omega]) for e in visible}
    # sanity of the chosen geometry: wall 1 is small (≈ 20 × 10 px at 10 m) so it is observed but not visible
    assert VR == {0: 2, 1: 0, 2: 2} and observed == [0, 1, 2]
    assert m.plan.z == 3
    assert m.plan.VC == pytest.approx(len(visible) / 3)
    assert m.plan.VC_bar == pytest.approx(len(visible) / len(observed))
    assert m.plan.VR == pytest.approx(sum(VR.values()) / len(visible))
    assert m.plan.R == pytest.approx(sum(Ri.values()) / len(visible), rel=1e-6)
    assert m.plan.O == pytest.approx(0.0, abs=1e-3)  # head-on walls, on-axis camera
    assert not m.elements.is_target[3]
