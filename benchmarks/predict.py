"""A calibrated prediction of per-element completeness from the plan's metrics, fitted and tested leave one model out.

    python benchmarks/predict.py [--model sample --model PATH ...] [--scale 0.1] [--photo-realism noise]
                                 [--out benchmarks/predict.json] [--collect-only] [--fit-only] [--bundle]

For each model (by default ``benchmarks/loop.py``'s three, the Duplex, IfcOpenHouse and the Schependomlaan XELLA
ground floor, and the Schependomlaan precast concrete), the facade grid and the orbit of ``benchmarks/loop.py``
(P4P, 10 m safety distance) go through the closed loop at ``--scale`` (render, pycolmap, measure). A run whose
reconstruction is already in the work folder (``benchmarks/.cache/loop/…``, as ``loop.py`` leaves it) is measured
again without rendering or reconstructing; a run whose SfM places fewer than three images gives no rows and is
listed as skipped. Per target element, the predictors of :mod:`sightplan.predict.columns` (the plan metrics, the
feature seen share, the triangulation angles) beside the measured completeness go to each run's
``predictors.csv``. Then, leaving each model out in turn, the predictor is fitted on the others and judged on it:
Pearson r between predicted and measured completeness, the calibration slope, and beside it the single predictor
with the largest |r| on the fitted models and its r on the held-out one; three feature sets are compared so.
Writes ``--out`` (the tables, the reliability bins, the model fitted on every model),
``benchmarks/predict_reliability.png`` beside it and, with ``--bundle``, the fitted model as
``src/sightplan/data/completeness_model.json``.
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
                  str(SHARED / "data" / "schependomlaan" / "XELLA-Begane grond.ifc"),
                  str(SHARED / "data" / "schependomlaan" / "MULTICOM-Prefab.ifc")]
PLANS = ("facade", "orbit")
ROW_FIELDS = ("model", "plan", "global_id", *PREDICTOR_COLUMNS, "loop_seen_share", "points", "completeness")


def collect(models: list[str], scale: float, preset: str, work: Path, fallback: bool = False
            ) -> tuple[list[dict], list[dict]]:
    """Run (or reuse) the loop of every model × plan, writing each run's per-element rows; one summary per run,
    and the runs skipped. ``fallback``: measure a plan in which no element reaches Ω pixels with
    :func:`fallback_tolerance`'s τ."""
    cam = get_camera("p4p")
    flight = FlightSettings(safety_distance_m=10.0)
    runs, skipped = [], []
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
            kwargs = {"scale": scale, "paper_table": False, "labels": {"model": label, "plan": name},
                      "photo_options": photo_options(preset)}
            try:
                res = loop(scene, plan, out, reconstruction=recon if reuse else None, **kwargs)
                tolerance = None
            except SightplanError as exc:
                if "structure from motion registered only" in str(exc):
                    print(f"{label} {name}: {exc}; no rows (nothing to measure)")
                    skipped.append({"model": label, "plan": name, "frames": len(plan), "skipped": str(exc)})
                    continue
                if "no element is visible" not in str(exc):
                    raise
                if not fallback:
                    print(f"{label} {name}: {exc}; no rows (the measures' τ needs an element seen by Ω pixels; "
                          "--fallback-tolerance sets one from every observed element)")
                    skipped.append({"model": label, "plan": name, "frames": len(plan), "skipped": str(exc)})
                    continue
                tolerance = fallback_tolerance(scene, plan, scale, recon)
                print(f"{label} {name}: no element reaches Ω pixels; τ from every observed element's ρ: "
                      f"{tolerance:.4f} m")
                res = loop(scene, plan, out, reconstruction=recon, tolerance_m=tolerance, **kwargs)
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
                         "fallback_tolerance_m": tolerance,
                         "photo_pixels": sorted(cams), "seconds": round(time.perf_counter() - t, 1),
                         "rows": _relative(out / "predictors.csv")})
            print(json.dumps(runs[-1]), flush=True)
    return runs, skipped


def _relative(path: Path) -> str:
    """``path`` relative to the repository when inside it (how runs.json and the result name a run's rows)."""
    try:
        return str(path.resolve().relative_to(HERE.parent.resolve()))
    except ValueError:
        return str(path)


def fallback_tolerance(scene, plan, scale: float, recon: Path) -> float:
    """τ = 1.2·e + 3·ρ as the loop's measures set it, with ρ the median surface sampling distance over every
    observation of a target element (the loop's own ρ needs an element seen by Ω pixels)."""
    from sightplan.evaluate import evaluate
    from sightplan.loop.files import read_reconstruction
    from sightplan.loop.run import photographed_plan

    obs = evaluate(scene, photographed_plan(plan, scale), cache_dir=False).observations
    rho = float(np.median(obs.ssd[obs.is_target[obs.element]]))
    e = read_reconstruction(recon).residual_m
    return 1.2 * (e if np.isfinite(e) else 0.0) + 3.0 * rho


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
    ap.add_argument("--ridge", type=float, default=RIDGE, help="the fits' L2 penalty on the standardised slopes")
    ap.add_argument("--fallback-tolerance", action="store_true",
                    help="measure a plan in which no element reaches Ω pixels with τ from every observed element")
    ap.add_argument("--bundle", action="store_true", help=f"write the model fitted on every model to {BUNDLED.name}")
    args = ap.parse_args(argv)
    suffix = "" if args.photo_realism == "noise" else f"-{args.photo_realism}"
    work = Path(args.work or HERE / ".cache" / f"loop{suffix}")
    out = Path(args.out or HERE / f"predict{suffix}.json")
    t0 = time.perf_counter()
    if args.fit_only:
        runs = json.loads((work / "runs.json").read_text(encoding="utf-8"))
    else:
        runs, skipped = collect(args.model or DEFAULT_MODELS, args.scale, args.photo_realism, work,
                                args.fallback_tolerance)
        print(f"collected {len(runs)} runs in {time.perf_counter() - t0:.0f} s, peak "
              f"{resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024:.0f} MB")
        runs = merge_runs(work / "runs.json", runs, skipped)
    if args.collect_only:
        return 0
    result = fit(runs, args, out)
    gone = work / "skipped.json"
    result["skipped"] = json.loads(gone.read_text(encoding="utf-8")) if gone.is_file() else []
    result["seconds"] = round(time.perf_counter() - t0, 1)
    out.write_text(json.dumps(result, indent=1, allow_nan=False) + "\n", encoding="utf-8")
    print(f"wrote {out} in {result['seconds']} s")
    return 0


