"""Speed on real sizes: `python benchmarks/speed.py` (or `--quick`, `--help`).

For each model, from the bundled Duplex to a ~3 M-triangle Revit-like building, in a fresh
process each (so every peak memory is that model's alone), with the Embree engine on
every core:
- load: the first load and feature sampling in a process of their own (its peak memory is
  theirs), then the cached load and features in the measuring process; BVH build;
- drone frames (DJI Phantom 4 Pro, 20 MP) at scale 1 and 0.25, on rings around the
  model: seconds per frame, of which the feature test; CPU seconds per frame too, since
  other work on the machine stretches wall time but not CPU time;
- raw Embree on the very same rays, on as many threads, without generating rays,
  reducing or testing features: embreex's ``rtcIntersect1`` (its ``run``, how Embree is
  called from Python), and ``rtcIntersect8`` packets through sightplan's binding on rays
  made beforehand; the ratio of sightplan's whole frame to each is what everything else
  costs beside the cast;
- 360° frames (Insta360 One RS 1-inch, 21 MP) on a walk through the model;
- the paper's 1.78 s per P1 frame (57 min for 1,924 frames on its GPU) beside them.
Then the growth with the plan: the Duplex evaluated end to end (`evaluate`, scale 0.25)
with 50 to 2,000 frames, each in its own process: seconds, seconds per frame, peak memory.
Writes benchmarks/speed.json.
"""

from __future__ import annotations

import argparse
import json
import os
import resource
import sys
import tempfile
import time
from concurrent.futures import ThreadPoolExecutor
from pathlib import Path

import numpy as np
from rich.console import Console

from run import PAPER_S_PER_FRAME_P1, cell_plan, emit, numeric_table, peak_rss_mb, run_script
from sightplan.engines.embree import EmbreeEngine
from sightplan.evaluate import EvaluationSettings, evaluate
from sightplan.model.load import load_model
from sightplan.observations.features import cached_features

HERE = Path(__file__).resolve().parent
DATA = HERE.parent.parent / "shared" / "data"
RESULT_PREFIX = "SPEED "
WORKDIR = HERE / ".cache"
PLAN_SIZES = (50, 200, 500, 2000)
console = Console(width=max(150, Console().width))  # the tables are wide; keep them whole in logs


def model_path(name: str) -> str | None:
    """The file of a named model (generated on first use), or None when it is not available here."""
    if name == "duplex":
        return "sample"
    if name in ("prefab", "steel"):  # the Schependomlaan precast concrete (Office class, 46 k) and steel (85 k)
        found = sorted(DATA.glob("schependomlaan/*" + ("Prefab" if name == "prefab" else "Staal") + "*.ifc"))
        return str(found[0]) if found else None
    if name == "revit-like":
        from revit_like import write_revit_like_ifc  # benchmarks/revit_like.py, beside this script

        path = WORKDIR / "revit_like.ifc"
        if not path.is_file():
            WORKDIR.mkdir(exist_ok=True)
            write_revit_like_ifc(path)
        return str(path)
    if name == "restaurant":  # the real 27 MB Revit restaurant's facts (benchmarks/revit_like.py --restaurant)
        from revit_like import RESTAURANT, generated

        WORKDIR.mkdir(exist_ok=True)
        return str(generated(WORKDIR / "restaurant.ifc", **RESTAURANT)[0])
    if name.startswith("campus-"):
        return name  # built in memory (benchmarks/large.py)
    raise ValueError(f"unknown model {name!r}")


