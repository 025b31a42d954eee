"""The closed loop's page: one self-contained HTML file with the correlation table beside the paper's Table 2,
the logistic fit, the frames, the scatter plots and the model drawn twice — coloured by the predicted VR_i and by
the measured completeness — with the colours and shading of the evaluation report (:mod:`sightplan.report`).

It reads a :class:`~sightplan.engines.views.SceneView` made at the engine stage; it casts no ray itself.
"""

from __future__ import annotations

import base64
import html
import io
from collections.abc import Mapping
from pathlib import Path

import numpy as np
from numpy.typing import NDArray

from ..engines.views import SceneView
from ..metrics.elements import ElementMetrics
from ..report.colours import colour_bounds, metric_colours, traffic_light
from ..report.files import write_bytes
from ..report.html import CSS
from ..report.overview import OCCLUDER, UNSEEN, shaded_image
from ..study import MODERATE, STRONG, strength
from ..version import __version__
from .measure import ReconstructionMeasures
from .study import LABELS, PAPER_QUALITIES, LoopStudy

_EXTRA_CSS = """.strong{background:#f6c9a8;font-weight:bold}.moderate{background:#fbe8c8}td.num{text-align:right}
figure{margin:10px 0}figcaption{color:#555;font-size:13px}"""


def measured_colours(measures: ReconstructionMeasures) -> NDArray[np.float64]:
    """(z, 3) sRGB: the traffic light from completeness 1 (green) to 0 (red); grey occluders, the 'unseen' red
    where no sample is visible."""
    c = measures.completeness
    rgb = traffic_light(1.0 - np.nan_to_num(c, nan=0.0))
    rgb[~np.isfinite(c)] = UNSEEN
    rgb[~measures.is_target] = OCCLUDER
    return rgb


def model_png(view: SceneView, em: ElementMetrics, measures: ReconstructionMeasures) -> str:
    """A data-URL PNG: the model coloured by VR_i (left) and by the measured completeness (right)."""
    from matplotlib.backends.backend_agg import FigureCanvasAgg
    from matplotlib.figure import Figure

    predicted = metric_colours(em, "vr")[:, :3]
    cam = view.camera
    fig = Figure(figsize=(2 * cam.width / 130, cam.height / 130 + 0.5), dpi=100)
    FigureCanvasAgg(fig)
    lo, hi = colour_bounds(em, "vr")
    titles = (f"predicted: VR_i (green {hi:.3g} → red {lo:.3g} frames; unseen red)",
              "measured: completeness (green 1 → red 0; no visible surface: unseen red)")
    for k, (colours, title) in enumerate(zip((predicted, measured_colours(measures)), titles, strict=True)):
        ax = fig.add_subplot(1, 2, k + 1)
        ax.imshow(shaded_image(view, colours), interpolation="nearest")
        ax.set_title(title, fontsize=9)
        ax.set_axis_off()
    fig.tight_layout(pad=0.3)
    buf = io.BytesIO()
    fig.savefig(buf, format="png")
    return "data:image/png;base64," + base64.b64encode(buf.getvalue()).decode("ascii")


def _f(v, spec: str) -> str:
    return "—" if v is None or (isinstance(v, float) and not np.isfinite(v)) else format(v, spec)


def _cls(r) -> str:
    """The cell's class: the strength of r when it is strong or moderate."""
    s = strength(r)
    return s if s in ("strong", "moderate") else ""