def merge_runs(path: Path, runs: list[dict], skipped: list[dict]) -> list[dict]:
    """The runs recorded in ``path`` with ``runs`` in place of those of the same model and plan (and without the
    ``skipped`` ones, kept in ``skipped.json`` beside it); written back."""
    old = json.loads(path.read_text(encoding="utf-8")) if path.is_file() else []
    new = {(r["model"], r["plan"]) for r in runs + skipped}
    merged = [r for r in old if (r["model"], r["plan"]) not in new] + runs
    path.write_text(json.dumps(merged, indent=1) + "\n", encoding="utf-8")
    gone = path.with_name("skipped.json")
    before = json.loads(gone.read_text(encoding="utf-8")) if gone.is_file() else []
    gone.write_text(json.dumps([r for r in before if (r["model"], r["plan"]) not in new] + skipped, indent=1) + "\n",
                    encoding="utf-8")
    return merged


SINGLES = (*PREDICTOR_COLUMNS, "loop_seen_share")
#: The feature sets compared leave one model out: the paper's plan metrics alone (with the pixels and the seen
#: share), with the triangulation angles, and with the stable views too (``FEATURES``, the bundled model's).
FEATURE_SETS = {"plan metrics": ("log_VR", "visible", "log_R", "O", "log_pixels", "seen_share"),
                "plan metrics + triangulation": ("log_VR", "visible", "log_R", "O", "log_pixels", "seen_share",
                                                 "tri_median", "tri_matchable", "triangulable", "log_views"),
                "all": FEATURES}


def _f(v, digits=2) -> str:
    return "—" if v is None else f"{v:.{digits}f}"


def fit(runs: list[dict], args, out: Path) -> dict:
    """Leave one model out, the model fitted on all, the plot; prints the tables, returns the result."""
    d = read_rows([HERE.parent / r["rows"] for r in runs])
    c = d["completeness"]
    ok = np.isfinite(c)
    d = {k: v[ok] for k, v in d.items()}
    c, groups = d["completeness"], d["model"].astype(str)
    singles = {k: d[k] for k in SINGLES}
    compared = {}
    for name, feats in FEATURE_SETS.items():
        h, p = leave_one_out(feature_matrix(d, feats), c, groups, singles, features=feats, ridge=args.ridge)
        compared[name] = {"features": list(feats), "pooled": calibration(p, c).to_dict(),
                          "held_out": {x.group: {"n": x.n, "r": x.calibration.r, "slope": x.calibration.slope}
                                       for x in h}}
    X = feature_matrix(d)
    held, pred = leave_one_out(X, c, groups, singles, ridge=args.ridge)
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
    model = fit_completeness(X, c, weights=group_weights(groups), info=info, ridge=args.ridge)
    model = model.with_intervals(pred, c)
    lomo = {"pooled": pooled.to_dict(), "held_out": [h.to_dict() for h in held], "feature_sets": compared}
    model.info["lomo"] = {"r": pooled.r, "slope": pooled.slope, "per_model": {
        h.group: {"n": h.n, "r": h.calibration.r, "slope": h.calibration.slope, "coverage": h.coverage,
                  "best_single": h.best_single, "best_single_r": h.best_single_r,
                  "best_single_r_aligned": h.best_single_aligned} for h in held}}
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
    print("\n| held-out model | predictor r | best single metric (on the fitted models) | its r there | its r held out "
          "| signed as fitted | largest single |r| held out |")
    print("|---|---:|---|---:|---:|---:|---|")
    for h in held:
        top = max(((k, v) for k, v in h.single_r.items() if v is not None), key=lambda kv: abs(kv[1]),
                  default=(None, None))
        print(f"| {h.group} | {_f(h.calibration.r)} | {h.best_single} | {_f(h.best_single_r_fitted)} | "
              f"{_f(h.best_single_r)} | {_f(h.best_single_aligned)} | {top[0]} ({_f(top[1])}) |")
    print("\n| features | " + " | ".join(f"{h.group} r (slope)" for h in held) + " | all held out r (slope) |")
    print("|---|" + "---:|" * (len(held) + 1))
    for name, v in compared.items():
        cells = [f"{_f(v['held_out'][h.group]['r'])} ({_f(v['held_out'][h.group]['slope'])})" for h in held]
        print(f"| {name} | " + " | ".join(cells) + f" | {_f(v['pooled']['r'])} ({_f(v['pooled']['slope'])}) |")
    return {"photo_realism": preset, "scale": args.scale, "camera": "p4p", "safety_distance_m": 10.0,
            "plans": list(PLANS), "features": list(FEATURES), "ridge": args.ridge, "runs": runs, "lomo": lomo,
            "model": model.to_dict(), "plot": plot.name}


if __name__ == "__main__":
    raise SystemExit(main())
