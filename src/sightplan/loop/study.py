"""The per-element study of the closed loop: do the predicted metrics come true in a real reconstruction?

One row per target element: the predictors of the plan's evaluation — VR_i (frames), R_i (mm/px), O_i (degrees),
the pixels it fills over the plan, and ``seen_share``, the share of its surface that some frame sees
unoccluded (:mod:`.measure`) — beside what the reconstruction measured: completeness, point count and density.

- Every predictor × measure pair is correlated over the elements where both are numbers (R_i and O_i are
  undefined on elements no frame sees by Ω pixels, completeness on elements no frame sees at all), with Pearson's
  r (:func:`sightplan.study.pearson`) and Spearman's ρ (:func:`scipy.stats.spearmanr`), two-sided p-values and n;
  strength as in :func:`sightplan.study.strength`.
- A logistic regression of *reconstructed* (completeness ≥ ``RECONSTRUCTED``) on the predictors ``LOGIT``,
  z-scored, over the elements where all are numbers: maximum likelihood with an L2 penalty of ``RIDGE``·‖β‖²/2
  on the slopes (per element, which only keeps a separable set finite), by L-BFGS; coefficients per standard
  deviation and per unit, Wald standard errors from the penalised information matrix, in-sample accuracy at
  p = 0.5 and McFadden's pseudo-R².
- Per frame: ν_f against registered (the point-biserial r, which is Pearson's r with a 0/1 variable) and the
  confusion of predicted stable (ν_f ≥ Λ) against registered.

Beside it, the paper's Table 2 correlations (per data set, :func:`sightplan.study.read_study`; by default the
table bundled as :data:`PAPER_TABLE`) for the analogous plan metric and quality: VR_i ↔ VR, R_i ↔ R, O_i ↔ O,
seen_share ↔ VC, ν_f ↔ T; completeness ↔ Ce and Cv.
"""

from __future__ import annotations

import csv
import json
import math
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np
from numpy.typing import NDArray

from ..errors import SightplanError
from ..evaluate import Evaluation
from ..study import Study, pearson, read_study, spearman, strength
from .files import _num
from .measure import ReconstructionMeasures

PREDICTORS = ("VR", "R", "O", "pixels", "seen_share")
MEASURES = ("completeness", "points", "density")
LOGIT = ("VR", "R", "O", "seen_share")
RECONSTRUCTED = 0.5
#: The paper's Table 2, bundled (see ``data/ATTRIBUTION.md``): the default beside the study's correlations.
PAPER_TABLE = Path(__file__).resolve().parents[1] / "data" / "table2.csv"
RIDGE = 1e-3
MIN_FIT = 10

LABELS = {"VR": "VR_i (frames)", "R": "R_i (mm/px)", "O": "O_i (°)", "pixels": "pixels over the plan",
          "seen_share": "seen share of the surface", "completeness": "completeness", "points": "points",
          "density": "points per m² seen", "nu": "ν_f (stable features)"}
#: The paper's plan metric analogous to each predictor, and its qualities analogous to completeness.
PAPER_METRIC = {"VR": "VR", "R": "R", "O": "O", "seen_share": "VC", "nu": "T"}
PAPER_QUALITIES = ("Ce", "Cv")


class LoopStudyError(SightplanError):
    """A study that cannot be made from the data given."""


@dataclass(frozen=True)
class Correlation:
    """One predictor × measure pair over the n elements (or frames) where both are numbers."""

    predictor: str
    measure: str
    n: int
    pearson_r: float | None
    pearson_p: float | None
    spearman_r: float | None
    spearman_p: float | None

    @property
    def strength(self) -> str:
        return strength(self.pearson_r)

    def to_dict(self) -> dict:
        return {"predictor": self.predictor, "measure": self.measure, "n": self.n, "pearson_r": self.pearson_r,
                "pearson_p": self.pearson_p, "spearman_r": self.spearman_r, "spearman_p": self.spearman_p,
                "strength": self.strength}


def correlation(predictor: str, measure: str, x, y) -> Correlation:
    """Pearson and Spearman of the pairs where both x and y are finite."""
    x, y = np.asarray(x, float), np.asarray(y, float)
    ok = np.isfinite(x) & np.isfinite(y)
    r, p = pearson(x[ok], y[ok])
    rs, ps = spearman(x[ok], y[ok])
    return Correlation(predictor, measure, int(ok.sum()), r, p, rs, ps)