def comparison_table(study: LoopStudy) -> str:
    e = html.escape
    head = ("<tr><th>predictor</th><th>with</th><th>n</th><th>Pearson r</th><th>p</th><th>Spearman ρ</th><th>p</th>"
            "<th>paper's metric</th>" + "".join(f"<th>paper r ({q})</th>" for q in PAPER_QUALITIES) + "</tr>")
    rows = []
    for r in study.comparison():
        label = LABELS.get(r["predictor"], r["predictor"])
        paper = "".join(f"<td class='num {_cls(r[f'paper_r_{q}'])}'>{_f(r[f'paper_r_{q}'], '+.2f')}</td>"
                        for q in PAPER_QUALITIES)
        rows.append(f"<tr><td>{e(label)}</td><td>{e(r['quality'])}</td><td class='num'>{r['n']}</td>"
                    f"<td class='num {_cls(r['pearson_r'])}'>{_f(r['pearson_r'], '+.3f')}</td>"
                    f"<td class='num'>{_f(r['pearson_p'], '.2g')}</td>"
                    f"<td class='num {_cls(r['spearman_r'])}'>{_f(r['spearman_r'], '+.3f')}</td>"
                    f"<td class='num'>{_f(r['spearman_p'], '.2g')}</td><td>{e(str(r['paper_metric'] or '—'))}</td>"
                    f"{paper}</tr>")
    return f"<table id='comparison'>{head}{''.join(rows)}</table>"


def pairs_table(study: LoopStudy) -> str:
    e = html.escape
    rows = "".join(
        f"<tr><td>{e(LABELS[c.predictor])}</td><td>{e(LABELS[c.measure])}</td><td class='num'>{c.n}</td>"
        f"<td class='num {_cls(c.pearson_r)}'>{_f(c.pearson_r, '+.3f')}</td><td class='num'>{_f(c.pearson_p, '.2g')}"
        f"</td><td class='num {_cls(c.spearman_r)}'>{_f(c.spearman_r, '+.3f')}</td>"
        f"<td class='num'>{_f(c.spearman_p, '.2g')}</td></tr>" for c in study.correlations)
    return ("<table id='pairs'><tr><th>predictor</th><th>measure</th><th>n</th><th>Pearson r</th><th>p</th>"
            f"<th>Spearman ρ</th><th>p</th></tr>{rows}</table>")


def logistic_html(study: LoopStudy) -> str:
    fit = study.logistic
    if fit is None:
        return f"<p>No logistic fit: {html.escape(study.fit_note)}</p>"
    rows = "".join(f"<tr><td>{html.escape(LABELS[p])}</td><td class='num'>{fit.coef[k]:+.3f}</td>"
                   f"<td class='num'>{_f(float(fit.se[k]), '.3f')}</td><td class='num'>{_f(float(fit.p[k]), '.2g')}</td>"
                   f"<td class='num'>{fit.raw_coef[k]:+.4g}</td></tr>" for k, p in enumerate(fit.predictors))
    return (f"<p>P(reconstructed) = σ(b₀ + Σ bₖ·zₖ) over {fit.n} elements ({fit.positives} reconstructed, "
            f"completeness ≥ {study.threshold:g}); in-sample accuracy {100 * fit.accuracy:.1f} % against "
            f"{100 * max(fit.base_rate, 1 - fit.base_rate):.1f} % for the majority class; McFadden pseudo-R² "
            f"{fit.pseudo_r2:.3f}; intercept {fit.intercept:+.3f} (standardised).</p>"
            "<table id='logistic'><tr><th>predictor</th><th>b per SD</th><th>SE</th><th>p</th><th>b per unit</th></tr>"
            f"{rows}</table>")


def frames_html(study: LoopStudy) -> str:
    f = study.frames
    return (f"<p>{f.registered} of {f.n} frames registered; {f.stable} predicted stable (ν_f ≥ Λ). Point-biserial r "
            f"of ν_f and registered: {_f(f.r, '+.3f')} (p {_f(f.p, '.2g')}); agreement {_f(100 * f.agreement, '.1f')} %."
            "</p><table id='confusion'><tr><th></th><th>registered</th><th>not registered</th></tr>"
            f"<tr><th>stable</th><td class='num'>{f.stable_registered}</td><td class='num'>{f.stable_unregistered}</td>"
            f"</tr><tr><th>not stable</th><td class='num'>{f.unstable_registered}</td>"
            f"<td class='num'>{f.unstable_unregistered}</td></tr></table>")


