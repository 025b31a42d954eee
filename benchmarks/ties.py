"""Coincident surfaces (ties): do the plan metrics hold when every camera moves by 0.1 mm, and what do ties cost?

`python benchmarks/ties.py` (or `--quick`: the Duplex only). For the bundled Duplex and each IFC model in
../shared/data: the faces flush with another element's (found when the model is loaded), then a 36-frame ring
(DJI Phantom 4 Pro, scale 0.25, the Embree engine) evaluated four times: without and with ties (METRICS.md §2),
each at the planned poses and with every camera moved by 0.1 mm along (1, 1, 1)/√3. Reports V, VC, VR, R, O for each,
whether they changed with the shift (V, VC, VR exactly, R and O beyond 10⁻³ relative), and the seconds per frame
with and without ties: of the whole ring at scale 0.25, and the best of three full-resolution (20 MP) runs of six of
its frames. Writes benchmarks/ties.json.

The tie search alone (:func:`sightplan.model.ties.coincident_face_pairs`), on the same models and on two generated
ones: the heating network of benchmarks/pipe_network.py (:data:`pipe_network.BIG`, fittings, valves and radiators flush with the
pipes) and the Revit-like restaurant of benchmarks/revit_like.py (:data:`revit_like.RESTAURANT`, furniture flush on
the floors). Each model is loaded once in a fresh process to fill a cache of its own, then read back from that cache in
another, which runs the search again after a warm-up: the pairs, the tied faces and elements, its CPU seconds and its
peak memory (the process's high-water mark, reset before the search, and its rise over the loaded scene).
`--search-only` measures only that (into the "search" part of ties.json, the ring study kept as it was);
`--pipes STOREYS BAYS` sizes the network.
"""

from __future__ import annotations

import argparse
import json
import sys
import tempfile
import time
from dataclasses import replace
from pathlib import Path

import numpy as np
from rich.console import Console

from run import numeric_table
from sightplan.camera.catalogue import get_camera
from sightplan.evaluate import EvaluationSettings, evaluate
from sightplan.model.load import load_model, sample_model_path
from sightplan.model.ties import tie_summary
from sightplan.observations.features import cached_features
from sightplan.plan.ring import ring_plan

HERE = Path(__file__).resolve().parent
DATA = HERE.parent.parent / "shared" / "data"
SHIFT_M = 1e-4
FRAMES = 36
SCALE = 0.25
KEYS = ("n_visible", "VC", "VR", "R", "O")
TIMED = 6  # frames of the ring timed at full resolution (20 MP), best of three
SEARCH_PREFIX = "TIES-SEARCH "
WORKDIR = Path(tempfile.gettempdir()) / "sightplan-bench-ties"


def models(quick: bool) -> list[Path]:
    sample = sample_model_path()
    found = [sample]
    if not quick:  # ../shared/data/ifc holds the sample's own file too
        found += [p for p in sorted((DATA / "ifc").glob("*.ifc")) + sorted((DATA / "schependomlaan").glob("*.ifc"))
                  if p.read_bytes() != sample.read_bytes()]
    return found


def metrics(scene, plan, features) -> tuple[dict, float]:
    t0 = time.perf_counter()
    ev = evaluate(scene, plan, EvaluationSettings(engine="embree", scale=SCALE), features=features, cache_dir=False)
    seconds = time.perf_counter() - t0
    m = ev.metrics.plan.to_dict()
    return {k: m[k] for k in KEYS}, seconds / len(plan)


def changed(a: dict, b: dict) -> list[str]:
    """The metrics that differ: V, VC, VR exactly; R, O beyond 10⁻³ relative."""
    out = []
    for k in KEYS:
        x, y = a[k], b[k]
        if x is None or y is None:
            if x is not y:
                out.append(k)
        elif k in ("R", "O"):
            if abs(x - y) > 1e-3 * abs(x):
                out.append(k)
        elif x != y:
            out.append(k)
    return out


def frame_seconds(scene, plan, features, repeats: int = 3) -> float:
    """Best of ``repeats`` full-resolution evaluations of ``plan``, in seconds per frame."""
    best = np.inf
    for _ in range(repeats):
        t0 = time.perf_counter()
        evaluate(scene, plan, EvaluationSettings(engine="embree", scale=1.0), features=features, cache_dir=False)
        best = min(best, (time.perf_counter() - t0) / len(plan))
    return best