# =========================================================================== logistic regression
@dataclass(frozen=True)
class LogisticFit:
    """P(y = 1) = σ(intercept + Σ coef_k · (x_k − mean_k) / scale_k). ``raw_coef``/``raw_intercept``: the same
    model per unit of each predictor. ``se``: Wald standard errors of the standardised slopes; ``p``: their
    two-sided p-values."""

    predictors: tuple[str, ...]
    coef: NDArray[np.float64]
    intercept: float
    mean: NDArray[np.float64]
    scale: NDArray[np.float64]
    se: NDArray[np.float64]
    p: NDArray[np.float64]
    n: int
    positives: int
    accuracy: float
    base_rate: float
    pseudo_r2: float
    converged: bool
    ridge: float

    @property
    def raw_coef(self) -> NDArray[np.float64]:
        return self.coef / self.scale

    @property
    def raw_intercept(self) -> float:
        return float(self.intercept - (self.coef * self.mean / self.scale).sum())

    def probability(self, X) -> NDArray[np.float64]:
        """(m,) P(y = 1) for the (m, k) predictor values in their own units."""
        eta = self.intercept + ((np.asarray(X, float) - self.mean) / self.scale) @ self.coef
        return 1.0 / (1.0 + np.exp(-eta))

    def to_dict(self) -> dict:
        return {"predictors": list(self.predictors), "standardised": {
                    "intercept": self.intercept, "coef": dict(zip(self.predictors, map(float, self.coef), strict=True)),
                    "se": dict(zip(self.predictors, map(_num, self.se), strict=True)),
                    "p": dict(zip(self.predictors, map(_num, self.p), strict=True))},
                "per_unit": {"intercept": self.raw_intercept,
                             "coef": dict(zip(self.predictors, map(float, self.raw_coef), strict=True))},
                "mean": dict(zip(self.predictors, map(float, self.mean), strict=True)),
                "scale": dict(zip(self.predictors, map(float, self.scale), strict=True)),
                "n": self.n, "positives": self.positives, "accuracy": self.accuracy, "base_rate": self.base_rate,
                "pseudo_r2": self.pseudo_r2, "converged": self.converged, "ridge": self.ridge}


def fit_logistic(X, y, predictors: tuple[str, ...] | None = None, ridge: float = RIDGE) -> LogisticFit:
    """Logistic regression of 0/1 ``y`` on the (n, k) ``X`` (module docstring); rows with a NaN are left out."""
    from scipy.stats import norm

    from ..predict.model import ridge_logistic

    X = np.asarray(X, float)
    X = X.reshape(len(X), -1)
    y = np.asarray(y, float)
    ok = np.isfinite(X).all(axis=1) & np.isfinite(y)
    X, y = X[ok], y[ok]
    n, k = X.shape
    predictors = predictors or tuple(f"x{j}" for j in range(k))
    if n < MIN_FIT:
        raise LoopStudyError(f"a logistic fit needs at least {MIN_FIT} elements with every predictor, got {n}")
    pos = int(y.sum())
    if pos in (0, n):
        raise LoopStudyError(f"a logistic fit needs both outcomes; all {n} elements are "
                             f"{'reconstructed' if pos else 'not reconstructed'}")
    mean = X.mean(axis=0)
    scale = X.std(axis=0)
    scale = np.where(scale > 0, scale, 1.0)
    Z = np.column_stack([np.ones(n), (X - mean) / scale])
    penalty = np.r_[0.0, np.full(k, ridge)]
    res = ridge_logistic(Z, y, ridge)
    beta = res.x
    mu = 1.0 / (1.0 + np.exp(-(Z @ beta)))
    info = (Z * (mu * (1 - mu))[:, None]).T @ Z + n * np.diag(penalty)
    try:
        cov = np.linalg.inv(info)
        se = np.sqrt(np.clip(np.diag(cov)[1:], 0, None))
    except np.linalg.LinAlgError:
        se = np.full(k, np.nan)
    with np.errstate(divide="ignore", invalid="ignore"):
        p = 2 * norm.sf(np.abs(beta[1:] / se))
    ll = float(np.sum(y * np.log(np.clip(mu, 1e-300, None)) + (1 - y) * np.log(np.clip(1 - mu, 1e-300, None))))
    rate = pos / n
    ll0 = n * (rate * math.log(rate) + (1 - rate) * math.log(1 - rate))
    return LogisticFit(predictors=tuple(predictors), coef=beta[1:], intercept=float(beta[0]), mean=mean, scale=scale,
                       se=se, p=p, n=n, positives=pos, accuracy=float(((mu >= 0.5) == (y == 1)).mean()),
                       base_rate=rate, pseudo_r2=1.0 - ll / ll0, converged=bool(res.success), ridge=ridge)


