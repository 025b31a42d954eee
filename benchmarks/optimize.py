"""Optimised plans against the best tuned template, per model.

    python benchmarks/optimize.py [--model sample --model PATH ...] [--scale 0.25]

For each model, the facade grid (box and outline footprints), the orbit and the lawn-mower are planned at the same
camera (P4P) and safety distance (10 m), over a grid of their overlaps (``sightplan.optimize.template_grid``, the
grid ``sightplan optimize`` compares with), split and checked; each is evaluated at the
same scale and scored against the same targets (k = 3 serving views, SSD ≤ the camera's at 10 m × 1.5, θ ≤ 45°).
The best template is the one that passes the flight checks and meets the most targets (then the fewest minutes); a
template that fails the checks (line of sight, battery, safety) cannot be flown as planned, so it is listed but not
chosen unless none passes. The optimiser then runs three times:

- at equal targets: no budget (it stops when no view adds anything) — frames and minutes against the best template;
- at the template's targets: the same, with every target the template does not meet skipped — the plan that meets
  exactly what the template meets, its frames and minutes against the template's;
- at equal minutes: a budget of the best template's minutes — targets met, VC, elements with VR_i ≥ k, median R_i.

A second optimiser run with other targets (k = 2) shows what the per-frame cache saves; the Duplex under a budget of
two batteries is timed from an empty cache and again with other targets. Writes
``benchmarks/optimize.json`` and the ``optimize`` entry of ``benchmarks/results.json``.
"""

from __future__ import annotations

import argparse
import json
import resource
import time
from pathlib import Path

import numpy as np

from sightplan.camera.catalogue import get_camera
from sightplan.errors import SightplanError
from sightplan.model.load import load_model
from sightplan.optimize import Budget, OptimizeSettings, Targets, default_ssd, only_met, optimize, score_plan, template_grid
from sightplan.optimize.compare import OVERLAPS
from sightplan.plan.checks.feasibility import FlightSettings
from sightplan.plan.templates.registry import plan_from_template

HERE = Path(__file__).parent
SHARED = HERE.parent.parent / "shared" / "data"
DEFAULT_MODELS = ["sample", str(SHARED / "ifc" / "IfcOpenHouse_IFC4.ifc"),
                  str(SHARED / "ifc" / "construction_scheduling_task.ifc"),
                  str(SHARED / "schependomlaan" / "XELLA-Begane grond.ifc")]
G = 10.0


def score(scene, plan, report, et, scale, cache) -> dict:
    s = score_plan(scene, plan, et, scale=scale, cache_dir=cache)
    return {"frames": len(plan), "minutes": round((report.total_time_s or 0) / 60, 2), "batteries": report.batteries,
            "ok": report.ok, "met": int(s.met.sum()), "met_set": np.flatnonzero(s.met).tolist(),
            "VC_pct": round(100 * (s.VC or 0), 2), "VR_ge_k": s.VR_ge_k,
            "median_R_mm_px": None if s.median_R_m_px is None else round(1000 * s.median_R_m_px, 3),
            "unstable_frames": s.unstable_frames}


