"""sightplan benchmark: one command, `make bench` (or `python benchmarks/run.py --help`).

Cases
- drone: about 2,000 frames of a 20 MP camera (DJI Phantom 4 Pro, 5472×3648) on rings
  around a real IFC model — the paper's P1 scale (1,924 frames, 1.78 s per frame on a GPU).
- 360: equirectangular frames (Insta360 ONE RS 1-inch, 6528×3264) on a walk through the model.
- scale: the drone plan at resolution scale 0.25, with VC and VR against full resolution.
- re-evaluation: the drone plan again after moving 10 frames (per-frame cache).
- baseline: the same per-frame work with trimesh's pure-numpy ray tracer, on a few frames
  at low resolution, reported per ray and extrapolated per 20 MP frame.
Prints seconds per frame, rays per second and peak memory; writes benchmarks/results.json.
"""

from __future__ import annotations

import argparse
import json
import resource
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

from sightplan.camera.catalogue import get_camera
from sightplan.evaluate import EvaluationSettings, evaluate
from sightplan.model.load import load_model
from sightplan.plan.poses import R_from_gimbal
from sightplan.plan.templates.orbit import ring_poses
from sightplan.plan.types import Mission, Plan

PAPER_S_PER_FRAME_P1 = 57.0 * 60 / 1924  # 1.78 s


def peak_rss_mb() -> float:
    return resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024.0


def drone_plan(scene, camera, n_frames: int) -> Plan:
    """Rings at three heights and two distances, looking at the model's centre."""
    lo, hi = scene.bounds()
    centre = (lo + hi) / 2
    half = float(np.hypot(*(hi - lo)[:2]) / 2)
    rings = [(half + d, hi[2] + h) for d in (8.0, 20.0) for h in (2.0, 10.0, 25.0)]
    per_ring = int(np.ceil(n_frames / len(rings)))
    C, heading, pitch = zip(*(ring_poses(centre, radius, z, per_ring) for radius, z in rings))
    C = np.concatenate(C)[:n_frames]
    R = R_from_gimbal(np.concatenate(heading)[:n_frames], np.concatenate(pitch)[:n_frames])
    return Plan.build(camera, R, C, missions=(Mission("rings", 0, len(C)),))


def walk_plan(scene, camera, n_frames: int) -> Plan:
    """A walk along the model's long axis at 1.6 m above each storey-ish level."""
    lo, hi = scene.bounds()
    t = np.linspace(0.05, 0.95, n_frames)
    axis = int(np.argmax((hi - lo)[:2]))
    C = np.tile((lo + hi) / 2, (n_frames, 1))
    C[:, axis] = lo[axis] + t * (hi - lo)[axis]
    levels = np.linspace(lo[2] + 1.6, max(lo[2] + 1.6, hi[2] - 1.5), 3)
    C[:, 2] = levels[np.arange(n_frames) % len(levels)]
    R = R_from_gimbal(np.zeros(n_frames), np.zeros(n_frames))
    return Plan.build(camera, R, C)


