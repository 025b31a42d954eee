"""Coincident surfaces (ties): do the plan metrics hold when every camera moves by 0.1 mm, and what do ties cost?

`python benchmarks/ties.py` (or `--quick`: the Duplex only). For the bundled Duplex and each IFC model in
../shared/data: the faces flush with another element's (found when the model is loaded), then a 36-frame ring
(DJI Phantom 4 Pro, scale 0.25, the Embree engine) evaluated four times: without and with ties (METRICS.md §2),
each at the planned poses and with every camera moved by 0.1 mm along (1, 1, 1)/√3. Reports V, VC, VR, R, O for each,
whether they changed with the shift (V, VC, VR exactly, R and O beyond 10⁻³ relative), and the seconds per frame
with and without ties: of the whole ring at scale 0.25, and the best of three full-resolution (20 MP) runs of six of
its frames. Writes benchmarks/ties.json.
"""

from __future__ import annotations

import argparse
import json
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


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--quick", action="store_true", help="the bundled Duplex only")
    parser.add_argument("--model", type=Path, action="append", default=None,
                        help="these models instead (repeatable), e.g. the 3 M-triangle file benchmarks/revit_like.py "
                             "writes; the results go to ties-models.json")
    args = parser.parse_args()
    console = Console(width=170)
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
    out = HERE / ("ties-models.json" if args.model else "ties.json")
    out.write_text(json.dumps({"frames": FRAMES, "scale": SCALE, "shift_m": SHIFT_M, "models": rows}, indent=1,
                              default=float))
    console.print(f"wrote {out}")


if __name__ == "__main__":
    main()
