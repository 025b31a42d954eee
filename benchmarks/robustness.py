"""Metrics under position error: what the draws of ``evaluate --position-error`` cost beside one evaluation.

    python benchmarks/robustness.py [--draws 64] [--pools 16 64] [--error gnss] [--scale 0.25]

The plan is the README's demo: the Duplex sample's facade plan as ``sightplan plan facade sample --safety-distance 8
--overlap 0.8`` makes it (plan_from_template with the command's flight settings), evaluated at resolution scale
0.25. Each pool runs in a fresh process: it loads the model, evaluates the plan once untimed (the features' cache
and the kernels' compilation), then times one evaluation (every frame cast, no frame cache) and the draws
(:func:`sightplan.robustness.evaluate_under_error` with that evaluation as the nominal: the perturbed frames cast,
each draw's metrics, the safety distances). Reported: the draws' processor time (all threads) and its ratio to the
evaluation's, wall times, the process's resident memory before the draws and at its peak, and each plan metric as
planned and over the draws (mean, p5, p95). A pool equal to the draws casts independent draws.

Writes benchmarks/robustness.json.
"""

from __future__ import annotations

import argparse
import json
import platform
import resource
import subprocess
import sys
import time
from pathlib import Path

HERE = Path(__file__).resolve().parent


def rss_mb() -> float:
    with open("/proc/self/status") as fh:
        for line in fh:
            if line.startswith("VmRSS:"):
                return int(line.split()[1]) / 1024
    return float("nan")


def one(draws: int, pool: int, error: str, scale: float, seed: int) -> dict:
    from sightplan.camera.catalogue import get_camera
    from sightplan.cli.flight import default_flight_settings
    from sightplan.evaluate import EvaluationSettings, evaluate
    from sightplan.model.load import load_model
    from sightplan.plan.templates.registry import plan_from_template
    from sightplan.robustness import REPORT_KEYS, evaluate_under_error

    scene, _ = load_model("sample")
    flight = default_flight_settings(False, 8.0, 500.0, None, None, 120.0, scene=scene)
    plan, _ = plan_from_template("facade", scene, get_camera("p4p"), {"overlap": 0.8}, flight)
    settings = EvaluationSettings(scale=scale)
    evaluate(scene, plan, settings, cache_dir=False)  # untimed: features cached, kernels compiled
    wall, cpu = time.perf_counter(), time.process_time()
    ev = evaluate(scene, plan, settings, cache_dir=False)
    eval_wall, eval_cpu = time.perf_counter() - wall, time.process_time() - cpu
    rss_before = rss_mb()
    wall, cpu = time.perf_counter(), time.process_time()
    r = evaluate_under_error(scene, plan, settings, error, draws, seed, pool=pool, nominal=ev)
    draws_wall, draws_cpu = time.perf_counter() - wall, time.process_time() - cpu
    metrics = {}
    for key, s in r.summary.plan.items():
        name, factor = REPORT_KEYS[key]
        metrics[name] = {k: None if v is None else round(v, 6) for k, v in s.to_dict(factor).items()}
    return {
        "model": "Duplex (sample)", "triangles": int(len(scene.faces)), "targets": int(scene.targets.sum()),
        "frames": len(plan), "missions": len(plan.missions), "scale": scale, "engine": ev.engine,
        "error": r.error.to_dict(), "draws": draws, "pool": r.pool, "seed": seed,
        "frames_cast": r.timings["frames_cast"],
        "evaluation_cpu_s": round(eval_cpu, 2), "evaluation_wall_s": round(eval_wall, 2),
        "draws_cpu_s": round(draws_cpu, 2), "draws_wall_s": round(draws_wall, 2),
        "cpu_ratio": round(draws_cpu / eval_cpu, 2), "wall_ratio": round(draws_wall / eval_wall, 2),
        "parts_s": {k: round(v, 2) for k, v in r.timings.items() if k.endswith("_s")},
        "rss_before_draws_mb": round(rss_before), "peak_rss_mb": round(resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024),
        "safety": {"minimum_m": r.safety.minimum_m, "nominal_least_m": round(r.safety.nominal_least_m, 3),
                   "draws_too_close_pct": round(100 * r.safety.draw_share, 2),
                   "frames_too_close_pct": round(100 * r.safety.frame_share, 3)},
        "metrics": metrics,
    }


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--draws", type=int, default=64)
    ap.add_argument("--pools", type=int, nargs="+", default=[16, 64], help="poses cast per frame, one run each")
    ap.add_argument("--error", default="gnss", help="the position error (default gnss: ±1.5 m, ±0.5 m)")
    ap.add_argument("--scale", type=float, default=0.25)
    ap.add_argument("--seed", type=int, default=0)
    ap.add_argument("--one", type=int, help=argparse.SUPPRESS)  # a child process: this pool only
    ap.add_argument("--out", default=str(HERE / "robustness.json"))
    args = ap.parse_args(argv)
    if args.one is not None:
        print(json.dumps(one(args.draws, args.one, args.error, args.scale, args.seed)))
        return 0
    results = []
    for pool in args.pools:
        cmd = [sys.executable, __file__, "--one", str(pool), "--draws", str(args.draws), "--error", args.error,
               "--scale", str(args.scale), "--seed", str(args.seed)]
        res = subprocess.run(cmd, capture_output=True, text=True, check=True)
        row = json.loads(res.stdout.strip().splitlines()[-1])
        row["machine"] = f"{platform.machine()}, {len(__import__('os').sched_getaffinity(0))} cores"
        results.append(row)
        print(f"pool {row['pool']}: {row['frames_cast']} frames cast, draws {row['draws_cpu_s']} s CPU "
              f"({row['draws_wall_s']} s wall) = {row['cpu_ratio']}× one evaluation's {row['evaluation_cpu_s']} s CPU "
              f"({row['wall_ratio']}× its {row['evaluation_wall_s']} s wall); RSS {row['rss_before_draws_mb']} → peak "
              f"{row['peak_rss_mb']} MB; too close: {row['safety']['draws_too_close_pct']} % of the draws, "
              f"{row['safety']['frames_too_close_pct']} % of the frames", flush=True)
        for name, m in row["metrics"].items():
            print(f"  {name:18s} planned {m['nominal']}  mean {m['mean']}  p5 {m['p5']}  p95 {m['p95']}", flush=True)
    Path(args.out).write_text(json.dumps(results, indent=1) + "\n", encoding="utf-8")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
