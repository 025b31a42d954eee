"""Correlation study (METRICS.md §8; paper §4.3, Figs. 11–13): plan metrics against reconstruction quality.

Input is a CSV with one row per data set. Plan-metric columns are VC, V̄C, VR, R, O, T and quality
columns A, Ce, Cv, Ct; both the paper's Table 2 names (``VC_pct``, ``VCbar_pct``, ``R_m``, ``O_deg``,
``A_m``, ``Ce_pct``, …) and sightplan's own (``VC``, ``VC_bar``, ``VC_pct``, ``VC_bar_pct``, …) are
recognised, case-insensitively. Other columns are ignored; a ``dataset``/``name``/``label`` column
labels the points.

Units do not matter: Pearson ``r`` is invariant under a positive rescaling or shift of either
variable, so a column in percent and the same column as a fraction give the same ``r`` and ``p``.
The fitted line and its band are drawn in the file's own units.

Every metric × quality pair uses the rows where both cells hold numbers (blank, ``NA`` or ``nan``
cells leave that row out of that pair only) and needs at least 3 such rows; ``n`` is reported per
pair. ``r`` and the two-sided ``p`` come from :func:`scipy.stats.pearsonr`. A pair is **strong**
when ``|r| ≥ 0.5``, **moderate** when ``0.25 ≤ |r| < 0.5`` and **weak** otherwise; ``n/a`` when
``r`` is undefined (fewer than 3 rows, or a constant column).
"""

from __future__ import annotations

import base64
import csv
import html
import json
import math
import warnings
from collections.abc import Iterable, Mapping, Sequence
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from .errors import SightplanError

METRICS = ("VC", "VC_bar", "VR", "R", "O", "T")
QUALITIES = ("A", "Ce", "Cv", "Ct")
STRONG = 0.5
MODERATE = 0.25
MIN_ROWS = 3

DISPLAY = {"VC": "VC", "VC_bar": "V̄C", "VR": "VR", "R": "R", "O": "O", "T": "T",
           "A": "A", "Ce": "Ce", "Cv": "Cv", "Ct": "Ct"}
MATH_DISPLAY = {**DISPLAY, "VC_bar": r"$\overline{\mathrm{V}}\mathrm{C}$"}
MEANING = {"VC": "visual coverage", "VC_bar": "relative visual coverage", "VR": "visual redundancy",
           "R": "back-projection resolution", "O": "viewpoint orientation", "T": "stability",
           "A": "accuracy", "Ce": "element completeness", "Cv": "visible completeness", "Ct": "total completeness"}

_ALIASES: dict[str, tuple[str, ...]] = {
    "VC": ("vc", "vc_pct", "vc_%", "vc_percent"),
    "VC_bar": ("vc_bar", "vcbar", "vc_bar_pct", "vcbar_pct", "vc_bar_%", "vcbar_%", "v̄c", "v̄c_pct", "vc̄"),
    "VR": ("vr", "vr_frames"),
    "R": ("r", "r_m", "r_m_px", "r_m/px", "r_m_per_px"),
    "O": ("o", "o_deg", "o_°"),
    "T": ("t", "t_features"),
    "A": ("a", "a_m"),
    "Ce": ("ce", "ce_pct", "ce_%"),
    "Cv": ("cv", "cv_pct", "cv_%"),
    "Ct": ("ct", "ct_pct", "ct_%"),
}
_CANONICAL = {alias: name for name, aliases in _ALIASES.items() for alias in aliases}
_LABEL_COLUMNS = ("dataset", "data_set", "name", "label", "id", "project")
_MISSING = {"", "na", "n/a", "nan", "none", "null", "—", "–", "-"}


class StudyError(SightplanError):
    """A study table that cannot be read or correlated."""


def _key(name: str) -> str:
    return "_".join(name.strip().lower().replace("-", " ").replace("(", " ").replace(")", " ").split())


def canonical(name: str) -> str | None:
    """The metric or quality a column name stands for (``'Ce_pct'`` → ``'Ce'``), or None."""
    return _CANONICAL.get(_key(name))


def strength(r: float | None) -> str:
    """``strong`` for |r| ≥ 0.5, ``moderate`` for 0.25 ≤ |r| < 0.5, ``weak`` below, ``n/a`` when undefined."""
    if r is None or not math.isfinite(r):
        return "n/a"
    if abs(r) >= STRONG:
        return "strong"
    if abs(r) >= MODERATE:
        return "moderate"
    return "weak"


