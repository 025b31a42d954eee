"""Completeness predicted per element: a fractional logistic regression on a few transformed predictors, its
calibration, leave-one-group-out testing and prediction intervals.

- **Features** (:data:`FEATURES`, from the columns of :mod:`.columns`): log(1 + VR_i); visible (VR_i > 0);
  log R_i and O_i / 90° (set to their fitted means where VR_i = 0, so only ``visible`` speaks there);
  log(1 + pixels); the seen share; the median and the matchable triangulation angles / 90°; the triangulable
  share; log(1 + views); the stable views' share. A feature that is NaN for an element (it owns no simulated
  feature) takes the fitted mean. Each is z-scored with the fitted mean and spread.
- **Fit**: the completeness c ∈ [0, 1] of each element is the outcome of a logistic model, ĉ = σ(β₀ + βᵀx),
  fitted by maximising the weighted Bernoulli quasi-likelihood Σ w (c log ĉ + (1 − c) log(1 − ĉ)) with an
  L2 penalty ``ridge``·‖β‖²/2 on the slopes (L-BFGS). Weights: each group (a model) counts equally, and within it
  each element alike, unless given.
- **Calibration** of predictions ĉ against measures c: the least-squares line c = a + b·ĉ (b, the calibration
  slope, is 1 for a calibrated predictor, below 1 for one that claims too much), the mean of c − ĉ, and the
  reliability table: the mean ĉ and the mean c in bins of ĉ.
- **Intervals**: per bin of ĉ (:data:`INTERVAL_EDGES`), the 5th and 95th percentiles of the held-out residuals
  c − ĉ; an element's interval is ĉ plus those, clipped to [0, 1] (a 90 % interval, as wide as the predictor
  missed on models it was not fitted on).
"""

from __future__ import annotations

import json
import math
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np
from numpy.typing import NDArray

from ..errors import SightplanError

FEATURES = ("log_VR", "visible", "log_R", "O", "log_pixels", "seen_share", "tri_median", "tri_matchable",
            "triangulable", "log_views", "stable_views")
RIDGE = 1e-3
INTERVAL_EDGES = (0.0, 0.1, 0.3, 0.5, 0.7, 0.9, 1.0)
INTERVAL_LEVEL = 0.90
RELIABILITY_BINS = 10
MIN_ROWS = 10
FORMAT = "sightplan-completeness-model"
#: The bundled model fitted on every model of the study (``benchmarks/predict.py --bundle``).
BUNDLED = Path(__file__).resolve().parents[1] / "data" / "completeness_model.json"


class PredictionError(SightplanError):
    """A completeness model that cannot be fitted, read or applied."""


def feature_matrix(columns: dict[str, NDArray], features: tuple[str, ...] = FEATURES) -> NDArray[np.float64]:
    """(m, k) raw features (NaN where undefined) from the predictor columns (module docstring)."""
    def col(name: str) -> NDArray[np.float64]:
        if name not in columns:
            raise PredictionError(f"the predictor column {name!r} is missing")
        return np.asarray(columns[name], float)

    vr = col("VR")
    with np.errstate(invalid="ignore", divide="ignore"):
        make = {
            "log_VR": lambda: np.log1p(np.maximum(vr, 0)),
            "visible": lambda: (vr > 0).astype(float),
            "log_R": lambda: np.where(vr > 0, np.log(col("R")), np.nan),
            "O": lambda: np.where(vr > 0, col("O") / 90.0, np.nan),
            "log_pixels": lambda: np.log1p(np.maximum(col("pixels"), 0)),
            "seen_share": lambda: col("seen_share"),
            "tri_median": lambda: col("tri_median") / 90.0,
            "tri_largest": lambda: col("tri_largest") / 90.0,
            "tri_matchable": lambda: col("tri_matchable") / 90.0,
            "triangulable": lambda: col("triangulable"),
            "log_views": lambda: np.log1p(col("views")),
            "stable_views": lambda: col("stable_views"),
        }
        unknown = [f for f in features if f not in make]
        if unknown:
            raise PredictionError(f"unknown feature(s) {', '.join(unknown)}")
        X = np.column_stack([make[f]() for f in features]) if features else np.zeros((len(vr), 0))
    X[~np.isfinite(X)] = np.nan
    return X


