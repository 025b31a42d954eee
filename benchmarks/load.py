"""Model loading benchmark: `python benchmarks/load.py` (or `--quick`, `--help`).

Models
- revit-like: benchmarks/revit_like.py's furnished restaurant, IFC2X3 in millimetres, about 28 MB,
  315,000 entities, 1,824 elements, 3.0 M triangles (`--quick`: 8 rooms, about 7 MB); written
  once and kept in --workdir (default: sightplan-bench-load in the temporary folder).
- duplex: the bundled buildingSMART Duplex (IFC2X3, 2.3 MB).
- steel: the Schependomlaan steel structure (../shared/data/schependomlaan/*Staal*.ifc, IFC2X3,
  3.9 MB), skipped when absent.

Each model is loaded twice through `load_model`, each time in a fresh interpreter: first with an
empty scene cache (the first load: parse, tessellate, assemble, write the cache), then again
(the cached load). For each: wall seconds, CPU seconds of the process (every thread, so above
the wall time when tessellation runs on several cores), and the loader's peak resident memory
(LoadReport.peak_rss_mb: the process's peak at the end of the load, imports included; the
cached load's own peak is cached_peak_rss_mb in load.json).
Another busy process on the machine lengthens the wall times but hardly the CPU seconds.
Prints a table and writes benchmarks/load.json.
"""

from __future__ import annotations

import argparse
import json
import os
import re
import shutil
import sys
import tempfile
import time
from pathlib import Path

RESULT_PREFIX = "RESULT "
HERE = Path(__file__).resolve().parent
SHARED = HERE.parent.parent / "shared" / "data"
FULL = {"rooms": 32, "detail": 1.0, "properties": 128}
QUICK = {"rooms": 8, "detail": 1.0, "properties": 128}


def count_entities(path: Path) -> int:
    """STEP instances in an .ifc file (lines that start with #id=), read without IfcOpenShell."""
    return len(re.findall(rb"^#\d+\s*=", path.read_bytes(), flags=re.M))


def child(args: argparse.Namespace) -> int:
    """One load in this fresh process: one JSON line on stdout. Imports nothing heavy before it."""
    from sightplan.model.ifc import _peak_rss_mb
    from sightplan.model.load import load_model

    rss_before = _peak_rss_mb()
    t, cpu = time.perf_counter(), time.process_time()
    scene, report = load_model(args.model, cache=True, cache_dir=args.cache_dir)
    wall, cpu = time.perf_counter() - t, time.process_time() - cpu
    print(RESULT_PREFIX + json.dumps({
        "wall_s": wall, "cpu_s": cpu, "from_cache": report.from_cache, "elements": report.n_elements,
        "triangles": int(len(scene.faces)), "products": report.n_products, "skipped": len(report.skipped),
        "fallbacks": len(report.fallbacks), "loader_peak_rss_mb": report.peak_rss_mb,
        "peak_rss_mb": _peak_rss_mb(), "rss_before_mb": rss_before,
    }), flush=True)
    return 0


def measure(path: Path, workdir: Path) -> dict:
    """The first (uncached) and the cached load of ``path``, each in a fresh process."""
    from run import run_script

    cache_dir = workdir / "scenes" / path.stem
    shutil.rmtree(cache_dir, ignore_errors=True)
    out: dict = {"file": path.name, "file_mb": path.stat().st_size / 2**20, "entities": count_entities(path)}
    for step in ("first", "cached"):
        proc, result, wall = run_script(__file__, ["--case", "load", "--model", str(path), "--cache-dir", str(cache_dir)],
                                        RESULT_PREFIX, capture_stderr=True)
        if result is None:
            tail = "\n".join((proc.stderr or proc.stdout or "").strip().splitlines()[-5:])
            return {**out, "error": f"{step} load failed (exit {proc.returncode}): {tail}"}
        if result["from_cache"] != (step == "cached"):
            return {**out, "error": f"{step} load: from_cache is {result['from_cache']}"}
        out[step] = {**result, "process_s": wall}
    first, cached = out["first"], out["cached"]
    out.update(elements=first["elements"], triangles=first["triangles"], first_load_wall_s=first["wall_s"],
               first_load_cpu_s=first["cpu_s"], cached_load_s=cached["wall_s"], peak_rss_mb=first["loader_peak_rss_mb"],
               cached_peak_rss_mb=cached["peak_rss_mb"], fallbacks=first["fallbacks"], skipped=first["skipped"])
    return out