def pearson(x: Sequence[float], y: Sequence[float]) -> tuple[float | None, float | None]:
    """Pearson ``r`` and the two-sided ``p`` of paired finite samples; (None, None) when undefined
    (fewer than 3 pairs or a constant sample)."""
    from scipy.stats import pearsonr

    return _coefficient(pearsonr, x, y)


def spearman(x: Sequence[float], y: Sequence[float]) -> tuple[float | None, float | None]:
    """Spearman's ρ and its two-sided p, undefined as :func:`pearson` is."""
    from scipy.stats import spearmanr

    return _coefficient(spearmanr, x, y)


def _coefficient(test, x: Sequence[float], y: Sequence[float]) -> tuple[float | None, float | None]:
    x, y = np.asarray(x, dtype=float), np.asarray(y, dtype=float)
    if len(x) < MIN_ROWS or np.ptp(x) == 0 or np.ptp(y) == 0:
        return None, None
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        res = test(x, y)
    r, p = float(res.statistic), float(res.pvalue)
    return (r, p) if math.isfinite(r) else (None, None)


@dataclass(frozen=True)
class LineFit:
    """Least-squares line ``y = intercept + slope·x`` with the confidence band of its mean.

    With ``s² = Σ(yᵢ − ŷᵢ)² / (n − 2)`` and ``Sxx = Σ(xᵢ − x̄)²``, the band at ``x₀`` is
    ``ŷ(x₀) ± t(1 − α/2, n − 2) · s · √(1/n + (x₀ − x̄)² / Sxx)``: a confidence band for the mean
    response (not a prediction band for new points)."""

    slope: float
    intercept: float
    s: float
    n: int
    x_mean: float
    sxx: float

    def predict(self, x: float | np.ndarray) -> np.ndarray:
        return self.intercept + self.slope * np.asarray(x, dtype=float)

    def half_width(self, x: float | np.ndarray, level: float = 0.95) -> np.ndarray:
        """Half-width of the ``level`` confidence band for the mean at ``x``."""
        from scipy.stats import t as student_t

        tq = float(student_t.ppf(0.5 + level / 2, self.n - 2))
        x = np.asarray(x, dtype=float)
        return tq * self.s * np.sqrt(1.0 / self.n + (x - self.x_mean) ** 2 / self.sxx)

    def band(self, x: float | np.ndarray, level: float = 0.95) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """(ŷ, lower, upper) at ``x``."""
        yhat, half = self.predict(x), self.half_width(x, level)
        return yhat, yhat - half, yhat + half


def fit_line(x: Sequence[float], y: Sequence[float]) -> LineFit:
    """Ordinary least squares of ``y`` on ``x`` (needs ≥ 3 points and ≥ 2 distinct ``x``)."""
    x, y = np.asarray(x, dtype=float), np.asarray(y, dtype=float)
    n = len(x)
    if n < MIN_ROWS or np.ptp(x) == 0:
        raise StudyError(f"a line with a confidence band needs ≥ {MIN_ROWS} points with distinct x (got {n})")
    x_mean = float(x.mean())
    sxx = float(((x - x_mean) ** 2).sum())
    slope = float(((x - x_mean) * (y - y.mean())).sum() / sxx)
    intercept = float(y.mean() - slope * x_mean)
    resid = y - (intercept + slope * x)
    s = math.sqrt(float((resid**2).sum()) / (n - 2))
    return LineFit(slope, intercept, s, n, x_mean, sxx)


@dataclass(frozen=True)
class Pair:
    """One metric × quality correlation over the ``n`` data sets that have both values."""

    metric: str
    quality: str
    n: int
    r: float | None
    p: float | None
    strength: str