def _sigmoid(eta: NDArray) -> NDArray:
    return 0.5 * (1.0 + np.tanh(0.5 * eta))


@dataclass(frozen=True)
class CompletenessModel:
    """ĉ = σ(intercept + Σ coef_k (x_k − mean_k) / scale_k), x_k = mean_k where NaN; intervals: per bin of ĉ between
    ``interval_edges``, the residual quantiles ``interval_low``/``interval_high``. ``info``: what it was fitted on."""

    features: tuple[str, ...]
    coef: NDArray[np.float64]
    intercept: float
    mean: NDArray[np.float64]
    scale: NDArray[np.float64]
    ridge: float
    n: int
    interval_edges: tuple[float, ...] = INTERVAL_EDGES
    interval_low: tuple[float, ...] = ()
    interval_high: tuple[float, ...] = ()
    interval_level: float = INTERVAL_LEVEL
    info: dict = field(default_factory=dict)

    def standardise(self, X: NDArray) -> NDArray[np.float64]:
        X = np.asarray(X, float).reshape(-1, len(self.features))
        X = np.where(np.isfinite(X), X, self.mean)
        return (X - self.mean) / self.scale

    def predict(self, X: NDArray) -> NDArray[np.float64]:
        """(m,) predicted completeness for the (m, k) raw features."""
        return _sigmoid(self.intercept + self.standardise(X) @ self.coef)

    def predict_columns(self, columns: dict[str, NDArray]) -> NDArray[np.float64]:
        return self.predict(feature_matrix(columns, self.features))

    def interval(self, p: NDArray) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
        """(low, high) of each prediction ``p``: p plus its bin's residual quantiles, clipped to [0, 1]; (p, p)
        when the model has no interval table."""
        p = np.asarray(p, float)
        if not self.interval_low:
            return p.copy(), p.copy()
        b = np.clip(np.searchsorted(self.interval_edges, p, side="right") - 1, 0, len(self.interval_low) - 1)
        lo = np.clip(p + np.asarray(self.interval_low)[b], 0.0, 1.0)
        hi = np.clip(p + np.asarray(self.interval_high)[b], 0.0, 1.0)
        return np.minimum(lo, p), np.maximum(hi, p)

    def with_intervals(self, predicted: NDArray, measured: NDArray) -> CompletenessModel:
        low, high = interval_table(predicted, measured, self.interval_edges, self.interval_level)
        return CompletenessModel(self.features, self.coef, self.intercept, self.mean, self.scale, self.ridge, self.n,
                                 self.interval_edges, low, high, self.interval_level, dict(self.info))

    def to_dict(self) -> dict:
        return {"format": FORMAT, "version": 1, "features": list(self.features),
                "intercept": self.intercept, "coef": dict(zip(self.features, map(float, self.coef), strict=True)),
                "mean": dict(zip(self.features, map(float, self.mean), strict=True)),
                "scale": dict(zip(self.features, map(float, self.scale), strict=True)),
                "ridge": self.ridge, "n": self.n,
                "interval": {"level": self.interval_level, "edges": list(self.interval_edges),
                             "low": list(self.interval_low), "high": list(self.interval_high)},
                "info": self.info}

    def write(self, path: str | Path) -> Path:
        path = Path(path)
        path.write_text(json.dumps(self.to_dict(), indent=1, allow_nan=False, ensure_ascii=False) + "\n",
                        encoding="utf-8")
        return path

    @classmethod
    def from_dict(cls, d: dict) -> CompletenessModel:
        try:
            if d.get("format") != FORMAT:
                raise PredictionError("not a sightplan completeness model")
            feats = tuple(d["features"])
            iv = d.get("interval", {})
            return cls(feats, np.array([d["coef"][f] for f in feats], float), float(d["intercept"]),
                       np.array([d["mean"][f] for f in feats], float), np.array([d["scale"][f] for f in feats], float),
                       float(d.get("ridge", RIDGE)), int(d.get("n", 0)),
                       tuple(iv.get("edges", INTERVAL_EDGES)), tuple(iv.get("low", ())), tuple(iv.get("high", ())),
                       float(iv.get("level", INTERVAL_LEVEL)), dict(d.get("info", {})))
        except (KeyError, TypeError, ValueError) as exc:
            raise PredictionError(f"not a sightplan completeness model: {exc}") from None

    @classmethod
    def read(cls, path: str | Path | None = None) -> CompletenessModel:
        """The model in ``path`` (default: the bundled :data:`BUNDLED`)."""
        path = Path(path) if path is not None else BUNDLED
        try:
            d = json.loads(path.read_text(encoding="utf-8"))
        except (OSError, ValueError) as exc:
            raise PredictionError(f"cannot read the completeness model {path}: {exc}") from None
        if not isinstance(d, dict):
            raise PredictionError(f"{path} is not a sightplan completeness model")
        return cls.from_dict(d)