# =========================================================================== frames
@dataclass(frozen=True)
class FrameStudy:
    """ν_f against registered over the plan's n frames: the point-biserial r and p, and the counts of predicted
    stable × registered."""

    n: int
    registered: int
    stable: int
    r: float | None
    p: float | None
    stable_registered: int
    stable_unregistered: int
    unstable_registered: int
    unstable_unregistered: int

    @property
    def agreement(self) -> float:
        return (self.stable_registered + self.unstable_unregistered) / self.n if self.n else math.nan

    def to_dict(self) -> dict:
        return {"n": self.n, "registered": self.registered, "stable": self.stable, "point_biserial_r": self.r,
                "p": self.p, "confusion": {"stable_registered": self.stable_registered,
                                           "stable_unregistered": self.stable_unregistered,
                                           "unstable_registered": self.unstable_registered,
                                           "unstable_unregistered": self.unstable_unregistered},
                "agreement": _num(self.agreement)}


def frame_study(nu, stable, registered) -> FrameStudy:
    nu = np.asarray(nu, float)
    s = np.asarray(stable, bool)
    g = np.asarray(registered, bool)
    r, p = pearson(nu, g.astype(float))
    return FrameStudy(n=len(nu), registered=int(g.sum()), stable=int(s.sum()), r=r, p=p,
                      stable_registered=int((s & g).sum()), stable_unregistered=int((s & ~g).sum()),
                      unstable_registered=int((~s & g).sum()), unstable_unregistered=int((~s & ~g).sum()))


# =========================================================================== the study
@dataclass
class LoopStudy:
    """The per-element table (``columns``: one array per column, one entry per target element), the
    correlations, the logistic fit (None with ``fit_note`` saying why), the frames and their table, and the
    paper's Table 2 correlations when given."""

    columns: dict[str, np.ndarray]
    correlations: list[Correlation]
    logistic: LogisticFit | None
    fit_note: str
    frames: FrameStudy
    frame_columns: dict[str, np.ndarray]
    threshold: float
    paper: Study | None = None
    info: dict = field(default_factory=dict)

    @property
    def n_elements(self) -> int:
        return len(self.columns["global_id"])

    def correlation(self, predictor: str, measure: str) -> Correlation:
        for c in self.correlations:
            if c.predictor == predictor and c.measure == measure:
                return c
        raise LoopStudyError(f"no pair {predictor} × {measure} in this study")

    def paper_r(self, predictor: str, quality: str) -> tuple[float | None, int | None]:
        """The paper's Table 2 r (and n) for the plan metric analogous to ``predictor``, or (None, None)."""
        metric = PAPER_METRIC.get(predictor)
        if self.paper is None or metric is None or metric not in self.paper.metrics or quality not in \
                self.paper.qualities:
            return None, None
        pair = self.paper.pair(metric, quality)
        return pair.r, pair.n

    def comparison(self) -> list[dict]:
        """The correlation table beside the paper's: one row per predictor with completeness (and ν_f with
        registered), our Pearson and Spearman r, p and n, and the paper's r for Ce and Cv."""
        rows = []
        for pred in PREDICTORS:
            c = self.correlation(pred, "completeness")
            rows.append({"predictor": pred, "quality": "completeness", **_ours(c),
                         **{f"paper_r_{q}": self.paper_r(pred, q)[0] for q in PAPER_QUALITIES},
                         "paper_metric": PAPER_METRIC.get(pred)})
        f = self.frames
        rows.append({"predictor": "nu", "quality": "registered", "n": f.n, "pearson_r": f.r, "pearson_p": f.p,
                     "spearman_r": None, "spearman_p": None, "strength": strength(f.r),
                     **{f"paper_r_{q}": self.paper_r("nu", q)[0] for q in PAPER_QUALITIES}, "paper_metric": "T"})
        return rows

    def to_dict(self) -> dict:
        return {"format": "sightplan-loop-study", "version": 1, "elements": self.n_elements,
                "reconstructed_threshold": self.threshold,
                "reconstructed": int(np.nansum(self.columns["reconstructed"] == 1)),
                "correlations": [c.to_dict() for c in self.correlations], "comparison": self.comparison(),
                "logistic": None if self.logistic is None else self.logistic.to_dict(), "logistic_note": self.fit_note,
                "frames": self.frames.to_dict(),
                "paper_table": None if self.paper is None or self.paper.source is None else str(self.paper.source),
                "info": dict(self.info)}

    def write(self, out: str | Path, plots: bool = True) -> dict[str, Path]:
        """study.json, elements.csv, frames.csv, correlations.csv and (``plots``) the scatter plots, in ``out``."""
        out = Path(out)
        out.mkdir(parents=True, exist_ok=True)
        paths = {"study": out / "study.json", "elements": out / "elements.csv", "frames": out / "frames.csv",
                 "correlations": out / "correlations.csv"}
        paths["study"].write_text(json.dumps(self.to_dict(), indent=1, allow_nan=False, ensure_ascii=False),
                                  encoding="utf-8")
        _write_columns(self.columns, paths["elements"])
        _write_columns(self.frame_columns, paths["frames"])
        table = [c.to_dict() for c in self.correlations]
        _write_rows(table, paths["correlations"])
        if plots:
            paths.update(plot_study(self, out))
        return paths


