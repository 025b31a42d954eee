"""A calibrated prediction of per-element completeness from the plan's metrics, fitted and tested leave one model out.

    python benchmarks/predict.py [--model sample --model PATH ...] [--scale 0.1] [--photo-realism noise]
                                 [--out benchmarks/predict.json] [--collect-only] [--fit-only]

For each model, the facade grid and the orbit of ``benchmarks/loop.py`` (P4P, 10 m safety distance) go through the
closed loop at ``--scale`` (render, pycolmap, measure; a run whose reconstruction is already in the work folder,
``benchmarks/.cache/loop/…`` as ``loop.py`` leaves it, is measured again without rendering or reconstructing).
Per target element, the predictors of :mod:`sightplan.predict.columns` (the plan metrics, the feature seen share,
the triangulation angles) beside the measured completeness go to ``rows.csv`` in the work folder. Then, leaving
each model out in turn, the predictor is fitted on the others and judged on it: Pearson r between predicted and
measured completeness, the calibration slope, and beside it the single predictor with the largest |r| on the
fitted models and its r on the held-out one. Writes ``--out`` (the tables, the reliability bins, the model fitted
on every model), ``reliability.png`` beside it (``benchmarks/predict_reliability.png``) and, with ``--bundle``, the
fitted model as ``src/sightplan/data/completeness_model.json``.
"""

from __future__ import annotations

import argparse
import csv
import json
import resource
import time
from pathlib import Path

import numpy as np

from sightplan.camera.catalogue import get_camera
from sightplan.errors import SightplanError
from sightplan.evaluate import scene_features
from sightplan.loop import loop
from sightplan.loop.photo import photo_options
from sightplan.metrics import MetricParams
from sightplan.model.load import load_model
from sightplan.plan.checks.feasibility import FlightSettings
from sightplan.plan.templates.registry import plan_from_template
from sightplan.predict.columns import PREDICTOR_COLUMNS, predictor_columns
from sightplan.predict.model import (
    BUNDLED,
    FEATURES,
    RIDGE,
    calibration,
    feature_matrix,
    fit_completeness,
    group_weights,
    leave_one_out,
)
from sightplan.predict.plot import plot_reliability
from sightplan.study import read_study

HERE = Path(__file__).parent
SHARED = HERE.parent.parent / "shared"
if not (SHARED / "data").is_dir():
    SHARED = Path("/work/shared")
DEFAULT_MODELS = ["sample", str(SHARED / "data" / "ifc" / "IfcOpenHouse_IFC4.ifc"),
                  str(SHARED / "data" / "schependomlaan" / "XELLA-Begane grond.ifc")]
PLANS = ("facade", "orbit")
ROW_FIELDS = ("model", "plan", "global_id", *PREDICTOR_COLUMNS, "loop_seen_share", "points", "completeness")