def group_weights(groups: NDArray) -> NDArray[np.float64]:
    """Weights under which each group counts equally (each of its rows 1/size), scaled to a mean of 1."""
    g = np.asarray(groups)
    _, inv, size = np.unique(g, return_inverse=True, return_counts=True)
    w = 1.0 / size[inv]
    return w * len(w) / w.sum()


def ridge_logistic(Z: NDArray, y: NDArray, ridge: float, weights: NDArray | None = None, beta0: NDArray | None = None,
                   *, maxiter: int = 1000, gtol: float = 1e-10):
    """Minimise the weighted mean logistic loss of outcomes ``y`` in [0, 1] (0/1, or fractions) on the design
    ``Z`` (n, 1 + k: a column of ones, then standardised predictors), plus ``ridge``/2 · Σ β_k² on all but the
    intercept, by L-BFGS from ``beta0`` (zeros by default). Returns scipy's result (``x``: the intercept, then
    the coefficients; ``success``)."""
    from scipy.optimize import minimize

    n, width = Z.shape
    w = np.ones(n) if weights is None else weights
    penalty = np.r_[0.0, np.full(width - 1, ridge)]

    def loss(beta):
        eta = Z @ beta
        f = float(np.mean(w * (np.logaddexp(0.0, eta) - y * eta)) + 0.5 * (penalty * beta * beta).sum())
        return f, Z.T @ (w * (_sigmoid(eta) - y)) / n + penalty * beta

    start = np.zeros(width) if beta0 is None else beta0
    return minimize(loss, start, jac=True, method="L-BFGS-B", options={"maxiter": maxiter, "gtol": gtol})


def fit_completeness(X: NDArray, c: NDArray, *, features: tuple[str, ...] = FEATURES, weights: NDArray | None = None,
                     ridge: float = RIDGE, info: dict | None = None) -> CompletenessModel:
    """The fractional logistic fit of completeness ``c`` (m,) on the raw features ``X`` (m, k) (module
    docstring); rows where c is not a number are left out."""
    X = np.asarray(X, float).reshape(len(X), -1)
    c = np.asarray(c, float)
    w = np.ones(len(c)) if weights is None else np.asarray(weights, float)
    ok = np.isfinite(c) & np.isfinite(w)
    X, c, w = X[ok], np.clip(c[ok], 0.0, 1.0), w[ok]
    n, k = X.shape
    if k != len(features):
        raise PredictionError(f"{k} feature columns for {len(features)} features")
    if n < MIN_ROWS:
        raise PredictionError(f"a completeness fit needs at least {MIN_ROWS} elements with a measured completeness, "
                              f"got {n}")
    w = w / w.mean()
    with np.errstate(invalid="ignore"):
        mean = np.array([np.average(X[np.isfinite(X[:, j]), j], weights=w[np.isfinite(X[:, j])])
                         if np.isfinite(X[:, j]).any() else 0.0 for j in range(k)])
    Xf = np.where(np.isfinite(X), X, mean)
    scale = np.sqrt(np.average((Xf - mean) ** 2, axis=0, weights=w)) if k else np.zeros(0)
    scale = np.where(scale > 1e-12, scale, 1.0)
    Z = np.column_stack([np.ones(n), (Xf - mean) / scale])
    rate = float(np.clip(np.average(c, weights=w), 1e-6, 1 - 1e-6))
    beta0 = np.r_[math.log(rate / (1 - rate)), np.zeros(k)]
    res = ridge_logistic(Z, c, ridge, w, beta0, maxiter=2000, gtol=1e-9)
    return CompletenessModel(tuple(features), res.x[1:].copy(), float(res.x[0]), mean, scale, float(ridge), int(n),
                             info={**(info or {}), "converged": bool(res.success)})