def load(name: str, cache_dir: Path | None):
    if name.startswith("campus-"):
        from large import campus_scene  # benchmarks/large.py: columns of 100 triangles

        return campus_scene(int(float(name.split("-")[1].rstrip("M")) * 1e6) // 100)
    scene, _ = load_model(model_path(name), cache_dir=cache_dir)
    return scene


def cpu_s() -> float:
    r = resource.getrusage(resource.RUSAGE_SELF)
    return r.ru_utime + r.ru_stime


def frame_rays(engine: EmbreeEngine, cam, R, C_world) -> tuple[np.ndarray, np.ndarray]:
    """The rays sightplan casts for one frame: (n, 3) float32 directions and the local float32 origin."""
    n = cam.width * cam.height
    dirs = np.empty((n, 3), np.float32)
    engine.pixel_directions(cam, np.ascontiguousarray(R, np.float64), 0, n, dirs)
    return dirs, (np.asarray(C_world, np.float64) - engine.centre).astype(np.float32)


def raw_s(cast_one, pool, threads: int, dirs: np.ndarray, origin: np.ndarray) -> tuple[float, float]:
    """Seconds and CPU seconds ``cast_one(origins, directions)`` takes for these rays, split over ``threads``
    threads."""
    parts = np.array_split(np.arange(len(dirs)), threads)

    def part(idx):
        d = dirs[idx[0]: idx[-1] + 1]
        cast_one(np.broadcast_to(origin, d.shape), d)

    t, c = time.perf_counter(), cpu_s()
    list(pool.map(part, parts))
    return time.perf_counter() - t, cpu_s() - c


def frames_case(engine: EmbreeEngine, plan, scale: float) -> dict:
    """Seconds per frame (wall and CPU), of which the feature test."""
    feature_s = [0.0, 0.0]  # wall, CPU
    visible = engine.visible_features

    def timed_features(*a, **k):
        t, c = time.perf_counter(), cpu_s()
        out = visible(*a, **k)
        feature_s[0] += time.perf_counter() - t
        feature_s[1] += cpu_s() - c
        return out

    engine.visible_features = timed_features
    wall = cpu = 0.0
    for i in range(len(plan)):
        cam = plan.camera_of(i)
        t, c = time.perf_counter(), cpu_s()
        engine.observe(cam, plan.R_world_camera[i], plan.C_world[i], scale)
        wall += time.perf_counter() - t
        cpu += cpu_s() - c
    del engine.visible_features
    n = len(plan)
    return {"frames": n, "scale": scale, "s_per_frame": wall / n, "cpu_s_per_frame": cpu / n,
            "feature_s_per_frame": feature_s[0] / n, "feature_share": feature_s[0] / wall if wall else None,
            "feature_cpu_s_per_frame": feature_s[1] / n, "feature_cpu_share": feature_s[1] / cpu if cpu else None,
            "peak_rss_mb": peak_rss_mb()}


def raw_case(engine: EmbreeEngine, plan, scale: float, casts: dict, pool) -> dict:
    """Seconds and CPU seconds per frame of each raw cast of the frames' rays (no generation, reduction or
    features), and its million rays a second."""
    total = dict.fromkeys(casts, 0.0)
    cpu = dict.fromkeys(casts, 0.0)
    rays = 0
    for i in range(len(plan)):
        cam = plan.camera_of(i)
        cam = cam.scaled(scale) if scale != 1 else cam
        dirs, origin = frame_rays(engine, cam, plan.R_world_camera[i], plan.C_world[i])
        for name, cast_one in casts.items():
            s, c = raw_s(cast_one, pool, engine.threads, dirs, origin)
            total[name] += s
            cpu[name] += c
        rays += len(dirs)
    return {name: (s / len(plan), rays / s / 1e6, cpu[name] / len(plan)) for name, s in total.items()}


def prepare_case(args) -> dict:
    """The first load and feature sampling of a model, in a process of their own (both go to the cache)."""
    cache_dir = Path(args.cache)
    t, c = time.perf_counter(), cpu_s()
    scene = load(args.model, cache_dir)
    res = {"load_s": time.perf_counter() - t, "load_cpu_s": cpu_s() - c}
    t = time.perf_counter()
    features = cached_features(scene, 1.0, 0, cache_dir=cache_dir)
    res.update(features=len(features), features_s=time.perf_counter() - t, prepare_peak_rss_mb=peak_rss_mb())
    return res


def model_case(args) -> dict:
    """The frames of one model, its scene and features read from the cache: the peak memory is the
    evaluation's (scene, features, BVH, one frame's buffers), not the one-time sampling's."""
    cache_dir = Path(args.cache)
    t = time.perf_counter()
    scene = load(args.model, cache_dir)
    res = {"model": args.model, "triangles": int(len(scene.faces)), "elements": int(scene.n_elements),
           "cached_load_s": time.perf_counter() - t}
    t = time.perf_counter()
    features = cached_features(scene, 1.0, 0, cache_dir=cache_dir)
    res["features_cached_s"] = time.perf_counter() - t
    t = time.perf_counter()
    engine = EmbreeEngine(scene, features)
    res.update(build_s=time.perf_counter() - t, threads=engine.threads)
    drone = cell_plan(scene, "drone", max(args.frames, args.frames_full))
    walk = cell_plan(scene, "360", args.frames_360)
    engine.observe(drone.camera_of(0), drone.R_world_camera[0], drone.C_world[0], 0.05)  # compile the kernels
    res["peak_rss_before_frames_mb"] = peak_rss_mb()
    cases = {"drone@1": (drone.subset(np.arange(args.frames_full)), 1.0),
             "drone@0.25": (drone.subset(np.arange(args.frames)), 0.25),
             "360@1": (walk, 1.0)}
    # raw Embree needs its own BVH: built after sightplan's frames, whose peak memory is taken first
    measured = {k: frames_case(engine, plan, scale) for k, (plan, scale) in cases.items()}
    from embreex import rtcore_scene
    from embreex.mesh_construction import TriangleMesh

    single = rtcore_scene.EmbreeScene()
    TriangleMesh(single, engine.local_vertices.astype(np.float32), scene.faces.astype(np.int32))
    casts = {"rtcIntersect1": lambda o, d: single.run(o, d, query="INTERSECT"), "rtcIntersect8": engine.first_hit}
    with ThreadPoolExecutor(engine.threads) as pool:
        for k, (plan, scale) in cases.items():
            raw = raw_case(engine, plan, scale, casts, pool)
            m = measured[k]
            (s1, r1, c1), (s8, r8, _) = raw["rtcIntersect1"], raw["rtcIntersect8"]
            m.update(raw_embree_s_per_frame=s1, raw_embree_mrays_per_s=r1, ratio_to_raw=m["s_per_frame"] / s1,
                     raw_embree_cpu_s_per_frame=c1, cpu_ratio_to_raw=m["cpu_s_per_frame"] / c1,
                     packets_s_per_frame=s8, packets_mrays_per_s=r8, ratio_to_packets=m["s_per_frame"] / s8)
    res["cases"] = measured
    engine.close()
    return res


def plan_case(args) -> dict:
    scene, _ = load_model("sample", cache_dir=Path(args.cache))
    plan = cell_plan(scene, "drone", args.plan_frames)
    settings = EvaluationSettings(engine="embree", scale=0.25)
    features = cached_features(scene, settings.feature_density, settings.feature_seed, cache_dir=Path(args.cache))
    t, c = time.perf_counter(), cpu_s()
    ev = evaluate(scene, plan, settings, features=features, cache_dir=False)
    wall = time.perf_counter() - t
    return {"frames": len(plan), "s": wall, "cpu_s": cpu_s() - c, "s_per_frame": wall / len(plan),
            "peak_rss_mb": peak_rss_mb(), "VC": ev.metrics.plan.VC, "T": ev.metrics.plan.T}


def child(argv: list[str]) -> int:
    p = argparse.ArgumentParser()
    p.add_argument("--model")
    p.add_argument("--prepare", action="store_true")
    p.add_argument("--plan-frames", type=int)
    p.add_argument("--frames", type=int, default=24)
    p.add_argument("--frames-full", type=int, default=6)
    p.add_argument("--frames-360", type=int, default=3)
    p.add_argument("--cache", required=True)
    args = p.parse_args(argv)
    emit(RESULT_PREFIX, plan_case(args) if args.plan_frames else prepare_case(args) if args.prepare
         else model_case(args))
    return 0


def run_child(options: list[str]) -> dict | None:
    proc, res, wall = run_script(__file__, ["--child", *options], RESULT_PREFIX, capture_stderr=True)
    if proc.returncode != 0 or res is None:
        tail = "\n".join((proc.stderr or proc.stdout).strip().splitlines()[-6:])
        console.print(f"[red]{' '.join(options)} failed:[/red]\n{tail}", markup=True, highlight=False)
        return None
    res["process_s"] = wall
    return res


def fmt(x, digits: int = 3) -> str:
    return "–" if x is None else f"{x:.{digits}f}"


def print_tables(models: list[dict], plans: list[dict]) -> None:
    t = numeric_table(("model", "triangles", "frame", "s/frame", "CPU s/frame", "features", "features CPU",
                       "rtcIntersect1 s", "× it", "CPU × it", "rtcIntersect8 s", "× it", "× paper", "peak MB"),
                      left=("model", "frame"),
                      title="Embree engine, every core, against raw Embree on the same rays "
                            "(paper: 1.78 s per 20 MP P1 frame on a GPU)")
    for m in models:
        for k, c in m["cases"].items():
            t.add_row(m["model"], f"{m['triangles']:,}", k, fmt(c["s_per_frame"]), fmt(c["cpu_s_per_frame"]),
                      f"{100 * (c['feature_share'] or 0):.0f} %", f"{100 * (c['feature_cpu_share'] or 0):.0f} %",
                      fmt(c["raw_embree_s_per_frame"]),
                      fmt(c["ratio_to_raw"], 2), fmt(c.get("cpu_ratio_to_raw"), 2), fmt(c["packets_s_per_frame"]),
                      fmt(c["ratio_to_packets"], 2),
                      fmt(c["s_per_frame"] / PAPER_S_PER_FRAME_P1, 3), f"{c['peak_rss_mb']:.0f}")
    console.print(t)
    t = numeric_table(("model", "first load s", "cached s", "features s", "from cache s", "BVH s", "features",
                       "peak MB"), left=("model",), title="Preparing a model (first load and sampling: peak MB)")
    for m in models:
        t.add_row(m["model"], fmt(m["load_s"], 2), fmt(m["cached_load_s"], 2), fmt(m["features_s"], 2),
                  fmt(m["features_cached_s"], 2), fmt(m["build_s"], 2), f"{m['features']:,}",
                  f"{m['prepare_peak_rss_mb']:.0f}")
    console.print(t)
    if plans:
        t = numeric_table(("frames", "s", "s/frame", "CPU s", "peak MB"), left=(),
                          title="Duplex, evaluate() at scale 0.25, as the plan grows")
        for p in plans:
            t.add_row(str(p["frames"]), fmt(p["s"], 1), fmt(p["s_per_frame"]), fmt(p["cpu_s"], 1),
                      f"{p['peak_rss_mb']:.0f}")
        console.print(t)


def main(argv: list[str] | None = None) -> int:
    argv = sys.argv[1:] if argv is None else argv
    if argv and argv[0] == "--child":
        return child(argv[1:])
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0], formatter_class=argparse.RawTextHelpFormatter)
    p.add_argument("--quick", action="store_true", help="the Duplex and a 1 M-triangle campus, few frames")
    p.add_argument("--models", default="duplex,prefab,steel,campus-1M,revit-like,restaurant",
                   help="comma-separated: duplex, prefab, steel, revit-like, restaurant, campus-<N>M")
    p.add_argument("--frames", type=int, default=24, help="drone frames at scale 0.25 per model")
    p.add_argument("--frames-full", type=int, default=6, help="drone frames at scale 1 per model")
    p.add_argument("--frames-360", type=int, default=3, help="360° frames at scale 1 per model")
    p.add_argument("--plan-sizes", default=",".join(map(str, PLAN_SIZES)),
                   help="frames of the Duplex plans evaluated end to end (empty: none)")
    p.add_argument("--out", default=str(HERE / "speed.json"))
    args = p.parse_args(argv)
    models = ["duplex", "campus-1M"] if args.quick else args.models.split(",")
    sizes = PLAN_SIZES[:2] if args.quick else [int(n) for n in args.plan_sizes.split(",") if n.strip()]
    frames = ["--frames", str(8 if args.quick else args.frames), "--frames-full", str(2 if args.quick else
              args.frames_full), "--frames-360", str(1 if args.quick else args.frames_360)]
    results, plans = [], []
    with tempfile.TemporaryDirectory() as tmp:
        cache = os.environ.get("SIGHTPLAN_CACHE") or tmp
        for name in models:
            if not name.startswith("campus-") and model_path(name) is None:
                console.print(f"{name}: not available here, skipped")
                continue
            console.print(f"[bold]{name}[/bold] …")
            first = run_child(["--model", name, "--cache", cache, "--prepare"])
            res = run_child(["--model", name, "--cache", cache, *frames]) if first else None
            if res:
                results.append({**res, **first})
        for n in sizes:
            console.print(f"[bold]Duplex, {n} frames[/bold] …")
            res = run_child(["--plan-frames", str(n), "--cache", cache])
            if res:
                plans.append(res)
    print_tables(results, plans)
    out = {"paper_s_per_frame": PAPER_S_PER_FRAME_P1, "cpu_count": os.cpu_count(), "models": results, "plans": plans}
    Path(args.out).write_text(json.dumps(out, indent=1, default=float))
    console.print(f"wrote {args.out}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