@dataclass
class Study:
    """Correlations of every plan metric present with every quality present.

    ``columns`` maps canonical names (``VC``, ``VC_bar``, …, ``Ct``) to float arrays, NaN for a blank
    cell; ``headers`` maps them back to the file's column names."""

    labels: list[str]
    columns: dict[str, np.ndarray]
    metrics: tuple[str, ...]
    qualities: tuple[str, ...]
    pairs: list[Pair]
    headers: dict[str, str] = field(default_factory=dict)
    source: Path | None = None

    @classmethod
    def from_csv(cls, path: str | Path) -> Study:
        return read_study(path)

    @property
    def n_rows(self) -> int:
        return len(self.labels)

    def pair(self, metric: str, quality: str) -> Pair:
        m, q = canonical(metric) or metric, canonical(quality) or quality
        for p in self.pairs:
            if p.metric == m and p.quality == q:
                return p
        raise StudyError(f"no pair {metric}:{quality} in this study (metrics: {', '.join(self.metrics)}; "
                         f"qualities: {', '.join(self.qualities)})")

    def r(self, metric: str, quality: str) -> float | None:
        return self.pair(metric, quality).r

    def strong(self) -> list[Pair]:
        """The strong pairs, strongest first."""
        return sorted((p for p in self.pairs if p.strength == "strong"), key=lambda p: -abs(p.r or 0.0))

    def r_matrix(self) -> np.ndarray:
        """``r`` as a metrics × qualities array, NaN where undefined."""
        out = np.full((len(self.metrics), len(self.qualities)), np.nan)
        for p in self.pairs:
            if p.r is not None:
                out[self.metrics.index(p.metric), self.qualities.index(p.quality)] = p.r
        return out

    def xy(self, metric: str, quality: str) -> tuple[list[str], np.ndarray, np.ndarray]:
        """The labels and values of the rows where both cells hold numbers."""
        x, y = self.columns[metric], self.columns[quality]
        ok = np.isfinite(x) & np.isfinite(y)
        return [lab for lab, keep in zip(self.labels, ok) if keep], x[ok], y[ok]

    def label(self, name: str) -> str:
        """Axis label: the display name, and the file's column name when it differs."""
        header = self.headers.get(name, name)
        return MATH_DISPLAY[name] + ("" if header in (name, DISPLAY[name]) else f" ({header})")

    def table(self) -> list[dict]:
        """The tidy table: one row per pair with metric, quality, n, r, p, strength."""
        return [{"metric": p.metric, "quality": p.quality, "n": p.n, "r": p.r, "p": p.p, "strength": p.strength}
                for p in self.pairs]

    def to_csv(self, path: str | Path) -> Path:
        path = Path(path)
        with open(path, "w", newline="", encoding="utf-8") as fh:
            w = csv.DictWriter(fh, fieldnames=["metric", "quality", "n", "r", "p", "strength"])
            w.writeheader()
            for row in self.table():
                w.writerow({k: "" if v is None else (f"{v:.6g}" if isinstance(v, float) else v) for k, v in row.items()})
        return path


def _check_columns(names: Sequence[str], where: str) -> None:
    found = {canonical(n) for n in names}
    missing = [kind for kind, group in (("plan-metric", METRICS), ("quality", QUALITIES)) if not found & set(group)]
    if missing:
        raise StudyError(f"{where}no {' and no '.join(missing)} column; expected plan metrics VC, VC_bar, VR, R, O, T "
                         "(or the paper's VC_pct, VCbar_pct, VR, R_m, O_deg, T) and qualities A, Ce, Cv, Ct "
                         f"(or A_m, Ce_pct, Cv_pct, Ct_pct); found: {', '.join(names) or 'no columns'}")


def correlate(columns: Mapping[str, Sequence[float | None]], labels: Sequence[str] | None = None,
              source: Path | None = None) -> Study:
    """A study from in-memory columns; keys may be any recognised column name, None or NaN is a blank."""
    data: dict[str, np.ndarray] = {}
    names: dict[str, str] = {}
    for key, values in columns.items():
        name = canonical(key)
        if name is None:
            continue
        if name in data:
            raise StudyError(f"columns {names[name]!r} and {key!r} both give {DISPLAY[name]}")
        data[name] = np.array([np.nan if v is None else float(v) for v in values], dtype=float)
        names[name] = key
    metrics = tuple(m for m in METRICS if m in data)
    qualities = tuple(q for q in QUALITIES if q in data)
    where = f"{source.name}: " if source is not None else ""
    _check_columns(list(columns), where)
    n_rows = len(next(iter(data.values())))
    if any(len(v) != n_rows for v in data.values()):
        raise StudyError("columns of different lengths")
    if n_rows < MIN_ROWS:
        raise StudyError(f"{where}{n_rows} data set{'s' if n_rows != 1 else ''}; a correlation needs at least {MIN_ROWS}")
    labs = [str(s) for s in labels] if labels is not None else [f"#{i + 1}" for i in range(n_rows)]
    pairs = []
    for m in metrics:
        for q in qualities:
            x, y = data[m], data[q]
            ok = np.isfinite(x) & np.isfinite(y)
            r, p = pearson(x[ok], y[ok])
            pairs.append(Pair(m, q, int(ok.sum()), r, p, strength(r)))
    return Study(labs, data, metrics, qualities, pairs, names, source)


