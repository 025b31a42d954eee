"""Real models, lean: `python benchmarks/lean.py` (or `--quick`, `--help`).

The model is benchmarks/revit_like.py's with the real restaurant's facts (:data:`revit_like.RESTAURANT`: about
3.3 M triangles, 92 % of them furniture, two heavy floor partitions that share no geometry, corners about 98 % of
the simulated features); `--quick` builds it with 2 rooms. It is written once and kept in --workdir. Each step runs
in a fresh interpreter with its own cache folder (SIGHTPLAN_CACHE), so its CPU seconds and peak memory are its own:

1. cold load (empty cache): CPU and wall seconds, the load report's peak memory (the whole load, tie pairs
   included), the model's facts (triangles, furniture share, the partitions' triangles, tied faces);
2. feature sampling on the cached scene, nothing cached: CPU seconds, the process's peak, and its rise over
   the memory the loaded scene held before; the corner share of the features;
3. a fresh evaluation of a 40-frame ring (DJI Phantom 4 Pro, scale 0.25, Embree): CPU seconds of the whole
   process, its peak, and the engine build;
4. the same evaluation again, every frame cached: CPU seconds and peak of the whole process (load from the
   cache included), and whether an engine was built.

CPU seconds count every thread. Another busy process lengthens the wall times but hardly the CPU seconds.
Prints a table and writes benchmarks/lean.json.
"""

from __future__ import annotations

import argparse
import json
import os
import shutil
import sys
import tempfile
import time
from pathlib import Path

RESULT_PREFIX = "RESULT "
HERE = Path(__file__).resolve().parent
FRAMES = 40
SCALE = 0.25


def _rss_mb() -> float:
    """This process's resident memory now (MB)."""
    with open("/proc/self/status", "rb") as fh:
        for line in fh:
            if line.startswith(b"VmRSS:"):
                return int(line.split()[1]) / 1024.0
    return 0.0


def child(args: argparse.Namespace) -> int:
    """One step in this fresh process; one JSON line on stdout."""
    os.environ["SIGHTPLAN_CACHE"] = args.cache
    import numpy as np

    from sightplan.model.load import load_model
    from sightplan.model.summary import peak_rss_mb

    cpu0, wall0 = time.process_time(), time.perf_counter()
    scene, report = load_model(args.model)
    out: dict = {"load_cpu_s": time.process_time() - cpu0, "load_wall_s": time.perf_counter() - wall0,
                 "from_cache": report.from_cache, "report_peak_rss_mb": report.peak_rss_mb}
    if args.case == "load":
        cls = scene.elements.ifc_class
        tri = np.bincount(scene.face_element, minlength=len(cls))
        out.update(triangles=len(scene.faces), elements=len(cls),
                   furniture=int((cls == "IfcFurnishingElement").sum()),
                   furniture_share=float(tri[cls == "IfcFurnishingElement"].sum() / max(1, len(scene.faces))),
                   proxy_triangles=tri[cls == "IfcBuildingElementProxy"].tolist(), tied_faces=report.tied_faces,
                   tied_elements=report.tied_elements)
    elif args.case == "features":
        from sightplan.observations.features import KIND_CORNER, sample_features

        before = _rss_mb()
        cpu = time.process_time()
        fs = sample_features(scene, 1.0, 0)
        out.update(features_cpu_s=time.process_time() - cpu, features=len(fs),
                   corner_share=float((fs.kind == KIND_CORNER).mean()), rss_before_mb=before,
                   features_peak_rss_mb=peak_rss_mb(), features_rise_mb=peak_rss_mb() - before)
    else:
        from sightplan.camera.catalogue import get_camera
        from sightplan.evaluate import EvaluationSettings, evaluate
        from sightplan.plan.ring import ring_plan

        module = sys.modules["sightplan.evaluate"]  # the module: the package exports a function of that name
        built = []
        make = module.make_engine
        module.make_engine = lambda *a, **k: built.append(1) or make(*a, **k)
        plan = ring_plan(scene, get_camera("p4p"), n_frames=FRAMES, distance_m=15.0)
        cpu = time.process_time()
        ev = evaluate(scene, plan, EvaluationSettings(engine="embree", scale=SCALE))
        out.update(evaluate_cpu_s=time.process_time() - cpu, engines_built=len(built),
                   frames_cast=ev.timings["frames_cast"], cache_hits=ev.cache_hits,
                   engine_build_s=ev.timings["engine_build_s"], cast_s=ev.timings["cast_s"],
                   features_s=ev.timings["features_s"], VC=ev.metrics.plan.VC)
    out.update(process_cpu_s=time.process_time(), peak_rss_mb=peak_rss_mb())
    print(RESULT_PREFIX + json.dumps(out, default=float), flush=True)
    return 0