# =========================================================================== calibration and intervals
@dataclass(frozen=True)
class Calibration:
    """Predictions against measures: n, Pearson r, the line measured = intercept + slope · predicted, the mean of
    measured − predicted, the root mean square error, and the reliability bins (mean predicted, mean measured,
    count)."""

    n: int
    r: float | None
    slope: float | None
    intercept: float | None
    bias: float | None
    rmse: float | None
    bins: list[dict]

    def to_dict(self) -> dict:
        return {"n": self.n, "r": self.r, "slope": self.slope, "intercept": self.intercept, "bias": self.bias,
                "rmse": self.rmse, "bins": self.bins}


def _finite(v: float) -> float | None:
    return float(v) if v is not None and math.isfinite(v) else None


def calibration(predicted: NDArray, measured: NDArray, bins: int = RELIABILITY_BINS) -> Calibration:
    """Calibration of ``predicted`` against ``measured`` over the pairs where both are numbers (:class:`Calibration`);
    the reliability bins split [0, 1] into ``bins`` equal parts."""
    p, c = np.asarray(predicted, float), np.asarray(measured, float)
    ok = np.isfinite(p) & np.isfinite(c)
    p, c = p[ok], c[ok]
    n = len(p)
    rows = []
    if n:
        b = np.clip((p * bins).astype(int), 0, bins - 1)
        for j in range(bins):
            s = b == j
            if s.any():
                rows.append({"low": j / bins, "high": (j + 1) / bins, "n": int(s.sum()),
                             "predicted": float(p[s].mean()), "measured": float(c[s].mean())})
    if n < 3 or np.ptp(p) == 0:
        return Calibration(n, None, None, None, _finite(float(np.mean(c - p))) if n else None,
                           _finite(float(np.sqrt(np.mean((c - p) ** 2)))) if n else None, rows)
    slope, intercept = np.polyfit(p, c, 1)
    r = float(np.corrcoef(p, c)[0, 1]) if np.ptp(c) > 0 else None
    return Calibration(n, _finite(r) if r is not None else None, _finite(slope), _finite(intercept),
                       _finite(float(np.mean(c - p))), _finite(float(np.sqrt(np.mean((c - p) ** 2)))), rows)


def interval_table(predicted: NDArray, measured: NDArray, edges: tuple[float, ...] = INTERVAL_EDGES,
                   level: float = INTERVAL_LEVEL) -> tuple[tuple[float, ...], tuple[float, ...]]:
    """Per bin of ``predicted`` between ``edges``, the (1 − level)/2 and (1 + level)/2 quantiles of measured −
    predicted; a bin with fewer than 10 pairs takes the quantiles over all pairs."""
    p, c = np.asarray(predicted, float), np.asarray(measured, float)
    ok = np.isfinite(p) & np.isfinite(c)
    p, res = p[ok], c[ok] - p[ok]
    if len(res) == 0:
        raise PredictionError("no held-out predictions to build intervals from")
    qs = ((1 - level) / 2, (1 + level) / 2)
    overall = np.quantile(res, qs)
    b = np.clip(np.searchsorted(edges, p, side="right") - 1, 0, len(edges) - 2)
    low, high = [], []
    for j in range(len(edges) - 1):
        r = res[b == j]
        q = np.quantile(r, qs) if len(r) >= 10 else overall
        low.append(round(float(min(q[0], 0.0)), 4))
        high.append(round(float(max(q[1], 0.0)), 4))
    return tuple(low), tuple(high)