def read_study(path: str | Path) -> Study:
    """Read a study table (one row per data set) and correlate it."""
    path = Path(path)
    if not path.is_file():
        raise StudyError(f"no such file: {path}")
    try:
        text = path.read_text(encoding="utf-8-sig")
    except (OSError, UnicodeDecodeError) as exc:
        raise StudyError(f"cannot read {path}: {exc}") from None
    try:
        dialect: type[csv.Dialect] | csv.Dialect = csv.Sniffer().sniff(text[:4096], delimiters=",;\t")
    except csv.Error:
        dialect = csv.excel
    reader = csv.reader(text.splitlines(), dialect)
    header = next(reader, None)
    if not header or not any(h.strip() for h in header):
        raise StudyError(f"{path.name}: empty file, expected a header row with the metric and quality columns")
    header = [h.strip() for h in header]
    _check_columns(header, f"{path.name}: ")
    wanted = {i: canonical(h) for i, h in enumerate(header) if canonical(h) is not None}
    label_col = next((i for i, h in enumerate(header) if _key(h) in _LABEL_COLUMNS), None)
    values: dict[int, list[float]] = {i: [] for i in wanted}
    labels: list[str] = []
    for row in reader:
        if not any(c.strip() for c in row):
            continue
        line = reader.line_num
        label = row[label_col].strip() if label_col is not None and label_col < len(row) else ""
        labels.append(label or f"line {line}")
        for i in wanted:
            cell = row[i].strip() if i < len(row) else ""
            if cell.lower() in _MISSING:
                values[i].append(math.nan)
                continue
            try:
                v = float(cell)
            except ValueError:
                v = None
            if v is None or math.isinf(v):
                raise StudyError(f"{path.name}: line {line}{f' ({label})' if label else ''}, column {header[i]!r}: "
                                 f"{cell!r} is not a number")
            values[i].append(v)
    columns = {header[i]: values[i] for i in wanted}
    return correlate(columns, labels, source=path)


def parse_pair(text: str, study: Study) -> tuple[str, str]:
    """``'VR:Ce'`` (any recognised names, either order) → canonical (metric, quality) present in ``study``."""
    parts = text.split(":")
    if len(parts) != 2:
        raise StudyError(f"--pair {text!r}: write METRIC:QUALITY, e.g. VR:Ce")
    a, b = canonical(parts[0]), canonical(parts[1])
    if a in QUALITIES and b in METRICS:
        a, b = b, a
    if a not in study.metrics or b not in study.qualities:
        raise StudyError(f"--pair {text!r}: not a metric:quality pair of this table "
                         f"(metrics: {', '.join(study.metrics)}; qualities: {', '.join(study.qualities)})")
    return a, b  # type: ignore[return-value]


def _pyplot():
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    return plt