def collect(models: list[str], scale: float, preset: str, work: Path) -> list[dict]:
    """Run (or reuse) the loop of every model × plan; the per-element rows, and one summary per run."""
    cam = get_camera("p4p")
    flight = FlightSettings(safety_distance_m=10.0)
    runs = []
    for model in models:
        scene, _ = load_model(model)
        label = "Duplex (sample)" if model == "sample" else Path(model).stem
        for name in PLANS:
            try:
                plan, _ = plan_from_template(name, scene, cam, {}, flight)
            except SightplanError as exc:
                print(f"{label} {name}: {exc}")
                continue
            out = work / Path(model).stem.replace(" ", "_") / name
            recon = out / "recon"
            reuse = (recon / "registration.json").is_file()
            t = time.perf_counter()
            res = loop(scene, plan, out, scale=scale, paper_table=False, labels={"model": label, "plan": name},
                       reconstruction=recon if reuse else None, photo_options=photo_options(preset))
            ev, photo, m = res.evaluation, res.plan, res.measures
            fs = scene_features(scene, ev.settings)
            if fs.key != ev.observations.meta.get("features"):
                raise SystemExit(f"{label} {name}: the features differ from the evaluation's")
            cols = predictor_columns(ev.observations, photo.C_world, fs.points, fs.element, metrics=ev.metrics)
            t_idx = np.flatnonzero(ev.metrics.elements.is_target & m.is_target)
            st = res.study.columns
            if not np.array_equal(m.global_id[t_idx], st["global_id"]):
                raise SystemExit(f"{label} {name}: the study's elements differ from the measures'")
            rows = [{"model": label, "plan": name, "global_id": str(g),
                     **{k: float(cols[k][i]) for k in PREDICTOR_COLUMNS},
                     "loop_seen_share": float(st["seen_share"][j]), "points": float(st["points"][j]),
                     "completeness": float(st["completeness"][j])}
                    for j, (i, g) in enumerate(zip(t_idx, st["global_id"], strict=True))]
            _write_rows(rows, out / "predictors.csv")
            rec = res.reconstruction
            cams = {c.width * c.height for c in photo.cameras.values()}
            runs.append({"model": label, "plan": name, "frames": len(plan), "registered": rec.n_registered,
                         "points": len(rec.points), "elements": len(rows), "reused_reconstruction": reuse,
                         "photo_pixels": sorted(cams), "seconds": round(time.perf_counter() - t, 1),
                         "rows": str(out / "predictors.csv")})
            print(json.dumps(runs[-1]), flush=True)
    return runs


def _write_rows(rows: list[dict], path: Path) -> None:
    with open(path, "w", newline="", encoding="utf-8") as fh:
        w = csv.DictWriter(fh, fieldnames=list(ROW_FIELDS))
        w.writeheader()
        for r in rows:
            w.writerow({k: (f"{v:.6g}" if isinstance(v, float) else v) for k, v in r.items()})


def read_rows(paths: list[Path]) -> dict[str, np.ndarray]:
    """The rows of every run's ``predictors.csv``, as columns (numbers as floats, blank as NaN)."""
    cols: dict[str, list] = {k: [] for k in ROW_FIELDS}
    for path in paths:
        with open(path, newline="", encoding="utf-8") as fh:
            for r in csv.DictReader(fh):
                for k in ROW_FIELDS:
                    v = r[k]
                    cols[k].append(v if k in ("model", "plan", "global_id") else (float(v) if v not in ("", "nan")
                                                                                  else np.nan))
    return {k: np.array(v, dtype=object if k in ("model", "plan", "global_id") else float) for k, v in cols.items()}


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--model", action="append")
    ap.add_argument("--scale", type=float, default=0.1)
    ap.add_argument("--photo-realism", default="noise")
    ap.add_argument("--work", default=None, help="default: benchmarks/.cache/loop (noise) or loop-PRESET")
    ap.add_argument("--out", default=None, help="default: benchmarks/predict.json (noise) or predict-PRESET.json")
    ap.add_argument("--collect-only", action="store_true")
    ap.add_argument("--fit-only", action="store_true", help="fit on the rows of the runs the work folder holds")
    ap.add_argument("--bundle", action="store_true", help=f"write the model fitted on every model to {BUNDLED.name}")
    args = ap.parse_args(argv)
    suffix = "" if args.photo_realism == "noise" else f"-{args.photo_realism}"
    work = Path(args.work or HERE / ".cache" / f"loop{suffix}")
    out = Path(args.out or HERE / f"predict{suffix}.json")
    t0 = time.perf_counter()
    if args.fit_only:
        runs = json.loads((work / "runs.json").read_text(encoding="utf-8"))
    else:
        runs = collect(args.model or DEFAULT_MODELS, args.scale, args.photo_realism, work)
        print(f"collected {len(runs)} runs in {time.perf_counter() - t0:.0f} s, peak "
              f"{resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024:.0f} MB")
        (work / "runs.json").write_text(json.dumps(runs, indent=1) + "\n", encoding="utf-8")
    if args.collect_only:
        return 0
    result = fit(runs, args, out)
    result["seconds"] = round(time.perf_counter() - t0, 1)
    out.write_text(json.dumps(result, indent=1, allow_nan=False) + "\n", encoding="utf-8")
    print(f"wrote {out} in {result['seconds']} s")
    return 0


