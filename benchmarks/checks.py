"""Flight-check benchmark: ``check_plan`` with the whole trajectory (take-off climb, flight out, return, landing) at a
GNSS drone's position error, on the default facade and orbit plans of each model.

    python benchmarks/checks.py [--models revit-like steel duplex] [--workdir DIR]

- revit-like: benchmarks/revit_like.py's furnished restaurant (the largest model of the benchmarks, about 3.0 M
  triangles), generated once into --workdir, as benchmarks/load.py does;
- steel: the Schependomlaan Tekla steel structure (../shared/data, 85 k triangles);
- duplex: the bundled sample.

Prints and writes (benchmarks/checks.json) per model and template: frames, missions, the seconds of the whole
``check_plan`` and of its parts (safety distance at the worst of the error, sight lines, the missions' paths), and the
process's peak resident memory.
"""

from __future__ import annotations

import argparse
import json
import resource
import tempfile
import time
from pathlib import Path

HERE = Path(__file__).resolve().parent
STEEL = HERE.parent.parent / "shared" / "data" / "schependomlaan" / "BERNTS-Staalconstructie.ifc"


def model_path(name: str, workdir: Path) -> str:
    if name == "duplex":
        return "sample"
    if name == "steel":
        return str(STEEL)
    import sys

    sys.path.insert(0, str(HERE))
    from load import FULL, revit_like

    return str(revit_like(workdir, FULL)[0])


def main(argv: list[str] | None = None) -> int:
    from sightplan.camera.catalogue import get_camera
    from sightplan.model.load import load_model
    from sightplan.plan.checks import feasibility
    from sightplan.plan.checks.feasibility import FlightSettings, check_plan
    from sightplan.plan.templates.registry import plan_from_template

    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--models", nargs="+", default=["revit-like", "steel", "duplex"],
                    choices=["revit-like", "steel", "duplex"])
    ap.add_argument("--workdir", default=str(Path(tempfile.gettempdir()) / "sightplan-bench-load"))
    ap.add_argument("--out", default=str(HERE / "checks.json"))
    args = ap.parse_args(argv)
    workdir = Path(args.workdir)
    workdir.mkdir(parents=True, exist_ok=True)
    settings = FlightSettings(safety_distance_m=10.0)  # a Phantom 4 Pro: ±1.5 m / ±0.5 m
    parts: dict[str, float] = {}

    def timed(name, fn):
        def run(*a, **k):
            t = time.perf_counter()
            try:
                return fn(*a, **k)
            finally:
                parts[name] = parts.get(name, 0.0) + time.perf_counter() - t
        return run

    # the parts of check_plan, timed where check_plan calls them
    feasibility.check_safety = timed("safety_s", feasibility.check_safety)
    feasibility.sight_lines = timed("sight_lines_s", feasibility.sight_lines)
    feasibility.check_paths = timed("paths_s", feasibility.check_paths)
    results = []
    for name in args.models:
        t = time.perf_counter()
        scene, _ = load_model(model_path(name, workdir))
        load_s = time.perf_counter() - t
        for template in ("facade", "orbit"):
            plan, _ = plan_from_template(template, scene, get_camera("p4p"), {}, settings)
            parts.clear()
            t = time.perf_counter()
            report = check_plan(scene, plan, settings)
            row = {"model": name, "triangles": int(len(scene.faces)), "template": template, "frames": len(plan),
                   "missions": len(plan.missions), "ok": report.ok, "load_s": round(load_s, 2),
                   "check_s": round(time.perf_counter() - t, 3), **{k: round(v, 3) for k, v in parts.items()},
                   "peak_rss_mb": round(resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024)}
            print(json.dumps(row))
            results.append(row)
    Path(args.out).write_text(json.dumps(results, indent=1) + "\n", encoding="utf-8")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