def loop_page(study: LoopStudy, measures: ReconstructionMeasures, *, images: Mapping[str, Path] | None = None,
              view: SceneView | None = None, em: ElementMetrics | None = None, title: str = "",
              facts: Mapping[str, str] | None = None, links: Mapping[str, str] | None = None) -> str:
    """The page as one string. images: caption → PNG file (embedded). view and em: the model pictures.
    facts: label → text for the header. links: label → relative URL (the evaluation report, the files)."""
    e = html.escape
    title = title or "sightplan — the closed loop"
    s = measures.summary()
    meta = {"elements": f"{study.n_elements} target elements, {s['elements_visible']} with visible surface, "
                        f"{s['elements_with_points']} with points",
            "reconstruction": f"{s['points']:,} points, {s['points_on_model']:,} within τ of the model; "
                              f"{s['frames_registered']} of {s['frames']} frames registered",
            "registration": f"residual {measures.residual_m:.4g} m ({100 * (s['residual_share'] or 0):.3f} % of "
                            f"{measures.scene_size_m:.3g} m); position error mean {_f(s['position_error_m_mean'], '.4g')}"
                            f" m, rotation error mean {_f(s['rotation_error_deg_mean'], '.3g')}°",
            "measures": f"τ = {measures.tolerance_m:.4g} m, r = {measures.radius_m:.4g} m, ρ = "
                        f"{_f(measures.resolution_m_px, '.4g')} m/px, {measures.samples_per_m2:g} samples per m²",
            **(facts or {})}
    meta_html = "".join(f"<dt>{e(k)}</dt><dd>{e(v)}</dd>" for k, v in meta.items())
    paper = ("" if study.paper is None else
             f" The paper's columns are its Table 2 correlations over {study.paper.n_rows} data sets of the analogous "
             "plan metric with element completeness Ce and visible completeness Cv.")
    parts = [f"<!DOCTYPE html><html lang='en'><head><meta charset='utf-8'><meta name='generator' content='sightplan "
             f"{e(__version__)}'><title>{e(title)}</title><style>{CSS}{_EXTRA_CSS}</style></head><body>",
             f"<h1>{e(title)}</h1><dl class='meta'>{meta_html}</dl>"]
    if links:
        parts.append("<p>" + " · ".join(f"<a href='{e(url)}'>{e(label)}</a>" for label, url in links.items()) + "</p>")
    parts += ["<h2>Predicted against measured, per element</h2>",
              f"<p>Correlations over the elements where both numbers are defined; <span class='strong'>strong</span> "
              f"|r| ≥ {STRONG}, <span class='moderate'>moderate</span> {MODERATE} ≤ |r| &lt; {STRONG}.{paper}</p>",
              comparison_table(study), "<h3>Every pair</h3>", pairs_table(study),
              "<h2>Reconstructed or not: a logistic fit</h2>", logistic_html(study),
              "<h2>Frames: predicted stability against registration</h2>", frames_html(study)]
    if view is not None and em is not None:
        parts.append(f"<h2>The model</h2><img class='plot' alt='the model coloured by predicted and measured' "
                     f"src='{model_png(view, em, measures)}'>")
    for caption, path in (images or {}).items():
        data = base64.b64encode(Path(path).read_bytes()).decode("ascii")
        parts.append(f"<figure><img class='plot' alt='{e(caption)}' src='data:image/png;base64,{data}'>"
                     f"<figcaption>{e(caption)}</figcaption></figure>")
    parts.append(f"<footer>sightplan {e(__version__)}</footer></body></html>")
    return "\n".join(parts)


def write_loop_page(path: str | Path, study: LoopStudy, measures: ReconstructionMeasures, **kwargs) -> Path:
    """Write :func:`loop_page` to ``path``."""
    return write_bytes(path, loop_page(study, measures, **kwargs))
