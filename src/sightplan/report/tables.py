"""Per-element and per-frame result tables (CSV), and the report JSON."""

from __future__ import annotations

import csv
import json
import math
import platform
from pathlib import Path

import numpy as np

from ..evaluate import Evaluation
from ..model.scene import Scene
from ..plan.types import Plan
from ..predict.apply import CompletenessPrediction
from ..version import __version__


def json_number(x: float) -> float | None:
    """A JSON-safe number: None for NaN/inf."""
    x = float(x)
    return x if math.isfinite(x) else None


def _cell(x) -> str:
    if isinstance(x, float | np.floating):
        return "" if not math.isfinite(x) else f"{float(x):.6g}"
    return str(x)


def element_rows(ev: Evaluation, scene: Scene, prediction: CompletenessPrediction | None = None) -> list[dict]:
    """One row per target element of the scene at its date, in element order; with ``prediction``, its predicted
    completeness and interval (blank where no frame sees the element)."""
    em, el = ev.metrics.elements, scene.elements
    rows = []
    for i in np.flatnonzero(em.is_target):
        row = {
            "index": int(i), "global_id": el.global_id[i], "name": el.name[i], "ifc_class": el.ifc_class[i],
            "discipline": el.discipline[i], "storey": el.storey[i],
            "visibility": "visible" if em.visible[i] else ("observed" if em.observed[i] else "unseen"),
            "VR_i": int(em.VR[i]), "R_i_m_per_px": em.R[i], "O_i_deg": em.O[i],
            "frames_observed": int(em.frames_observed[i]), "pixels_total": em.pixels_total[i],
        }
        if prediction is not None:
            row.update({"predicted_completeness": float(prediction.predicted[i]),
                        "predicted_low": float(prediction.low[i]), "predicted_high": float(prediction.high[i])})
        rows.append(row)
    return rows


def frame_rows(ev: Evaluation, plan: Plan) -> list[dict]:
    fm = ev.metrics.frames
    C = plan.C_world
    return [{
        "index": f, "name": plan.frame_names[f], "camera": plan.frame_camera[f],
        "x": C[f, 0], "y": C[f, 1], "z": C[f, 2],
        "nu_f": int(fm.nu[f]), "stable": bool(fm.stable[f]), "features_observed": int(fm.features_observed[f]),
        "elements_visible": int(fm.elements_visible[f]), "pixels_on_targets": fm.pixels_on_targets[f],
    } for f in range(len(plan))]


def write_csv(rows: list[dict], path: Path) -> None:
    with open(path, "w", newline="", encoding="utf-8") as fh:
        if not rows:
            fh.write("")
            return
        w = csv.DictWriter(fh, fieldnames=list(rows[0]))
        w.writeheader()
        for r in rows:
            w.writerow({k: _cell(v) for k, v in r.items()})


def prediction_dict(prediction: CompletenessPrediction, scene: Scene) -> dict:
    """The report's ``completeness_prediction``: the model's summary and one entry per element it predicts."""
    gid = scene.elements.global_id
    return {**prediction.summary(), "elements": [
        {"index": int(i), "global_id": gid[i], "predicted": round(float(prediction.predicted[i]), 4),
         "low": round(float(prediction.low[i]), 4), "high": round(float(prediction.high[i]), 4)}
        for i in np.flatnonzero(np.isfinite(prediction.predicted))]}


def report_dict(ev: Evaluation, scene: Scene, plan: Plan, model_path: str = "", plan_path: str = "",
                prediction: CompletenessPrediction | None = None) -> dict:
    p = ev.metrics.plan
    pct = lambda x: None if x is None else 100.0 * x  # noqa: E731
    extra = {} if prediction is None else {"completeness_prediction": prediction_dict(prediction, scene)}
    return {
        "format": "sightplan-report", "version": 1, "sightplan": __version__, "python": platform.python_version(),
        "model": {"path": model_path, "hash": scene.content_hash, "elements": scene.n_elements,
                  "targets": int(scene.targets.sum()), "triangles": int(len(scene.faces)),
                  "date": None if scene.date is None else str(scene.date)},
        "plan": {"path": plan_path, "frames": len(plan), "missions": len(plan.missions),
                 "cameras": {k: c.to_dict() for k, c in plan.cameras.items()}},
        "parameters": {**ev.settings.metric.to_dict(), "engine": ev.engine, "scale": ev.settings.scale,
                       "d_max_m": ev.settings.d_max, "feature_density_per_m2": ev.settings.feature_density,
                       "feature_seed": ev.settings.feature_seed},
        "metrics": {"VC_pct": pct(p.VC), "VC_bar_pct": pct(p.VC_bar), "VR": p.VR, "R_m_per_px": p.R, "O_deg": p.O,
                    "T": p.T, "stable_frames_pct": pct(p.stable_share), "z": p.z, "visible": p.n_visible,
                    "observed": p.n_observed, "frames": p.n_frames, "features": ev.n_features},
        "timings": {k: json_number(v) for k, v in ev.timings.items()},
        "cache_hits": ev.cache_hits,
        **extra,
    }


def write_report(ev: Evaluation, scene: Scene, plan: Plan, out_dir: str | Path, model_path: str = "",
                 plan_path: str = "", prediction: CompletenessPrediction | None = None) -> dict[str, Path]:
    """Write report.json, elements.csv, frames.csv and observations.npz; return their paths. ``prediction``:
    the predicted completeness per element, in elements.csv and report.json."""
    out = Path(out_dir)
    out.mkdir(parents=True, exist_ok=True)
    paths = {"report": out / "report.json", "elements": out / "elements.csv", "frames": out / "frames.csv",
             "observations": out / "observations.npz"}
    paths["report"].write_text(json.dumps(report_dict(ev, scene, plan, model_path, plan_path, prediction), indent=2,
                                          allow_nan=False), encoding="utf-8")
    write_csv(element_rows(ev, scene, prediction), paths["elements"])
    write_csv(frame_rows(ev, plan), paths["frames"])
    ev.observations.save(paths["observations"])
    return paths
