"""Progress series: one plan evaluated at several capture dates of a 4D model.

Each date gives the scene as it stands then (:meth:`Scene.at`). Dates at which the same
elements stand share one evaluation: nothing is cast twice for an unchanged site. Distinct
states are cast through the per-frame cache, so a rerun casts nothing. The series reads
only each date's Evaluation (its Observations and metrics).
"""

from __future__ import annotations

import csv
import hashlib
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from .errors import ScheduleError
from .evaluate import Evaluation, EvaluationSettings, evaluate
from .model.dates import parse_day
from .model.scene import DateBasis, Scene
from .plan.types import Plan

METRIC_COLUMNS = ("VC", "VC_bar", "VR", "R", "O", "T", "stable_share")
LABELS = {"VC": "VC (%)", "VC_bar": "V̄C (%)", "VR": "VR (frames)", "R": "R (m/px)", "O": "O (°)", "T": "T (features)",
          "stable_share": "stable frames (%)"}
PERCENT = {"VC", "VC_bar", "stable_share"}


@dataclass(frozen=True)
class SeriesPoint:
    """One capture date: how many target elements stand, and the evaluation (None when nothing stands yet).
    ``same_as``: the earlier date whose evaluation this one shares (the same elements stand)."""

    date: str
    n_built: int
    evaluation: Evaluation | None
    same_as: str | None = None

    def metric(self, name: str) -> float | None:
        if self.evaluation is None:
            return None
        v = getattr(self.evaluation.metrics.plan, name)
        return None if v is None else float(v) * (100.0 if name in PERCENT else 1.0)


@dataclass(frozen=True)
class ProgressSeries:
    points: tuple[SeriesPoint, ...]
    warnings: tuple[str, ...] = ()

    def rows(self) -> list[dict]:
        """One dict per date: date, elements built, each metric (VC, V̄C and stable share in %)."""
        return [{"date": p.date, "built": p.n_built, **{m: p.metric(m) for m in METRIC_COLUMNS},
                 "same_as": p.same_as or ""} for p in self.points]

    def write_csv(self, path: str | Path) -> Path:
        path = Path(path)
        rows = self.rows()
        with open(path, "w", newline="", encoding="utf-8") as fh:
            w = csv.DictWriter(fh, fieldnames=list(rows[0]))
            w.writeheader()
            for r in rows:
                w.writerow({k: "" if v is None else (f"{v:.6g}" if isinstance(v, float) else v) for k, v in r.items()})
        return path

    def plot(self, path: str | Path, title: str = "") -> Path:
        """Each metric over the capture dates, and the elements built, as one PNG."""
        import matplotlib

        matplotlib.use("Agg")
        import matplotlib.dates as mdates
        import matplotlib.pyplot as plt

        path = Path(path)
        days = [np.datetime64(p.date, "D").astype(object) for p in self.points]
        names = ("built", *METRIC_COLUMNS)
        fig, axes = plt.subplots(2, 4, figsize=(15, 6.5), sharex=True)
        for ax, name in zip(axes.flat, names):
            if name == "built":
                ys = [p.n_built for p in self.points]
                ax.set_title("target elements built")
            else:
                ys = [np.nan if p.metric(name) is None else p.metric(name) for p in self.points]
                ax.set_title(LABELS[name])
            ax.plot(days, ys, marker="o", color="#1f6f43" if name != "built" else "#555555", drawstyle="steps-post"
                    if name == "built" else "default")
            ax.grid(alpha=0.3)
            locator = mdates.AutoDateLocator(minticks=2, maxticks=5, interval_multiples=True)
            locator.intervald[mdates.HOURLY] = []  # capture dates are days: never tick hours
            ax.xaxis.set_major_locator(locator)
            ax.xaxis.set_major_formatter(mdates.DateFormatter("%Y-%m-%d"))
            ax.tick_params(axis="x", labelrotation=30)
        fig.suptitle(title or "capture plan over the schedule")
        fig.tight_layout()
        fig.savefig(path, dpi=110)
        plt.close(fig)
        return path


def schedule_days(scene: Scene, basis: DateBasis = "finish") -> list[str]:
    """Every distinct day on which a target element comes to stand (its ``basis`` date), sorted."""
    first, second = (scene.elements.finish, scene.elements.start) if basis == "finish" else \
        (scene.elements.start, scene.elements.finish)
    when = np.where(np.isnat(first), second, first)[scene.elements.is_target]
    when = when[~np.isnat(when)]
    if not len(when):
        raise ScheduleError("no target element has a schedule date: link a schedule first")
    return sorted({str(d)[:10] for d in when.astype("datetime64[D]")})


def evaluate_series(scene: Scene, plan: Plan, dates: Sequence[str], settings: EvaluationSettings | None = None, *,
                    basis: DateBasis = "finish", unscheduled: str = "present", cache_dir: str | Path | None | bool = None,
                    progress: Callable[[int, int, str], None] | None = None,
                    stages: Callable[[str, int, int], None] | None = None) -> ProgressSeries:
    """``plan`` evaluated on ``scene`` (undated) at each of ``dates`` (ISO days), in date order.

    progress(done, dates, date): called as each date begins and once at the end. stages: each date's evaluation's
    stages (:func:`~sightplan.evaluate.evaluate`)."""
    if not dates:
        raise ScheduleError("give at least one capture date")
    days = sorted({str(parse_day(d)) for d in dates})
    dated = np.concatenate([scene.elements.start, scene.elements.finish])
    dated = dated[~np.isnat(dated)]
    warnings = []
    if len(dated):
        last = str(dated.max())[:10]
        late = [d for d in days if d > last]
        if late:
            warnings.append(f"{', '.join(late)} after the schedule's last date {last}: everything scheduled stands")
    else:
        warnings.append("no element has a schedule date: every date shows the same site")
    done: dict[bytes, tuple[str, Evaluation]] = {}
    points = []
    for k, day in enumerate(days):
        if progress is not None:
            progress(k, len(days), day)
        try:
            at = scene.at(day, basis=basis, unscheduled=unscheduled)  # type: ignore[arg-type]
        except ScheduleError:
            points.append(SeriesPoint(day, 0, None))
            continue
        state = hashlib.sha256(np.packbits(at.present).tobytes()).digest()
        n_built = int(at.targets.sum())
        if state in done:
            first, ev = done[state]
            points.append(SeriesPoint(day, n_built, ev, same_as=first))
            continue
        ev = evaluate(at, plan, settings, cache_dir=cache_dir, stages=stages)
        done[state] = (day, ev)
        points.append(SeriesPoint(day, n_built, ev))
    if progress is not None:
        progress(len(days), len(days), days[-1])
    if all(p.evaluation is None for p in points):
        raise ScheduleError(f"no element stands on any of the dates ({days[0]} … {days[-1]})")
    return ProgressSeries(tuple(points), tuple(warnings))