def _ours(c: Correlation) -> dict:
    return {"n": c.n, "pearson_r": c.pearson_r, "pearson_p": c.pearson_p, "spearman_r": c.spearman_r,
            "spearman_p": c.spearman_p, "strength": c.strength}


def _cell(v) -> str:
    if isinstance(v, (bool, np.bool_)):
        return "1" if v else "0"
    if isinstance(v, (float, np.floating)):
        return "" if not math.isfinite(v) else f"{float(v):.6g}"
    if v is None:
        return ""
    return str(v)


def _write_rows(rows: list[dict], path: Path) -> None:
    with open(path, "w", newline="", encoding="utf-8") as fh:
        w = csv.writer(fh)
        if rows:
            w.writerow(list(rows[0]))
            for r in rows:
                w.writerow([_cell(v) for v in r.values()])


def _write_columns(columns: dict[str, np.ndarray], path: Path) -> None:
    names = list(columns)
    with open(path, "w", newline="", encoding="utf-8") as fh:
        w = csv.writer(fh)
        w.writerow(names)
        for i in range(len(columns[names[0]]) if names else 0):
            w.writerow([_cell(columns[k][i]) for k in names])


def element_table(evaluation: Evaluation, measures: ReconstructionMeasures,
                  threshold: float = RECONSTRUCTED) -> dict[str, np.ndarray]:
    """The per-element columns over the target elements (module docstring); ``reconstructed`` is 1/0, NaN where
    completeness is undefined."""
    em = evaluation.metrics.elements
    if len(em.VR) != len(measures.points):
        raise LoopStudyError(f"the evaluation has {len(em.VR)} elements and the measures {len(measures.points)}: "
                             "measure the reconstruction on the evaluated model")
    t = np.flatnonzero(em.is_target & measures.is_target)
    c = measures.completeness[t]
    with np.errstate(invalid="ignore", divide="ignore"):
        seen = np.where(measures.samples[t] > 0, measures.visible_samples[t] / np.maximum(measures.samples[t], 1),
                        np.nan)
    return {"global_id": measures.global_id[t], "name": measures.name[t], "ifc_class": measures.ifc_class[t],
            "VR": em.VR[t].astype(float), "R": 1000.0 * em.R[t], "O": em.O[t].astype(float),
            "pixels": em.pixels_total[t].astype(float), "seen_share": seen, "area_m2": measures.area_m2[t],
            "points": measures.points[t].astype(float), "density": measures.density_per_m2[t], "completeness": c,
            "reconstructed": np.where(np.isfinite(c), (c >= threshold).astype(float), np.nan)}


def loop_study(evaluation: Evaluation, measures: ReconstructionMeasures, *, threshold: float = RECONSTRUCTED,
               logit: tuple[str, ...] = LOGIT, paper_table: str | Path | Study | bool | None = None,
               info: dict | None = None) -> LoopStudy:
    """The per-element and per-frame study (module docstring). paper_table: the paper's Table 2 (a CSV path or a
    read :class:`~sightplan.study.Study`) to set beside the correlations; None: the bundled :data:`PAPER_TABLE`;
    False: none."""
    if not 0 < threshold <= 1:
        raise LoopStudyError(f"the completeness threshold must be in (0, 1], got {threshold!r}")
    unknown = [p for p in logit if p not in PREDICTORS]
    if unknown:
        raise LoopStudyError(f"unknown predictor(s) {', '.join(unknown)}; choose from {', '.join(PREDICTORS)}")
    cols = element_table(evaluation, measures, threshold)
    corr = [correlation(p, m, cols[p], cols[m]) for p in PREDICTORS for m in MEASURES]
    try:
        fit, note = fit_logistic(np.column_stack([cols[p] for p in logit]), cols["reconstructed"], tuple(logit)), ""
    except LoopStudyError as exc:
        fit, note = None, str(exc)
    frames = frame_study(measures.nu, measures.stable, measures.registered)
    frame_cols = {"frame": np.array(measures.frame_names, dtype=object), "registered": measures.registered,
                  "position_error_m": measures.position_error_m, "rotation_error_deg": measures.rotation_error_deg,
                  "nu": measures.nu, "stable": measures.stable}
    if paper_table is None:
        paper_table = PAPER_TABLE
    paper = read_study(paper_table) if isinstance(paper_table, (str, Path)) else (paper_table or None)
    return LoopStudy(cols, corr, fit, note, frames, frame_cols, threshold, paper, dict(info or {}))


