"""The metrics of a plan as it may be flown: draws of the plan under the aircraft's pose error.

Each draw moves and turns every frame independently by a normal error (:class:`~sightplan.plan.perturb.PoseError`:
the ``h, v`` metres of the flight checks' position error read as 95 % bounds, and a heading error). The perturbed
frames are cast in one pass of the ordinary engine path (:func:`~sightplan.evaluate.observe_plan`, without the
per-frame cache: perturbed poses would never be asked for again), and each draw's metrics are computed from its
own Observations only; :mod:`sightplan.metrics.robustness` summarises them.

**Pool.** Casting dominates the cost, so the draws may share cast frames: ``pool`` K perturbed poses are cast per
planned frame, and each of the N draws takes, for every frame, one of that frame's K poses (each pose by N/K
draws, in independent random orders per frame). Each draw is still an exact sample of the error: its frames are
independent of each other and each is a normal draw of its pose. What is shared is between draws, so the draws are
not independent of each other: the mean over N draws is as precise as about K independent draws for a metric
that adds over frames, and a rare event (a frame too close) is estimated from K·n distinct poses, not N·n.
``pool = draws`` (``--pool N``) casts N independent draws. The default pool is min(N, :data:`DEFAULT_POOL`).

**Safety.** Beside the metrics: in how many draws at least one frame comes closer to the model than the safety
distance (the plan's recorded one, :func:`~sightplan.plan.checks.gate.recorded_settings`, else the
``sightplan check`` default), by the exact point distance of the flight checks, and the share of all the draws'
frames that do.
"""

from __future__ import annotations

import csv
import json
import time
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path

import numpy as np
from numpy.typing import NDArray

from .errors import SightplanError
from .evaluate import Evaluation, EvaluationSettings, evaluate, observe_plan
from .metrics import compute_metrics
from .metrics.plan import PlanMetrics
from .metrics.robustness import SPREAD_METRICS, DrawSummary, summarize_draws
from .model.scene import Scene
from .observations.features import FeatureSet
from .plan.checks.gate import recorded_settings
from .plan.checks.safety import CHECK_TOLERANCE_M, point_distances
from .plan.perturb import PoseError, perturbed_plan
from .plan.types import Plan

DEFAULT_POOL = 16  # perturbed poses cast per frame unless told: 64 draws cost about 16 evaluations, not 64
MAX_DRAWS = 100_000

#: how the files and tables name the plan metrics: (key, factor) — VC, V̄C and the stable share in %, as report.json
REPORT_KEYS = {"n_visible": ("visible", 1.0), "VC": ("VC_pct", 100.0), "VC_bar": ("VC_bar_pct", 100.0),
               "VR": ("VR", 1.0), "R": ("R_m_per_px", 1.0), "O": ("O_deg", 1.0), "T": ("T", 1.0),
               "stable_share": ("stable_frames_pct", 100.0)}


@dataclass(frozen=True)
class SafetySpread:
    """minimum_m: the safety distance; nominal_least_m: the planned frames' least distance to the model;
    least_m: (draws,) each draw's least frame distance; too_close: (draws,) frames of each draw closer than the
    minimum (less the checks' 1 mm tolerance)."""

    minimum_m: float
    nominal_least_m: float
    least_m: NDArray[np.float64]
    too_close: NDArray[np.int64]
    frames: int

    @property
    def draw_share(self) -> float:
        """Share of the draws with at least one frame too close."""
        return float((self.too_close > 0).mean())

    @property
    def frame_share(self) -> float:
        """Share of all the draws' frames that are too close."""
        return float(self.too_close.sum() / max(1, len(self.too_close) * self.frames))


@dataclass(frozen=True)
class RobustnessResult:
    """The plan as planned (``nominal``) and ``draws`` draws under ``error``; ``pool`` poses cast per frame;
    ``draw_metrics``: each draw's plan metrics; ``summary``: their spread; ``timings``: seconds (wall ``*_s``,
    processor ``cpu_*_s``)."""

    error: PoseError
    draws: int
    pool: int
    seed: int
    nominal: Evaluation
    draw_metrics: tuple[PlanMetrics, ...]
    summary: DrawSummary
    safety: SafetySpread
    timings: dict