SINGLES = (*PREDICTOR_COLUMNS, "loop_seen_share")


def _f(v, digits=2) -> str:
    return "—" if v is None else f"{v:.{digits}f}"


def fit(runs: list[dict], args, out: Path) -> dict:
    """Leave one model out, the model fitted on all, the plot; prints the tables, returns the result."""
    d = read_rows([Path(r["rows"]) for r in runs])
    c = d["completeness"]
    ok = np.isfinite(c)
    d = {k: v[ok] for k, v in d.items()}
    c, groups = d["completeness"], d["model"].astype(str)
    X = feature_matrix(d)
    singles = {k: d[k] for k in SINGLES}
    held, pred = leave_one_out(X, c, groups, singles)
    pooled = calibration(pred, c)
    table2 = SHARED / "spec" / "table2.csv"
    paper = read_study(table2 if table2.is_file() else BUNDLED.parent / "table2.csv")
    preset = args.photo_realism
    plot = out.with_name(out.stem + "_reliability.png")
    plot_reliability(held, pred, c, groups, plot, paper=paper,
                     title=f"completeness predicted per element, photographs '{preset}' at render scale {args.scale:g}")
    info = {"fitted_on": sorted(set(groups.tolist())), "plans": list(PLANS), "camera": "p4p",
            "render_scale": args.scale, "photo_pixels": sorted({p for r in runs for p in r["photo_pixels"]}),
            "photo_realism": preset, "elements": int(len(c)), "weights": "each model equally",
            "metric": MetricParams().to_dict()}
    model = fit_completeness(X, c, weights=group_weights(groups), info=info)
    model = model.with_intervals(pred, c)
    lomo = {"pooled": pooled.to_dict(), "held_out": [h.to_dict() for h in held]}
    model.info["lomo"] = {"r": pooled.r, "slope": pooled.slope, "per_model": {
        h.group: {"n": h.n, "r": h.calibration.r, "slope": h.calibration.slope, "coverage": h.coverage,
                  "best_single": h.best_single, "best_single_r": h.best_single_r} for h in held}}
    if args.bundle:
        model.write(BUNDLED)
        print(f"wrote {BUNDLED}")
    print(f"\nleave one model out ({len(c)} elements with a measured completeness; photographs '{preset}', "
          f"render scale {args.scale:g}):")
    print("| held-out model | n | predictor r | calibration slope | bias | 90 % interval coverage |")
    print("|---|---:|---:|---:|---:|---:|")
    for h in held:
        cal = h.calibration
        print(f"| {h.group} | {h.n} | {_f(cal.r)} | {_f(cal.slope)} | {_f(cal.bias, 3)} | {_f(h.coverage)} |")
    print(f"| all held out | {pooled.n} | {_f(pooled.r)} | {_f(pooled.slope)} | {_f(pooled.bias, 3)} | |")
    print("\n| held-out model | best single metric (on the fitted models) | its r there | its r held out | "
          "largest single |r| held out |")
    print("|---|---|---:|---:|---|")
    for h in held:
        top = max(((k, v) for k, v in h.single_r.items() if v is not None), key=lambda kv: abs(kv[1]),
                  default=(None, None))
        print(f"| {h.group} | {h.best_single} | {_f(h.best_single_r_fitted)} | {_f(h.best_single_r)} | "
              f"{top[0]} ({_f(top[1])}) |")
    return {"photo_realism": preset, "scale": args.scale, "camera": "p4p", "safety_distance_m": 10.0,
            "plans": list(PLANS), "features": list(FEATURES), "ridge": RIDGE, "runs": runs, "lomo": lomo,
            "model": model.to_dict(), "plot": plot.name}


if __name__ == "__main__":
    raise SystemExit(main())