# =========================================================================== plots
def _pyplot():
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    return plt


def _title(c: Correlation) -> str:
    r = "n/a" if c.pearson_r is None else f"{c.pearson_r:+.2f}"
    rs = "n/a" if c.spearman_r is None else f"{c.spearman_r:+.2f}"
    return f"r = {r}, ρ = {rs}, n = {c.n}"


def plot_study(study: LoopStudy, out: Path) -> dict[str, Path]:
    """scatter_completeness.png (each predictor against completeness), scatter_points.png (pixels and R_i
    against the points and their density) and frames.png (ν_f of registered and unregistered frames)."""
    plt = _pyplot()
    cols = study.columns
    paths = {}
    recon = cols["reconstructed"] == 1
    fig, axes = plt.subplots(1, len(PREDICTORS), figsize=(3.3 * len(PREDICTORS), 3.4), squeeze=False)
    for ax, p in zip(axes[0], PREDICTORS, strict=True):
        x, y = cols[p], cols["completeness"]
        ok = np.isfinite(x) & np.isfinite(y)
        ax.scatter(x[ok & recon], y[ok & recon], s=8, c="#1f7a3f", alpha=0.6, lw=0, label="reconstructed")
        ax.scatter(x[ok & ~recon], y[ok & ~recon], s=8, c="#c0392b", alpha=0.6, lw=0, label="not")
        ax.axhline(study.threshold, color="#888", lw=0.8, ls="--")
        if p == "pixels" and ok.any() and (x[ok] > 0).all():
            ax.set_xscale("log")
        ax.set_xlabel(LABELS[p])
        ax.set_title(_title(study.correlation(p, "completeness")), fontsize=9)
        ax.grid(alpha=0.3)
    axes[0][0].set_ylabel("measured completeness")
    axes[0][0].legend(fontsize=7, loc="lower right")
    fig.tight_layout()
    paths["scatter_completeness"] = out / "scatter_completeness.png"
    fig.savefig(paths["scatter_completeness"], dpi=100)
    plt.close(fig)

    fig, axes = plt.subplots(1, 2, figsize=(8.4, 3.6))
    for ax, (p, m) in zip(axes, (("pixels", "points"), ("R", "density")), strict=True):
        x, y = cols[p], cols[m]
        ok = np.isfinite(x) & np.isfinite(y)
        ax.scatter(x[ok], y[ok], s=8, c="#1f4e9e", alpha=0.6, lw=0)
        if ok.any() and (x[ok] > 0).all() and p == "pixels":
            ax.set_xscale("log")
        if ok.any() and (y[ok] > 0).all():
            ax.set_yscale("log")
        ax.set_xlabel(LABELS[p])
        ax.set_ylabel(LABELS[m])
        ax.set_title(_title(study.correlation(p, m)), fontsize=9)
        ax.grid(alpha=0.3)
    fig.tight_layout()
    paths["scatter_points"] = out / "scatter_points.png"
    fig.savefig(paths["scatter_points"], dpi=100)
    plt.close(fig)

    fc = study.frame_columns
    fig, ax = plt.subplots(figsize=(6.4, 3.2))
    idx = np.arange(len(fc["nu"]))
    reg = np.asarray(fc["registered"], bool)
    ax.bar(idx[reg], np.asarray(fc["nu"])[reg], color="#1f7a3f", width=1.0, label="registered")
    ax.bar(idx[~reg], np.asarray(fc["nu"])[~reg], color="#c0392b", width=1.0, label="not registered")
    ax.set_xlabel("frame")
    ax.set_ylabel(LABELS["nu"])
    f = study.frames
    r = "n/a" if f.r is None else f"{f.r:+.2f}"
    ax.set_title(f"{f.registered} of {f.n} frames registered; point-biserial r = {r}", fontsize=9)
    ax.legend(fontsize=7)
    fig.tight_layout()
    paths["frames_plot"] = out / "frames.png"
    fig.savefig(paths["frames_plot"], dpi=100)
    plt.close(fig)
    return paths
