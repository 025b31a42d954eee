"""Validation benchmark: a plan validated against a synthetic reconstruction of the model.

    python benchmarks/validation.py [--model sample] [--frames 300] [--scale 0.25]

The reality is the model with two elements removed and one moved 5 cm, so the answers are
known in kind. Prints the seconds of each step and peak memory; writes benchmarks/validation.json.
"""

from __future__ import annotations

import argparse
import json
import time
from pathlib import Path

from run import peak_rss_mb  # benchmarks/run.py, beside this script
from sightplan.camera.catalogue import get_camera
from sightplan.evaluate import EvaluationSettings, evaluate
from sightplan.model.load import load_model
from sightplan.plan.ring import ring_plan
from sightplan.validate import synthetic_reality, validate


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--model", default="sample")
    ap.add_argument("--frames", type=int, default=300)
    ap.add_argument("--scale", type=float, default=0.25)
    ap.add_argument("--out", default=str(Path(__file__).with_name("validation.json")))
    args = ap.parse_args(argv)
    scene, _ = load_model(args.model)
    plan = ring_plan(scene, get_camera("p4p"), n_frames=args.frames)
    targets = [i for i in range(scene.n_elements) if scene.elements.is_target[i]]
    reality = synthetic_reality(scene, remove=targets[:2], shift={targets[2]: 0.05})
    settings = EvaluationSettings(engine="embree", scale=args.scale)
    t = time.perf_counter()
    ev = evaluate(scene, plan, settings, cache_dir=False)
    evaluate_s = time.perf_counter() - t
    t = time.perf_counter()
    val = validate(scene, plan, reality, 0.03, settings, evaluation=ev)
    validate_s = time.perf_counter() - t
    peak_mb = peak_rss_mb()
    res = {"model": args.model, "frames": len(plan), "scale": args.scale, "evaluate_s": evaluate_s,
           "validate_s": validate_s, "timings": val.timings, "metrics": val.plan_metrics(), "peak_rss_mb": peak_mb}
    print(f"{len(plan)} frames at scale {args.scale}: evaluate {evaluate_s:.1f} s, validate {validate_s:.1f} s "
          f"(casting {val.timings['cast_s']:.1f} s, Ct {val.timings['ct_s']:.1f} s, precision "
          f"{val.timings['precision_s']:.1f} s), peak {peak_mb:.0f} MB")
    print("  " + ", ".join(f"{k} {v:.3f}" for k, v in val.plan_metrics().items() if isinstance(v, float)))
    Path(args.out).write_text(json.dumps(res, indent=2, default=float))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