def check_draws(draws: int, pool: int | None) -> int:
    """The pool for ``draws`` draws (default min(draws, :data:`DEFAULT_POOL`)); a SightplanError names a bad value."""
    if not 1 <= draws <= MAX_DRAWS:
        raise SightplanError(f"the number of draws must be 1 to {MAX_DRAWS:,}, got {draws:,}")
    if pool is None:
        return min(draws, DEFAULT_POOL)
    if not 1 <= pool <= draws:
        raise SightplanError(f"the pool of perturbed poses per frame must be 1 to the number of draws ({draws:,}), "
                             f"got {pool:,}")
    return pool


def draw_picks(draws: int, pool: int, n_frames: int, rng: np.random.Generator) -> NDArray[np.int64]:
    """(draws, n_frames) which of its ``pool`` samples each frame takes in each draw: per frame, random
    permutations of 0..pool−1 one after the other, so every sample serves draws/pool draws (±1) and, within a
    draw, the frames' picks are independent and uniform."""
    blocks = -(-draws // pool)
    order = np.argsort(rng.random((blocks, pool, n_frames)), axis=1)
    return order.reshape(blocks * pool, n_frames)[:draws].astype(np.int64)


def evaluate_under_error(
    scene: Scene,
    plan: Plan,
    settings: EvaluationSettings | None = None,
    error: PoseError | str | tuple = "gnss",
    draws: int = 64,
    seed: int = 0,
    *,
    pool: int | None = None,
    nominal: Evaluation | None = None,
    features: FeatureSet | None = None,
    cache_dir: str | Path | None | bool = None,
    safety_distance_m: float | None = None,
    progress: Callable[[int, int], None] | None = None,
) -> RobustnessResult:
    """Evaluate ``plan`` as planned and in ``draws`` draws under the pose ``error`` (see the module docstring).

    nominal: the plan's evaluation when already made (with these settings); otherwise it is made here, through
    the per-frame cache ``cache_dir`` (as :func:`~sightplan.evaluate.evaluate`). seed: the draws' generator seed.
    progress(done, total): perturbed frames cast.
    """
    settings = settings or (nominal.settings if nominal is not None else EvaluationSettings())
    if nominal is not None and nominal.settings != settings:
        raise SightplanError("the nominal evaluation was made with other settings than the draws")
    error = PoseError.parse(error)
    pool = check_draws(int(draws), pool)
    if int(seed) < 0:
        raise SightplanError(f"the seed of the draws must be ≥ 0, got {seed}")
    minimum = recorded_settings(plan).safety_distance_m if safety_distance_m is None else float(safety_distance_m)
    if not minimum > 0:
        raise SightplanError(f"the safety distance must be positive, got {minimum}")
    timings: dict[str, float] = {}
    wall, cpu = time.perf_counter(), time.process_time()
    if nominal is None:
        nominal = evaluate(scene, plan, settings, features=features, cache_dir=cache_dir)
        timings["nominal_s"], timings["cpu_nominal_s"] = time.perf_counter() - wall, time.process_time() - cpu
    n = len(plan)
    rng = np.random.default_rng(int(seed))
    cast_plan = perturbed_plan(plan, error, pool, rng)
    picks = draw_picks(int(draws), pool, n, rng)
    wall, cpu = time.perf_counter(), time.process_time()
    obs, _, cast_timings = observe_plan(scene, cast_plan, settings, features, cache=None, progress=progress,
                                       feature_cache=cache_dir is not False)
    timings["cast_s"], timings["cpu_cast_s"] = time.perf_counter() - wall, time.process_time() - cpu
    timings["frames_cast"] = cast_timings["frames_cast"]
    wall, cpu = time.perf_counter(), time.process_time()
    rows = picks * n + np.arange(n)  # draw d's frames in the cast table
    per_draw = [compute_metrics(obs.take_frames(r), settings.metric) for r in rows]
    summary = summarize_draws(nominal.metrics, per_draw)
    timings["metrics_s"], timings["cpu_metrics_s"] = time.perf_counter() - wall, time.process_time() - cpu
    wall, cpu = time.perf_counter(), time.process_time()
    d = point_distances(scene, cast_plan.C_world)[rows]
    too_close = (d < minimum - CHECK_TOLERANCE_M).sum(axis=1).astype(np.int64)
    safety = SafetySpread(minimum, float(point_distances(scene, plan.C_world).min()), d.min(axis=1), too_close, n)
    timings["safety_s"], timings["cpu_safety_s"] = time.perf_counter() - wall, time.process_time() - cpu
    return RobustnessResult(error, int(draws), pool, int(seed), nominal, tuple(m.plan for m in per_draw), summary,
                            safety, timings)


# ----------------------------------------------------------------------- files
def _number(x: float | None) -> float | None:
    return None if x is None or not np.isfinite(x) else float(x)


def robustness_dict(result: RobustnessResult) -> dict:
    """robustness.json: the error, the draws, each plan metric's spread (VC, V̄C and the stable share in %), the
    safety shares and the timings."""
    s = result.safety
    return {
        "format": "sightplan-robustness", "version": 1,
        "error": result.error.to_dict(), "draws": result.draws, "pool": result.pool, "seed": result.seed,
        "frames": s.frames, "engine": result.nominal.engine, "scale": result.nominal.settings.scale,
        "metrics": {REPORT_KEYS[k][0]: result.summary.plan[k].to_dict(REPORT_KEYS[k][1]) for k in SPREAD_METRICS},
        "safety": {"minimum_m": s.minimum_m, "nominal_least_m": _number(s.nominal_least_m),
                   "least_m_mean": _number(float(s.least_m.mean())), "least_m_min": _number(float(s.least_m.min())),
                   "draws_too_close_pct": 100 * s.draw_share, "frames_too_close_pct": 100 * s.frame_share},
        "timings": {k: _number(v) for k, v in result.timings.items()},
    }


def element_spread_rows(result: RobustnessResult, scene: Scene) -> list[dict]:
    """One row per target element: VR_i as planned, its mean, p5 and p95 over the draws, and the share of draws
    in which the element is visible."""
    es, el = result.summary.elements, scene.elements
    return [{"index": int(i), "global_id": el.global_id[i], "name": el.name[i], "ifc_class": el.ifc_class[i],
             "VR_i": int(es.VR_nominal[i]), "VR_i_mean": round(float(es.VR_mean[i]), 4),
             "VR_i_p5": round(float(es.VR_p5[i]), 4), "VR_i_p95": round(float(es.VR_p95[i]), 4),
             "visible_draws_pct": round(100 * float(es.visible_share[i]), 2)}
            for i in np.flatnonzero(result.nominal.metrics.elements.is_target)]


def draw_rows(result: RobustnessResult) -> list[dict]:
    """One row per draw: its plan metrics, its frames too close and its least frame distance."""
    rows = []
    for d, p in enumerate(result.draw_metrics):
        row: dict = {"draw": d}
        for k in SPREAD_METRICS:
            v = getattr(p, k)
            row[REPORT_KEYS[k][0]] = "" if v is None else f"{v * REPORT_KEYS[k][1]:.6g}"
        row["frames_too_close"] = int(result.safety.too_close[d])
        row["least_distance_m"] = f"{result.safety.least_m[d]:.4f}"
        rows.append(row)
    return rows


def _write_csv(rows: list[dict], path: Path) -> None:
    with open(path, "w", newline="", encoding="utf-8") as fh:
        if rows:
            w = csv.DictWriter(fh, fieldnames=list(rows[0]))
            w.writeheader()
            w.writerows(rows)


def write_robustness(result: RobustnessResult, scene: Scene, out_dir: str | Path) -> dict[str, Path]:
    """Write robustness.json, robustness_elements.csv and robustness_draws.csv into ``out_dir``; their paths."""
    out = Path(out_dir)
    out.mkdir(parents=True, exist_ok=True)
    paths = {"robustness": out / "robustness.json", "robustness_elements": out / "robustness_elements.csv",
             "robustness_draws": out / "robustness_draws.csv"}
    paths["robustness"].write_text(json.dumps(robustness_dict(result), indent=2, allow_nan=False) + "\n",
                                   encoding="utf-8")
    _write_csv(element_spread_rows(result, scene), paths["robustness_elements"])
    _write_csv(draw_rows(result), paths["robustness_draws"])
    return paths