def coverage(model: CompletenessModel, predicted: NDArray, measured: NDArray) -> float | None:
    """The share of the measures inside their predictions' intervals."""
    p, c = np.asarray(predicted, float), np.asarray(measured, float)
    ok = np.isfinite(p) & np.isfinite(c)
    if not ok.any():
        return None
    lo, hi = model.interval(p[ok])
    return float(((c[ok] >= lo - 1e-9) & (c[ok] <= hi + 1e-9)).mean())


# =========================================================================== leave one group out
@dataclass(frozen=True)
class HeldOut:
    """One held-out group: the calibration of the predictor fitted without it, the interval coverage (intervals
    from the other held-out groups' residuals), and the single column with the largest |r| on the fitted groups
    (``best_single``, its r there and on the held-out group)."""

    group: str
    n: int
    calibration: Calibration
    coverage: float | None
    best_single: str | None
    best_single_r_fitted: float | None
    best_single_r: float | None
    single_r: dict

    @property
    def best_single_aligned(self) -> float | None:
        """The best single column's r on the held-out group, signed so that positive is the direction it had on
        the fitted groups (a metric that falls as completeness rises counts as predicting it there too)."""
        if self.best_single_r is None or self.best_single_r_fitted is None:
            return None
        return math.copysign(1.0, self.best_single_r_fitted) * self.best_single_r

    def to_dict(self) -> dict:
        return {"group": self.group, "n": self.n, "r": self.calibration.r, "slope": self.calibration.slope,
                "intercept": self.calibration.intercept, "bias": self.calibration.bias, "rmse": self.calibration.rmse,
                "coverage": self.coverage, "best_single": self.best_single,
                "best_single_r_fitted": self.best_single_r_fitted, "best_single_r": self.best_single_r,
                "best_single_r_aligned": self.best_single_aligned,
                "single_r": self.single_r, "reliability": self.calibration.bins}


def _r(x: NDArray, y: NDArray) -> float | None:
    ok = np.isfinite(x) & np.isfinite(y)
    if ok.sum() < 3 or np.ptp(x[ok]) == 0 or np.ptp(y[ok]) == 0:
        return None
    return float(np.corrcoef(x[ok], y[ok])[0, 1])


def leave_one_out(X: NDArray, c: NDArray, groups: NDArray, singles: dict[str, NDArray] | None = None, *,
                  features: tuple[str, ...] = FEATURES, ridge: float = RIDGE, balanced: bool = True
                  ) -> tuple[list[HeldOut], NDArray[np.float64]]:
    """Fit without each group and predict it: one :class:`HeldOut` per group, and the (m,) held-out predictions.
    ``singles``: single predictor columns (m,) to compare with (the one with the largest |r| on the fitted groups
    is reported, with its r on the held-out group)."""
    X = np.asarray(X, float).reshape(len(c), -1)
    c = np.asarray(c, float)
    groups = np.asarray(groups).astype(str)
    names = list(dict.fromkeys(groups.tolist()))
    if len(names) < 2:
        raise PredictionError("leaving one group out needs at least two groups")
    pred = np.full(len(c), np.nan)
    for g in names:
        train = (groups != g) & np.isfinite(c)
        model = fit_completeness(X[train], c[train], features=features, ridge=ridge,
                                 weights=group_weights(groups[train]) if balanced else None)
        pred[groups == g] = model.predict(X[groups == g])
    out = []
    for g in names:
        test = (groups == g) & np.isfinite(c)
        others = (groups != g) & np.isfinite(c)
        low, high = interval_table(pred[others], c[others])
        iv = CompletenessModel(features, np.zeros(len(features)), 0.0, np.zeros(len(features)),
                               np.ones(len(features)), ridge, 0, INTERVAL_EDGES, low, high)
        single_r = {k: _r(np.asarray(v, float)[test], c[test]) for k, v in (singles or {}).items()}
        fitted = {k: _r(np.asarray(v, float)[others], c[others]) for k, v in (singles or {}).items()}
        fitted = {k: v for k, v in fitted.items() if v is not None}
        best = max(fitted, key=lambda k: abs(fitted[k])) if fitted else None
        out.append(HeldOut(g, int(test.sum()), calibration(pred[test], c[test]), coverage(iv, pred[test], c[test]),
                           best, fitted.get(best) if best else None, single_r.get(best) if best else None, single_r))
    return out, pred