def run_model(model: str, scale: float, cache: Path) -> dict:
    print(f"\n== {model}")
    scene, _ = load_model(model)
    cam = get_camera("p4p")
    flight = FlightSettings(safety_distance_m=G)
    targets = Targets()
    et = targets.resolve(scene, default_ssd(cam, G))
    rows = {}
    for label, name, params in template_grid(scene, flight):
        try:
            plan, report = plan_from_template(name, scene, cam, params, flight)
        except SightplanError as exc:
            print(f"{label:>24}: {exc}")
            continue
        rows[label] = score(scene, plan, report, et, scale, cache)
        r = rows[label]
        print(f"{label:>24}: {r['frames']:5d} frames {r['minutes']:6.1f} min met {r['met']:4d} VC {r['VC_pct']:5.1f} % "
              f"VR≥k {r['VR_ge_k']:4d} R {r['median_R_mm_px']}")
    best_label = max(rows, key=lambda k: (rows[k]["ok"], rows[k]["met"], -rows[k]["minutes"]))
    best = rows[best_label]
    out = {"model": Path(model).name, "triangles": int(len(scene.faces)), "targets": et.n_active,
           "templates": {k: {kk: vv for kk, vv in v.items() if kk != "met_set"} for k, v in rows.items()},
           "best_template": best_label}
    settings = OptimizeSettings(scale=scale, cache_dir=cache)
    met = np.zeros(scene.n_elements, bool)
    met[best["met_set"]] = True
    only_template = only_met(targets, scene, et, met)
    for mode, budget, goal in (("equal_targets", Budget(), targets), ("template_targets", Budget(), only_template),
                               ("equal_minutes", Budget(minutes=best["minutes"]), targets)):
        t = time.perf_counter()
        res = optimize(scene, cam, goal, budget, flight=flight, settings=settings)
        elapsed = time.perf_counter() - t
        r = score(scene, res.plan, res.report, et, scale, cache)
        r |= {"seconds": round(elapsed, 1), "candidates": res.candidates, "timings_s": res.summary()["timings_s"],
              "covers_template": bool(set(best["met_set"]) <= set(r["met_set"])),
              "template_targets_missed": len(set(best["met_set"]) - set(r["met_set"]))}
        if mode in ("equal_targets", "template_targets"):
            r["fewer_frames_pct"] = round(100 * (1 - r["frames"] / best["frames"]), 1)
            r["fewer_minutes_pct"] = round(100 * (1 - r["minutes"] / best["minutes"]), 1) if best["minutes"] else None
        out[mode] = {k: v for k, v in r.items() if k != "met_set"}
        print(f"{'optimised ' + mode:>24}: {r['frames']:5d} frames {r['minutes']:6.1f} min met {r['met']:4d} "
              f"VC {r['VC_pct']:5.1f} % VR≥k {r['VR_ge_k']:4d} R {r['median_R_mm_px']} ({elapsed:.0f} s; covers "
              f"the template's: {r['covers_template']})")
    t = time.perf_counter()
    optimize(scene, cam, Targets(k=2), flight=flight, settings=settings)
    out["rerun_other_targets_s"] = round(time.perf_counter() - t, 1)
    out["peak_rss_mb"] = round(resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024)
    return out


def speed_run() -> dict:
    """The Duplex under a budget of two batteries from an empty frame cache (candidates, cast, selection, route),
    then again with other targets (k = 2) from the cache that run filled."""
    import tempfile

    scene, _ = load_model("sample")
    cam, flight = get_camera("p4p"), FlightSettings(safety_distance_m=G)
    out = {}
    with tempfile.TemporaryDirectory() as cache:
        for label, targets in (("empty_cache", Targets()), ("cached_other_targets", Targets(k=2))):
            t = time.perf_counter()
            res = optimize(scene, cam, targets, Budget(batteries=2), flight=flight,
                           settings=OptimizeSettings(cache_dir=Path(cache)))
            s = res.summary()
            out[label] = {"seconds": round(time.perf_counter() - t, 1), "timings_s": s["timings_s"]} | {
                k: s[k] for k in ("frames", "missions", "batteries", "minutes", "met", "unstable_frames", "ok")}
            print(f"Duplex, two batteries, {label}: {out[label]}")
    out["peak_rss_mb"] = round(resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024)
    return out


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--model", action="append")
    ap.add_argument("--scale", type=float, default=0.25)
    ap.add_argument("--cache", default=str(HERE / ".cache" / "optimize"))
    ap.add_argument("--out", default=str(HERE / "optimize.json"))
    args = ap.parse_args(argv)
    models = args.model or [m for m in DEFAULT_MODELS if m == "sample" or Path(m).exists()]
    results = [run_model(m, args.scale, Path(args.cache)) for m in models]
    doc = {"scale": args.scale, "safety_distance_m": G, "camera": "p4p", "overlaps_searched": list(OVERLAPS),
           "models": results, "duplex_two_batteries": speed_run()}
    Path(args.out).write_text(json.dumps(doc, indent=1) + "\n", encoding="utf-8")
    combined = HERE / "results.json"
    if combined.exists():
        data = json.loads(combined.read_text(encoding="utf-8"))
        data["optimize"] = doc
        combined.write_text(json.dumps(data, indent=1) + "\n", encoding="utf-8")
    print(f"wrote {args.out}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