def run_case(name, scene, plan, settings, cache_dir=False, features=None):
    t = time.perf_counter()
    ev = evaluate(scene, plan, settings, cache_dir=cache_dir, features=features)
    wall = time.perf_counter() - t
    rays = sum(plan.camera_of(i).scaled(settings.scale).width * plan.camera_of(i).scaled(settings.scale).height
               for i in range(len(plan))) if settings.scale != 1 else \
        sum(plan.camera_of(i).width * plan.camera_of(i).height for i in range(len(plan)))
    cast = ev.timings["cast_s"]
    res = {"case": name, "frames": len(plan), "wall_s": wall, "cast_s": cast, "s_per_frame": cast / len(plan),
           "rays_per_s": rays / cast if cast else None, "peak_rss_mb": peak_rss_mb(),
           "features": ev.n_features, "metrics": ev.metrics.plan.to_dict()}
    print(f"{name:>22}: {len(plan)} frames, {cast:.1f} s casting ({res['s_per_frame']:.3f} s/frame, "
          f"{res['rays_per_s'] / 1e6:.1f} M rays/s), wall {wall:.1f} s, peak {res['peak_rss_mb']:.0f} MB", flush=True)
    return res, ev


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--model", default="sample", help="IFC or mesh (default: the bundled Duplex)")
    ap.add_argument("--frames", type=int, default=2000, help="drone frames (paper's P1: 1,924)")
    ap.add_argument("--frames-360", type=int, default=150, help="360° frames")
    ap.add_argument("--baseline-frames", type=int, default=3, help="frames for the trimesh baseline")
    ap.add_argument("--out", default=str(Path(__file__).with_name("results.json")))
    args = ap.parse_args(argv)

    t = time.perf_counter()
    scene, _ = load_model(args.model, cache=False)
    load_s = time.perf_counter() - t
    print(f"model {args.model}: {int(scene.targets.sum())} elements, {len(scene.faces):,} triangles, loaded in {load_s:.1f} s")
    results = {"model": args.model, "triangles": int(len(scene.faces)), "load_s": load_s, "cases": []}
    drone_cam = get_camera("p4p")
    plan = drone_plan(scene, drone_cam, args.frames)
    full_settings = EvaluationSettings(engine="embree")
    with tempfile.TemporaryDirectory() as tmp:
        full, ev_full = run_case("drone 20 MP", scene, plan, full_settings, cache_dir=tmp)
        results["cases"].append(full)
        # re-evaluation after moving 10 frames
        C = plan.C_world.copy()
        moved = np.linspace(0, len(plan) - 1, 10).astype(int)
        C[moved, 2] += 1.0
        plan2 = Plan.build(drone_cam, plan.R_world_camera, C, missions=plan.missions)
        t = time.perf_counter()
        ev2 = evaluate(scene, plan2, full_settings, cache_dir=tmp)
        re_s = time.perf_counter() - t
        print(f"{'re-evaluate (10 moved)':>22}: {re_s:.1f} s ({ev2.cache_hits} frames from cache)")
        results["reevaluate_10_moved_s"] = re_s
    quarter, ev_q = run_case("drone 20 MP @ s=0.25", scene, plan, EvaluationSettings(engine="embree", scale=0.25))
    pf, pq = ev_full.metrics.plan, ev_q.metrics.plan
    err = {k: (abs(getattr(pq, k) - getattr(pf, k)) / getattr(pf, k) * 100 if getattr(pf, k) else None)
           for k in ("VC", "VR", "R", "O")}
    print(f"{'scale 0.25 error %':>22}: " + ", ".join(f"{k} {v:.2f}" for k, v in err.items() if v is not None))
    quarter["error_vs_full_pct"] = err
    results["cases"].append(quarter)
    pano = walk_plan(scene, get_camera("one-rs-1inch"), args.frames_360)
    r360, _ = run_case("360° 21 MP", scene, pano, full_settings)
    results["cases"].append(r360)
    # baseline: trimesh's numpy ray tracer on a few frames at 0.02 scale, per ray
    sub = plan.subset(np.linspace(0, len(plan) - 1, args.baseline_frames).astype(int))
    base, _ = run_case("baseline trimesh @0.02", scene, sub, EvaluationSettings(engine="trimesh", scale=0.02))
    emb, _ = run_case("embree @0.02 (same)", scene, sub, EvaluationSettings(engine="embree", scale=0.02))
    base_frame_s = drone_cam.width * drone_cam.height / base["rays_per_s"]
    ratio = {"paper_s_per_frame": PAPER_S_PER_FRAME_P1,
             "speedup_vs_paper": PAPER_S_PER_FRAME_P1 / full["s_per_frame"],
             "baseline_s_per_20mp_frame": base_frame_s,
             "speedup_vs_baseline": base_frame_s / full["s_per_frame"],
             "speedup_vs_baseline_same_frames": base["cast_s"] / emb["cast_s"]}
    results["ratios"] = ratio
    print(f"\n20 MP drone frame: {full['s_per_frame']:.3f} s — {ratio['speedup_vs_paper']:.1f}× faster than the paper "
          f"({PAPER_S_PER_FRAME_P1:.2f} s on a GPU), {ratio['speedup_vs_baseline']:.0f}× faster than the trimesh baseline "
          f"({base_frame_s:.0f} s extrapolated). Peak memory of the drone evaluation {full['peak_rss_mb']:.0f} MB "
          f"(the whole run, baseline included: {peak_rss_mb():.0f} MB).")
    Path(args.out).write_text(json.dumps(results, indent=2, default=float))
    return 0


if __name__ == "__main__":
    sys.exit(main())