def study(path: Path) -> dict:
    scene, report = load_model(path)
    pairs = scene.tie_pairs()
    tied_faces, tied_elements = tie_summary(pairs, scene.face_element)
    untied = replace(scene)  # the same geometry, its ties switched off
    untied.set_tie_pairs(np.zeros((0, 2), np.int32))
    plan = ring_plan(scene, get_camera("p4p"), n_frames=FRAMES, distance_m=15.0)
    moved = replace(plan, C_world=plan.C_world + SHIFT_M / np.sqrt(3.0))
    features = cached_features(scene)
    metrics(scene, plan.subset(np.arange(2)), features)  # warm-up: compiled kernels, thread pools
    row = {"model": path.name, "triangles": int(len(scene.faces)), "elements": int(scene.n_elements),
           "tied_faces": tied_faces, "tied_elements": tied_elements}
    for label, s in (("without_ties", untied), ("with_ties", scene)):
        at, spf = metrics(s, plan, features)
        shifted, _ = metrics(s, moved, features)
        row[label] = {"planned": at, "moved": shifted, "changed": changed(at, shifted), "s_per_frame": spf,
                      "s_per_frame_full": frame_seconds(s, plan.subset(np.arange(0, FRAMES, FRAMES // TIMED)), features)}
    return row


def _rss_mb(field: str) -> float:
    """This process's VmRSS or VmHWM (MB) from /proc, 0.0 where the platform does not tell."""
    try:
        with open("/proc/self/status") as fh:
            for line in fh:
                if line.startswith(field + ":"):
                    return int(line.split()[1]) / 1024.0
    except OSError:
        pass
    return 0.0


def search_child(path: Path, cache: Path, cold: bool) -> dict:
    """In a fresh process: ``cold``, the load that fills the cache (its CPU seconds and peak); otherwise the load from
    that cache, then the tie search again, alone, with its CPU seconds and peak memory."""
    from sightplan.model.ties import coincident_face_pairs

    t_cpu = time.process_time()
    scene, report = load_model(path, cache_dir=cache)
    out = {"model": path.name, "triangles": int(len(scene.faces)), "elements": int(scene.n_elements)}
    if cold:
        return {**out, "load_cpu_s": time.process_time() - t_cpu, "load_peak_mb": _rss_mb("VmHWM")}
    square = np.array([[0, 0, 0], [1, 0, 0], [0, 1, 0], [1, 1, 0]], float)
    coincident_face_pairs(square, np.array([[0, 1, 2], [1, 3, 2]]), np.array([0, 1]))  # warm-up: compiled kernels
    before = _rss_mb("VmRSS")
    try:  # reset the high-water mark to the present (Linux), so the peak is the search's
        with open("/proc/self/clear_refs", "w") as fh:
            fh.write("5")
        reset = True
    except OSError:
        reset = False
    t_cpu, t_wall = time.process_time(), time.perf_counter()
    pairs = coincident_face_pairs(scene.vertices, scene.faces, scene.face_element)
    cpu, wall = time.process_time() - t_cpu, time.perf_counter() - t_wall
    peak = _rss_mb("VmHWM")
    tied_faces, tied_elements = tie_summary(pairs, scene.face_element)
    return {**out, "pairs": int(len(pairs)), "tied_faces": tied_faces, "tied_elements": tied_elements,
            "search_cpu_s": cpu, "search_wall_s": wall, "rss_before_mb": before,
            "search_peak_mb": peak if reset else None, "search_rise_mb": peak - before if reset else None,
            "same_as_load": bool(np.array_equal(pairs, scene.tie_pairs()))}


def generated_models(quick: bool, pipes_size: tuple[int, int] | None) -> list[tuple[str, Path]]:
    """The generated pipe network (written once into WORKDIR) and, unless ``quick``, the restaurant."""
    sys.path.insert(0, str(HERE))
    import pipe_network
    import revit_like

    WORKDIR.mkdir(parents=True, exist_ok=True)
    size = pipe_network.SMALL if quick else pipe_network.BIG if pipes_size is None else {"storeys": pipes_size[0],
                                                                         "bays": pipes_size[1]}
    found = [(f"pipe network, {size['storeys']} storeys × {size['bays']} bays",
              pipe_network.generated(WORKDIR / "pipes-{storeys}s-{bays}b.ifc".format(**size), **size)[0])]
    if not quick:
        found.append(("restaurant", revit_like.generated(WORKDIR / "restaurant.ifc", **revit_like.RESTAURANT)[0]))
    return found


def search_rows(named: list[tuple[str, Path]], console: Console) -> list[dict]:
    """The tie search on each model, each step in a fresh interpreter with its own cache folder."""
    import shutil

    from run import run_script

    rows = []
    for name, path in named:
        cache = WORKDIR / "cache" / path.stem
        shutil.rmtree(cache, ignore_errors=True)
        row = {"name": name}
        for cold in (True, False):
            proc, result, wall = run_script(__file__, ["--search-child", str(path), "--cache", str(cache)]
                                            + (["--cold"] if cold else []), SEARCH_PREFIX, capture_stderr=True)
            if result is None:
                raise SystemExit(f"{name}: the tie search failed (exit {proc.returncode}): {proc.stderr[-2000:]}")
            row.update(result)
        shutil.rmtree(cache, ignore_errors=True)
        console.print(f"{name}: {row['triangles']:,} triangles, {row['pairs']:,} pairs, "
                      f"{row['search_cpu_s']:.2f} CPU-s, peak {row['search_peak_mb'] or 0:,.0f} MB")
        rows.append(row)
    return rows


def search_table(rows: list[dict]):
    table = numeric_table(("model", "triangles", "elements", "tie pairs", "tied faces (elements)", "search CPU s",
                           "peak MB (rise)", "cold load CPU s"), left=("model",),
                          title="the tie search alone, after a load from the cache")
    for r in rows:
        table.add_row(r["name"], f"{r['triangles']:,}", f"{r['elements']:,}", f"{r['pairs']:,}",
                      f"{r['tied_faces']:,} ({r['tied_elements']:,})", f"{r['search_cpu_s']:.2f}",
                      f"{r['search_peak_mb']:,.0f} (+{r['search_rise_mb']:,.0f})" if r["search_peak_mb"] else "?",
                      f"{r['load_cpu_s']:.1f}")
    return table


NAMES = {"duplex.ifc": "Duplex (sample)", "Ifc2s3_Duplex_Electrical.ifc": "Duplex electrical",
         "IfcOpenHouse_IFC4.ifc": "IfcOpenHouse (IFC4)", "construction_scheduling_task.ifc": "construction scheduling task",
         "BERNTS-Staalconstructie.ifc": "Schependomlaan steel", "MULTICOM-Prefab.ifc": "Schependomlaan prefab",
         "XELLA-Begane grond.ifc": "Schependomlaan ground floor"}


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--quick", action="store_true", help="the bundled Duplex only")
    parser.add_argument("--model", type=Path, action="append", default=None,
                        help="these models instead (repeatable), e.g. the 3 M-triangle file benchmarks/revit_like.py "
                             "writes; the results go to ties-models.json")
    parser.add_argument("--search-only", action="store_true", help="only the tie search (into ties.json's 'search')")
    parser.add_argument("--pipes", type=int, nargs=2, metavar=("STOREYS", "BAYS"), default=None,
                        help="the size of the generated pipe network (default pipe_network.BIG)")
    parser.add_argument("--search-child", type=Path, help=argparse.SUPPRESS)
    parser.add_argument("--cache", type=Path, help=argparse.SUPPRESS)
    parser.add_argument("--cold", action="store_true", help=argparse.SUPPRESS)
    args = parser.parse_args()
    if args.search_child:
        print(SEARCH_PREFIX + json.dumps(search_child(args.search_child, args.cache, args.cold)), flush=True)
        return
    console = Console(width=170)
    out = HERE / ("ties-models.json" if args.model else "ties.json")
    named = [(p.name if args.model else NAMES.get(p.name, p.name), p) for p in args.model or models(args.quick)]
    if not args.model:
        named += generated_models(args.quick, args.pipes)
    searched = search_rows(named, console)
    console.print(search_table(searched))
    if args.search_only:
        previous = json.loads(out.read_text()) if out.is_file() else {}
        out.write_text(json.dumps({**previous, "search": searched}, indent=1, default=float))
        console.print(f"wrote {out}")
        return
    rows = []
    for path in args.model or models(args.quick):
        console.print(f"[bold]{path.name}[/]")
        rows.append(study(path))
    table = numeric_table(("model", "tied faces (elements)", "ties", "V", "VC %", "VR", "R mm/px", "O °",
                           "changed by 0.1 mm", "s/frame", "s/frame 20 MP"), left=("model", "ties", "changed by 0.1 mm"),
                          title=f"{FRAMES}-frame ring, P4P at scale {SCALE}: planned → moved by 0.1 mm")
    for r in rows:
        for label in ("without_ties", "with_ties"):
            x = r[label]
            a, b = x["planned"], x["moved"]

            def pair(k, fmt, a=a, b=b):
                return fmt(a[k]) if fmt(a[k]) == fmt(b[k]) else f"{fmt(a[k])} → {fmt(b[k])}"

            table.add_row(r["model"] if label == "without_ties" else "",
                          f"{r['tied_faces']:,} ({r['tied_elements']})" if label == "without_ties" else "",
                          "off" if label == "without_ties" else "on",
                          pair("n_visible", str), pair("VC", lambda v: f"{100 * v:.2f}"),
                          pair("VR", lambda v: f"{v:.4f}"), pair("R", lambda v: f"{1000 * v:.4f}"),
                          pair("O", lambda v: f"{v:.4f}"), ", ".join(x["changed"]) or "none",
                          f"{x['s_per_frame']:.3f}", f"{x['s_per_frame_full']:.3f}")
    console.print(table)
    out.write_text(json.dumps({"frames": FRAMES, "scale": SCALE, "shift_m": SHIFT_M, "models": rows,
                               "search": searched}, indent=1, default=float))
    console.print(f"wrote {out}")


if __name__ == "__main__":
    main()
