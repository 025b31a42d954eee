"""The closed loop over real models: do the predicted metrics come true per element?

    python benchmarks/loop.py [--model sample --model PATH ...] [--scale 0.1] [--out benchmarks/loop.json]

For each model, a facade grid and an orbit (P4P, 10 m safety distance, the templates' defaults) are rendered at
``--scale`` of the camera's resolution, reconstructed with pycolmap, and measured per element (``sightplan loop``).
The per-element rows of every run are pooled: Pearson and Spearman r (with p and n) of each predictor (VR_i, R_i,
O_i, pixels, seen share) against the measured completeness, per plan type and over all, beside the paper's
Table 2; frames: ν_f against registered. Writes ``benchmarks/loop.json``, the ``loop`` entry of
``benchmarks/results.json`` and each run's page under ``benchmarks/.cache/loop/``.
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
from sightplan.loop import loop
from sightplan.loop.study import correlation
from sightplan.model.load import load_model
from sightplan.plan.checks.feasibility import FlightSettings
from sightplan.plan.templates.registry import plan_from_template
from sightplan.study import read_study

HERE = Path(__file__).parent
SHARED = HERE.parent.parent / "shared"
DEFAULT_MODELS = ["sample", str(SHARED / "data" / "ifc" / "IfcOpenHouse_IFC4.ifc"),
                  str(SHARED / "data" / "schependomlaan" / "XELLA-Begane grond.ifc")]
PLANS = ("facade", "orbit")
PREDICTORS = ("VR", "R", "O", "pixels", "seen_share")
PAPER = {"VR": "VR", "R": "R", "O": "O", "seen_share": "VC"}


def _pair(x: np.ndarray, y: np.ndarray) -> dict:
    c = correlation("", "", x, y)
    rounded = lambda r: None if r is None else round(r, 3)  # noqa: E731
    return {"n": c.n, "pearson_r": rounded(c.pearson_r), "pearson_p": c.pearson_p,
            "spearman_r": rounded(c.spearman_r), "spearman_p": c.spearman_p}


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--model", action="append")
    ap.add_argument("--scale", type=float, default=0.1)
    ap.add_argument("--work", default=str(HERE / ".cache" / "loop"))
    ap.add_argument("--out", default=str(HERE / "loop.json"))
    args = ap.parse_args(argv)
    table2 = SHARED / "spec" / "table2.csv"
    paper = read_study(table2) if table2.is_file() else None
    cam = get_camera("p4p")
    flight = FlightSettings(safety_distance_m=10.0)
    runs, pooled, frames = [], {p: {k: [] for k in (*PREDICTORS, "completeness")} for p in PLANS}, []
    t_all = time.perf_counter()
    for model in args.model or DEFAULT_MODELS:
        scene, _ = load_model(model)
        for name in PLANS:
            try:
                plan, _ = plan_from_template(name, scene, cam, {}, flight)
            except SightplanError as exc:
                print(f"{Path(model).name} {name}: {exc}")
                continue
            t = time.perf_counter()
            out = Path(args.work) / Path(model).stem.replace(" ", "_") / name
            res = loop(scene, plan, out, scale=args.scale, paper_table=paper,
                       labels={"model": Path(model).name, "plan": name})
            cols = res.study.columns
            for k in (*PREDICTORS, "completeness"):
                pooled[name][k].append(np.asarray(cols[k], float))
            m = res.measures
            frames.append((m.nu.astype(float), m.registered.astype(float)))
            rec = res.reconstruction
            row = {"model": Path(model).name, "plan": name, "frames": len(plan), "registered": rec.n_registered,
                   "points": len(rec.points), "residual_m": round(rec.residual_m, 4),
                   "residual_pct": round(100 * rec.residual_share, 3), "elements": res.study.n_elements,
                   "seconds": round(time.perf_counter() - t, 1),
                   "timings_s": {k: round(v, 1) for k, v in res.timings.items()}}
            runs.append(row)
            print(json.dumps(row))
    result = {"scale": args.scale, "camera": "p4p", "safety_distance_m": 10.0, "runs": runs, "correlations": {}}
    for group in (*PLANS, "all"):
        names = PLANS if group == "all" else (group,)
        col = {k: np.concatenate([a for p in names for a in pooled[p][k]]) if any(pooled[p][k] for p in names)
               else np.zeros(0) for k in (*PREDICTORS, "completeness")}
        result["correlations"][group] = {
            p: {**_pair(col[p], col["completeness"]),
                "paper_r_Ce": paper.pair(PAPER[p], "Ce").r if paper is not None and p in PAPER else None,
                "paper_r_Cv": paper.pair(PAPER[p], "Cv").r if paper is not None and p in PAPER else None}
            for p in PREDICTORS}
        result["correlations"][group]["elements"] = int(len(col["completeness"]))
    if frames:
        nu = np.concatenate([f[0] for f in frames])
        reg = np.concatenate([f[1] for f in frames])
        result["frames"] = {"nu_vs_registered": _pair(nu, reg), "frames": int(len(nu)),
                            "registered": int(reg.sum())}
    result["seconds"] = round(time.perf_counter() - t_all, 1)
    result["peak_rss_mb"] = round(resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024)
    Path(args.out).write_text(json.dumps(result, indent=1) + "\n", encoding="utf-8")
    combined = HERE / "results.json"
    if combined.exists() and Path(args.out).resolve() == (HERE / "loop.json").resolve():
        data = json.loads(combined.read_text(encoding="utf-8"))
        data["loop"] = result
        combined.write_text(json.dumps(data, indent=1) + "\n", encoding="utf-8")
    print(json.dumps(result["correlations"]["all"], indent=1))
    print(f"wrote {args.out} in {result['seconds']} s")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