def plot_heatmap(study: Study, path: str | Path, title: str = "") -> Path:
    """Heat map of ``r``, metrics × qualities, diverging colours over −1..1 with the values in the cells (Fig. 11)."""
    plt = _pyplot()
    path = Path(path)
    mat = study.r_matrix()
    fig, ax = plt.subplots(figsize=(1.3 * len(study.qualities) + 2.4, 0.75 * len(study.metrics) + 1.6))
    cmap = plt.get_cmap("RdBu_r").with_extremes(bad="#dddddd")
    im = ax.imshow(np.ma.masked_invalid(mat), cmap=cmap, vmin=-1, vmax=1, aspect="auto")
    for i, m in enumerate(study.metrics):
        for j, q in enumerate(study.qualities):
            pr = study.pair(m, q)
            text = "n/a" if pr.r is None else f"{pr.r:.2f}"
            colour = "white" if pr.r is not None and abs(pr.r) > 0.6 else "black"
            ax.text(j, i, text, ha="center", va="center", color=colour, fontsize=10,
                    fontweight="bold" if pr.strength == "strong" else "normal")
    ax.set_xticks(range(len(study.qualities)), [MATH_DISPLAY[q] for q in study.qualities])
    ax.set_yticks(range(len(study.metrics)), [MATH_DISPLAY[m] for m in study.metrics])
    ax.xaxis.tick_top()
    ax.set_xlabel("reconstruction quality")
    ax.xaxis.set_label_position("top")
    ax.set_ylabel("plan metric")
    fig.colorbar(im, ax=ax, label="Pearson r")
    ax.set_title(title or f"Pearson r over {study.n_rows} data sets", pad=28)
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)
    return path


def plot_scatter(study: Study, metric: str, quality: str, path: str | Path, level: float = 0.95) -> Path:
    """One pair: the data sets as labelled points, the least-squares line and its confidence band (Figs. 12–13)."""
    plt = _pyplot()
    path = Path(path)
    labels, x, y = study.xy(metric, quality)
    pr = study.pair(metric, quality)
    fig, ax = plt.subplots(figsize=(6.4, 4.8))
    if len(x) >= MIN_ROWS and np.ptp(x) > 0:
        fit = fit_line(x, y)
        pad = 0.05 * np.ptp(x)
        xs = np.linspace(x.min() - pad, x.max() + pad, 200)
        yhat, lo, hi = fit.band(xs, level)
        ax.fill_between(xs, lo, hi, color="#1f6f43", alpha=0.18, lw=0, label=f"{100 * level:.0f} % confidence band")
        ax.plot(xs, yhat, color="#1f6f43", lw=1.8, label="least-squares line")
    ax.scatter(x, y, color="#222222", zorder=3, s=22)
    for lab, xi, yi in zip(labels, x, y):
        ax.annotate(lab, (xi, yi), xytext=(4, 4), textcoords="offset points", fontsize=8)
    ax.set_xlabel(study.label(metric))
    ax.set_ylabel(study.label(quality))
    r_text = "n/a" if pr.r is None else f"{pr.r:.2f}"
    p_text = "" if pr.p is None else f", p = {pr.p:.3g}"
    ax.set_title(f"{MATH_DISPLAY[metric]} vs {MATH_DISPLAY[quality]}: r = {r_text}{p_text}, n = {pr.n}")
    ax.grid(alpha=0.3)
    ax.legend(loc="best", fontsize=8)
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)
    return path


_CSS = """body{font-family:system-ui,sans-serif;margin:2em;color:#222}table{border-collapse:collapse;margin:1em 0}
td,th{border:1px solid #ccc;padding:.3em .7em;text-align:right}th{background:#f3f3f3}
.strong{background:#f6c9a8;font-weight:bold}.moderate{background:#fbe8c8}.na{color:#999}
img{max-width:100%;margin:1em 0;display:block}caption{text-align:left;font-weight:bold;padding:.3em 0}"""


_STRENGTH_CLASS = {"strong": "strong", "moderate": "moderate", "n/a": "na"}


def _fmt(v: float | None, spec: str) -> str:
    return "—" if v is None else format(v, spec)


