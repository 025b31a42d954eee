"""Planning benchmark: build templates around a model, split them into flyable missions, export them.

    python benchmarks/planning.py [--model sample]

Prints seconds per step and writes benchmarks/planning.json.
"""

from __future__ import annotations

import argparse
import json
import tempfile
import time
from pathlib import Path

import numpy as np

from sightplan.camera.catalogue import get_camera
from sightplan.geo import Georeference
from sightplan.model.load import load_model
from sightplan.plan.checks.feasibility import FlightSettings, corner_stations, plan_flights
from sightplan.plan.templates import facade_grid, lawnmower, orbit


def timed(results: dict, name: str, fn):
    t = time.perf_counter()
    out = fn()
    results[name] = time.perf_counter() - t
    print(f"{name:>34}: {results[name]:.3f} s")
    return out


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--model", default="sample")
    ap.add_argument("--out", default=str(Path(__file__).with_name("planning.json")))
    args = ap.parse_args(argv)
    scene, _ = load_model(args.model, cache=False)
    cam = get_camera("p4p")
    res: dict = {"model": args.model, "triangles": int(len(scene.faces))}
    print(f"model {args.model}: {len(scene.faces):,} triangles")
    facade = timed(res, "facade grid (g 8 m, 80 %)", lambda: facade_grid(scene, cam, 8.0, 0.8))
    timed(res, "facade grid, outline", lambda: facade_grid(scene, cam, 8.0, 0.8, footprint="outline"))
    lo, hi = scene.bounds()
    r = float(np.hypot(*(hi - lo)[:2]) / 2 + 10)
    timed(res, "orbit (2 rings)", lambda: orbit(scene, cam, [r, r + 10], [lo[2] + 5, hi[2] + 10]))
    timed(res, "lawn-mower (GSD 5 mm)", lambda: lawnmower(scene, cam, gsd_m=0.005))
    settings = FlightSettings(safety_distance_m=8.0, vlos_radius_m=60.0)
    report = timed(res, "split + all checks (facade)", lambda: plan_flights(scene, facade, settings))
    res["frames"] = len(facade)
    res["missions"] = len(report.missions)
    res["violations"] = len(report.violations)
    print(f"{len(facade)} frames → {len(report.missions)} missions, {len(report.violations)} violations, "
          f"{report.total_time_s / 60:.1f} min of flight")
    try:
        from sightplan.export import EXPORT_FORMATS, export_plan
    except ImportError:  # exports not installed in this build
        EXPORT_FORMATS = ()
    geo = Georeference.from_scene_metadata(scene.metadata) or Georeference.from_origin(0.0, 0.0)
    takeoff = corner_stations(scene, report.plan)[0]
    with tempfile.TemporaryDirectory() as tmp:
        for fmt in EXPORT_FORMATS:
            # the facade grid is a Phantom 4 Pro plan, which no WPML aircraft carries: flown by a Mavic 3 Enterprise
            aircraft = "m3e" if fmt == "wpml" else None
            timed(res, f"export {fmt}", lambda fmt=fmt, a=aircraft: export_plan(report.plan, fmt, Path(tmp) / f"p.{fmt}",
                                                                                geo, takeoff, aircraft=a))
    Path(args.out).write_text(json.dumps(res, indent=2))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