def restaurant(workdir: Path, options: dict) -> tuple[Path, dict]:
    """The generated model for ``options``, written once into ``workdir``."""
    from revit_like import generated

    name = "-".join(f"{k}{v:g}" if isinstance(v, float) else f"{k}{v}" for k, v in sorted(options.items()))
    return generated(workdir / f"restaurant-{name}.ifc", **options)


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--quick", action="store_true", help="the restaurant's facts on 2 rooms")
    ap.add_argument("--workdir", default=str(Path(tempfile.gettempdir()) / "sightplan-bench-lean"),
                    help="where the generated model and the caches are kept")
    ap.add_argument("--out", default=str(HERE / "lean.json"))
    ap.add_argument("--case", choices=["load", "features", "evaluate"], help=argparse.SUPPRESS)
    ap.add_argument("--model", help=argparse.SUPPRESS)
    ap.add_argument("--cache", help=argparse.SUPPRESS)
    args = ap.parse_args(argv)
    if args.case:
        return child(args)

    from revit_like import RESTAURANT
    from run import console, numeric_table, run_script

    options = {**RESTAURANT, "rooms": 2} if args.quick else dict(RESTAURANT)
    workdir = Path(args.workdir)
    workdir.mkdir(parents=True, exist_ok=True)
    t = time.perf_counter()
    path, info = restaurant(workdir, options)
    console.print(f"model: {path.name}, {info['bytes'] / 2**20:.1f} MB ({time.perf_counter() - t:.1f} s)")
    cache = workdir / "cache"
    shutil.rmtree(cache, ignore_errors=True)
    steps: dict = {}
    for step, case in (("cold load", "load"), ("feature sampling", "features"), ("fresh evaluation", "evaluate"),
                       ("cached re-evaluation", "evaluate")):
        proc, result, wall = run_script(__file__, ["--case", case, "--model", str(path), "--cache", str(cache)],
                                        RESULT_PREFIX, capture_stderr=True)
        if result is None:
            tail = "\n".join((proc.stderr or proc.stdout or "").strip().splitlines()[-5:])
            console.print(f"[red]{step} failed (exit {proc.returncode}): {tail}[/red]")
            return 1
        steps[step] = {**result, "process_wall_s": wall}
        console.print(f"{step}: {result['process_cpu_s']:.1f} CPU-s, peak {result['peak_rss_mb']:,.0f} MB")
    load, feats = steps["cold load"], steps["feature sampling"]
    fresh, cached = steps["fresh evaluation"], steps["cached re-evaluation"]
    results = {"settings": {"quick": args.quick, "model": options, "frames": FRAMES, "scale": SCALE,
                            "cpus": os.cpu_count()}, "generated": info, "steps": steps}
    Path(args.out).write_text(json.dumps(results, indent=2, default=float))
    console.width = max(console.width, 120)
    facts = (f"{load['triangles']:,} triangles, {load['elements']:,} elements ({load['furniture']:,} furniture, "
             f"{100 * load['furniture_share']:.1f} % of the triangles), partitions of "
             f"{', '.join(f'{n:,}' for n in load['proxy_triangles'])} triangles, {feats['features']:,} features "
             f"({100 * feats['corner_share']:.1f} % corners), {load['tied_faces']:,} tied faces")
    console.print(facts)
    table = numeric_table(("step", "CPU s", "wall s", "peak MB", "note"), left=("step", "note"),
                          title=f"Real models, lean ({os.cpu_count()} CPU cores, each step in a fresh process)")
    table.add_row("cold load", f"{load['load_cpu_s']:.1f}", f"{load['load_wall_s']:.1f}",
                  f"{load['report_peak_rss_mb']:,.0f}", "the load report's peak, tie pairs included")
    table.add_row("feature sampling", f"{feats['features_cpu_s']:.1f}", "", f"{feats['features_peak_rss_mb']:,.0f}",
                  f"+{feats['features_rise_mb']:,.0f} MB over the loaded scene's {feats['rss_before_mb']:,.0f}")
    table.add_row(f"fresh evaluation, {FRAMES} frames", f"{fresh['process_cpu_s']:.1f}",
                  f"{fresh['process_wall_s']:.1f}", f"{fresh['peak_rss_mb']:,.0f}",
                  f"engine build {fresh['engine_build_s']:.1f} s, cast {fresh['cast_s']:.1f} s")
    table.add_row("cached re-evaluation", f"{cached['process_cpu_s']:.1f}", f"{cached['process_wall_s']:.1f}",
                  f"{cached['peak_rss_mb']:,.0f}",
                  f"{cached['cache_hits']} frames from the cache, {cached['engines_built']} engines built")
    console.print(table)
    console.print(f"wrote {args.out}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