def write_html(study: Study, path: str | Path, images: Iterable[Path] = ()) -> Path:
    """A self-contained page: the r matrix, the tidy table (strong and moderate pairs highlighted) and the
    figures embedded as base64 PNG."""
    path = Path(path)
    esc = html.escape
    title = f"Correlation study — {study.source.name}" if study.source else "Correlation study"
    out = [f"<!DOCTYPE html><html><head><meta charset='utf-8'><title>{esc(title)}</title><style>{_CSS}</style></head><body>",
           f"<h1>{esc(title)}</h1>",
           f"<p>{study.n_rows} data sets ({esc(', '.join(study.labels))}). Pearson r with two-sided p; "
           f"<span class='strong'>strong</span> |r| ≥ {STRONG}, <span class='moderate'>moderate</span> "
           f"{MODERATE} ≤ |r| &lt; {STRONG}. Bands: 95 % confidence band of the least-squares mean "
           "(t-distribution, n − 2 degrees of freedom).</p>",
           "<table><caption>r (rows: plan metrics, columns: reconstruction quality)</caption><tr><th></th>"
           + "".join(f"<th>{esc(DISPLAY[q])}</th>" for q in study.qualities) + "</tr>"]
    for m in study.metrics:
        cells = []
        for q in study.qualities:
            p = study.pair(m, q)
            cls = _STRENGTH_CLASS.get(p.strength, "")
            cells.append(f"<td class='{cls}'>{_fmt(p.r, '+.2f')}</td>")
        out.append(f"<tr><th>{esc(DISPLAY[m])}</th>{''.join(cells)}</tr>")
    out.append("</table><table><caption>All pairs</caption>"
               "<tr><th>metric</th><th>quality</th><th>n</th><th>r</th><th>p</th><th>strength</th></tr>")
    for p in study.pairs:
        cls = _STRENGTH_CLASS.get(p.strength, "")
        out.append(f"<tr class='{cls}'><td>{esc(DISPLAY[p.metric])}</td><td>{esc(DISPLAY[p.quality])}</td>"
                   f"<td>{p.n}</td><td>{_fmt(p.r, '+.3f')}</td><td>{_fmt(p.p, '.3g')}</td><td>{p.strength}</td></tr>")
    out.append("</table>")
    for img in images:
        data = base64.b64encode(Path(img).read_bytes()).decode("ascii")
        out.append(f"<img alt='{esc(Path(img).stem)}' src='data:image/png;base64,{data}'>")
    out.append("</body></html>")
    path.write_text("\n".join(out), encoding="utf-8")
    return path


def write_study(study: Study, out: str | Path, pairs: Iterable[tuple[str, str]] = ()) -> dict[str, Path]:
    """Write correlations.csv, heatmap.png, scatter_<metric>_<quality>.png for every strong pair and every
    pair in ``pairs``, and study.html into ``out``."""
    out = Path(out)
    out.mkdir(parents=True, exist_ok=True)
    paths = {"correlations": study.to_csv(out / "correlations.csv"), "heatmap": plot_heatmap(study, out / "heatmap.png")}
    wanted = [(p.metric, p.quality) for p in study.strong()]
    wanted += [mq for mq in pairs if mq not in wanted]
    for m, q in wanted:
        paths[f"scatter_{m}_{q}"] = plot_scatter(study, m, q, out / f"scatter_{m}_{q}.png")
    images = [v for k, v in paths.items() if k != "correlations"]
    paths["html"] = write_html(study, out / "study.html", images)
    return paths


def collect_table(folders: Sequence[str | Path], path: str | Path) -> Path:
    """Write a study table from output folders: each holds ``report.json`` (``sightplan evaluate --out``)
    and ``validation.json`` (``sightplan validate --out``), one data set per folder, named by the folder."""
    rows = []
    for folder in map(Path, folders):
        row: dict = {"dataset": folder.name}
        for name, keys in (("report.json", ("VC_pct", "VC_bar_pct", "VR", "R_m_per_px", "O_deg", "T")),
                           ("validation.json", ("A_m", "Ce", "Cv", "Ct"))):
            f = folder / name
            if not f.is_file():
                raise StudyError(f"{folder}: no {name} — run `sightplan "
                                 f"{'evaluate' if name == 'report.json' else 'validate'} … --out {folder}` first")
            try:
                metrics = json.loads(f.read_text(encoding="utf-8"))["metrics"]
            except (ValueError, KeyError, TypeError) as exc:
                raise StudyError(f"{f}: not a sightplan {name} ({exc})") from None
            for k in keys:
                v = metrics.get(k)
                if k in ("Ce", "Cv", "Ct"):  # fractions in validation.json; percent here, as VC and the paper's table
                    row[f"{k}_pct"] = None if v is None else 100.0 * float(v)
                else:
                    row[k] = v
        rows.append(row)
    if not rows:
        raise StudyError("give at least one folder to collect")
    path = Path(path)
    with open(path, "w", newline="", encoding="utf-8") as fh:
        w = csv.DictWriter(fh, fieldnames=list(rows[0]))
        w.writeheader()
        for r in rows:
            w.writerow({k: "" if v is None else v for k, v in r.items()})
    return path