def revit_like(workdir: Path, options: dict) -> tuple[Path, dict]:
    """The generated model for ``options``, written once into ``workdir``."""
    from revit_like import generated

    return generated(workdir / "revit_like-{rooms}r-{detail:g}d-{properties}p.ifc".format(**options), **options)


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--quick", action="store_true", help=f"a smaller generated model: {QUICK}")
    ap.add_argument("--workdir", default=str(Path(tempfile.gettempdir()) / "sightplan-bench-load"),
                    help="where the generated model and the scene caches are kept")
    ap.add_argument("--models", nargs="+", default=["revit-like", "duplex", "steel"],
                    choices=["revit-like", "duplex", "steel"])
    ap.add_argument("--out", default=str(HERE / "load.json"))
    ap.add_argument("--case", choices=["load"], help=argparse.SUPPRESS)
    ap.add_argument("--model", help=argparse.SUPPRESS)
    ap.add_argument("--cache-dir", help=argparse.SUPPRESS)
    args = ap.parse_args(argv)
    if args.case:
        return child(args)

    from run import console, numeric_table
    from sightplan.model.load import sample_model_path

    workdir = Path(args.workdir)
    workdir.mkdir(parents=True, exist_ok=True)
    options = QUICK if args.quick else FULL
    results: dict = {"settings": {"quick": args.quick, "revit_like": options, "cpus": os.cpu_count()}, "models": {}}
    t_all = time.perf_counter()
    for name in args.models:
        if name == "revit-like":
            t = time.perf_counter()
            path, info = revit_like(workdir, options)
            console.print(f"revit-like: {path.name}, {info['bytes'] / 2**20:.1f} MB ({time.perf_counter() - t:.1f} s)")
        elif name == "duplex":
            path, info = sample_model_path(), {}
        else:
            found = sorted(SHARED.glob("schependomlaan/*Staal*.ifc"))
            if not found:
                console.print(f"steel: no *Staal*.ifc under {SHARED / 'schependomlaan'}, skipped")
                continue
            path, info = found[0], {}
        r = measure(path, workdir)
        if info:
            r["generated"] = info
        results["models"][name] = r
        if "error" in r:
            console.print(f"[red]{name}: {r['error']}[/red]")
            continue
        console.print(f"{name}: first load {r['first_load_wall_s']:.1f} s ({r['first_load_cpu_s']:.1f} s CPU), "
                      f"cached {r['cached_load_s']:.2f} s, peak {r['peak_rss_mb']:,.0f} MB")
    results["total_s"] = time.perf_counter() - t_all
    console.width = max(console.width, 120)
    table = numeric_table(("model", "file MB", "entities", "elements", "triangles", "first load s", "CPU s",
                           "cached s", "peak RSS MB", "fallbacks"), left=("model",),
                          title=f"Model loading ({os.cpu_count()} CPU cores, each load in a fresh process)")
    for name, r in results["models"].items():
        if "error" in r:
            table.add_row(name, f"{r['file_mb']:.1f}", f"{r['entities']:,}", f"[red]{r['error'][:60]}[/red]", *[""] * 6)
            continue
        table.add_row(name, f"{r['file_mb']:.1f}", f"{r['entities']:,}", f"{r['elements']:,}", f"{r['triangles']:,}",
                      f"{r['first_load_wall_s']:.1f}", f"{r['first_load_cpu_s']:.1f}", f"{r['cached_load_s']:.2f}",
                      f"{r['peak_rss_mb']:,.0f}", str(r["fallbacks"]))
    console.print(table)
    Path(args.out).write_text(json.dumps(results, indent=2, default=float))
    console.print(f"wrote {args.out} (total {results['total_s']:.0f} s)")
    return 0


if __name__ == "__main__":
    sys.exit(main())
