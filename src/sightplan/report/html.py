"""One self-contained HTML report of an evaluation, to open in any browser with nothing installed.

The page holds the plan metrics as in the paper's Table 2, per-element histograms and ν_f
along the path (inline PNGs), the worst elements, and an interactive 3D view: the coloured
GLB of :mod:`.gltf` as base64, drawn by three.js. three.js is not fetched from anywhere: its
ES modules are read from the wheel's own copy, or in a checkout from ``web/node_modules/three``
(installed by ``make setup`` from the project's ``web/package.json``), and inlined as module text, wired together by an import map
of blob URLs. The page loads no http(s) resource.
"""

from __future__ import annotations

import base64
import datetime as dt
import html
import io
import json
import posixpath
import re
from collections.abc import Callable
from pathlib import Path

import numpy as np

from ..assets import vendor_root
from ..errors import ReportError
from ..evaluate import Evaluation
from ..metrics.glossary import GLOSSARY, explain
from ..model.scene import Scene
from ..plan.types import Plan
from ..version import __version__
from .colours import (
    COLOUR_BY,
    GRADIENT,
    METRIC_LABELS,
    OCCLUDER,
    UNSEEN,
    ColourBy,
    check_colour_by,
    colour_bounds,
    element_values,
    visibility_class,
)
from .files import write_bytes
from .gltf import ViewerFrame, scene_glb
from .overview import OBSERVED_ONLY, VISIBLE

REPO_ROOT = Path(__file__).resolve().parents[3]
THREE_DIR = vendor_root() / "three"  # a wheel's own copy, else the checkout's web/node_modules
# The bare specifiers the viewer imports → files in the three package.
THREE_ENTRIES = {
    "three": "build/three.module.js",
    "three/addons/controls/OrbitControls.js": "examples/jsm/controls/OrbitControls.js",
    "three/addons/loaders/GLTFLoader.js": "examples/jsm/loaders/GLTFLoader.js",
}
# Top-level static imports and re-exports (statements start a line in three's sources).
_IMPORT = re.compile(r"""^(?:import|export)\b[^;'"]*?\bfrom\s*(['"])([^'"\n]+)\1|^import\s*(['"])([^'"\n]+)\3""", re.M)
_SCRIPT_END = re.compile(r"</(script)", re.I)

# Table 2 of the paper: one row per plan. (attribute, heading, unit, format, scale)
PLAN_COLUMNS: tuple[tuple[str, str, str, str, float], ...] = (
    ("VC", "VC", "%", ".2f", 100.0),
    ("VC_bar", "V̄C", "%", ".2f", 100.0),
    ("VR", "VR", "frames", ".2f", 1.0),
    ("R", "R", "m/px", ".4f", 1.0),
    ("O", "O", "°", ".2f", 1.0),
    ("T", "T", "features", ".1f", 1.0),
)
GLOSSARY_KEYS = {"VC": "VC_pct", "VC_bar": "VC_bar_pct", "VR": "VR", "R": "R_m_per_px", "O": "O_deg", "T": "T"}
STABLE_COLOUR, UNSTABLE_COLOUR = VISIBLE, UNSEEN
COLOURS_JS = Path(__file__).with_name("colours.js")  # the viewer's colouring, shared with the web page


# --------------------------------------------------------------------------- three.js
def find_three(three_dir: str | Path | None = None) -> Path:
    """The installed three package (``web/node_modules/three`` of the repository), or one clear error."""
    path = Path(three_dir) if three_dir is not None else THREE_DIR
    missing = [rel for rel in THREE_ENTRIES.values() if not (path / rel).is_file()]
    if missing:
        raise ReportError(f"three.js is not installed ({path / missing[0]} is missing); run `make setup`, which runs "
                          "`npm ci --prefix web`, to install it from web/package.json")
    return path


def _resolve(specifier: str, importer: str, three: Path) -> str:
    """A module specifier seen in ``importer`` (a path in the three package) → the path it names."""
    if specifier in THREE_ENTRIES:
        rel = THREE_ENTRIES[specifier]
    elif specifier.startswith("three/addons/"):
        rel = "examples/jsm/" + specifier.removeprefix("three/addons/")
    elif specifier.startswith(("./", "../")):
        rel = posixpath.normpath(posixpath.join(posixpath.dirname(importer), specifier))
    else:
        raise ReportError(f"three.js module {importer} imports {specifier!r}, which the report cannot inline")
    if not (three / rel).is_file():
        raise ReportError(f"three.js module {importer} imports {specifier!r}, but {three / rel} is missing; "
                          "run `make setup` again")
    return rel


def _module_key(rel: str) -> str:
    for key, entry in THREE_ENTRIES.items():
        if entry == rel:
            return key
    return "three/" + rel


def three_modules(three_dir: str | Path | None = None) -> dict[str, str]:
    """Bare specifier → ES module text, for every module the viewer needs, imports rewritten to those specifiers."""
    three = find_three(three_dir)
    modules: dict[str, str] = {}
    queue = list(THREE_ENTRIES.values())
    while queue:
        rel = queue.pop()
        key = _module_key(rel)
        if key in modules:
            continue
        text = (three / rel).read_text(encoding="utf-8")

        def rewrite(m: re.Match, importer: str = rel) -> str:
            spec = m.group(2) or m.group(4)
            target = _resolve(spec, importer, three)
            queue.append(target)
            start = (m.start(2) if m.group(2) else m.start(4)) - m.start()
            return m.group(0)[:start] + _module_key(target) + m.group(0)[start + len(spec):]

        modules[key] = _IMPORT.sub(rewrite, text)
    return modules


def _script_text(text: str) -> str:
    """Text safe inside a <script> element (no early end tag, no comment-open), same meaning as JS."""
    return _SCRIPT_END.sub(r"<\\/\1", text).replace("<!--", "<\\!--")


def _json_script(obj: object) -> str:
    return json.dumps(obj, ensure_ascii=False, allow_nan=False, separators=(",", ":")).replace("<", "\\u003c")


# --------------------------------------------------------------------------- plots
def _png(fig) -> str:
    buf = io.BytesIO()
    fig.savefig(buf, format="png")
    return "data:image/png;base64," + base64.b64encode(buf.getvalue()).decode("ascii")


def _figure(width: float, height: float):
    from matplotlib.backends.backend_agg import FigureCanvasAgg
    from matplotlib.figure import Figure

    fig = Figure(figsize=(width, height), dpi=100, layout="constrained")
    FigureCanvasAgg(fig)
    return fig


def histograms_png(ev: Evaluation) -> str:
    """Visibility classes, and VR_i, R_i, O_i over the visible target elements, as a PNG data URI."""
    em = ev.metrics.elements
    vis = em.visible & em.is_target
    fig = _figure(11, 2.7)
    axes = fig.subplots(1, 4)
    cls = visibility_class(em)[em.is_target]
    counts = np.bincount(cls, minlength=3)[:3]
    axes[0].bar(["visible", "observed\nonly", "unseen"], counts, color=[VISIBLE, OBSERVED_ONLY, UNSEEN])
    axes[0].set_title(f"target elements (z = {int(em.is_target.sum())})", fontsize=9)
    panels = ((em.VR[vis], "VR_i (frames)", True), (em.R[vis], "R_i (m/px)", False), (em.O[vis], "O_i (°)", False))
    for ax, (values, label, integer) in zip(axes[1:], panels):
        values = np.asarray(values, np.float64)
        values = values[np.isfinite(values)]
        if len(values):
            bins = np.arange(values.min(), values.max() + 2) - 0.5 if integer and values.max() - values.min() < 40 else 20
            ax.hist(values, bins=bins, color="#4c72b0")
        else:
            ax.text(0.5, 0.5, "no visible element", ha="center", va="center", transform=ax.transAxes, fontsize=9)
        ax.set_title(f"{label}, {len(values)} visible", fontsize=9)
    for ax in axes:
        ax.tick_params(labelsize=8)
    axes[1].set_ylabel("elements", fontsize=8)
    return _png(fig)


def stability_png(ev: Evaluation, plan: Plan) -> str:
    """ν_f, the stable features of each frame, along the path, with Λ and the missions, as a PNG data URI."""
    fm = ev.metrics.frames
    n = len(fm.nu)
    fig = _figure(11, 2.8)
    ax = fig.subplots()
    colours = np.where(fm.stable[:, None], np.array(STABLE_COLOUR), np.array(UNSTABLE_COLOUR))
    ax.bar(np.arange(n), fm.nu, width=1.0, color=colours, linewidth=0)
    lam = ev.metrics.params.min_features
    ax.axhline(lam, color="#333333", linestyle="--", linewidth=1, label=f"Λ = {lam}")
    if len(plan.missions) > 1:
        for m in plan.missions[1:]:
            ax.axvline(m.start - 0.5, color="#888888", linestyle=":", linewidth=1)
        for m in plan.missions:
            ax.text((m.start + m.stop) / 2 - 0.5, 1.0, m.name, ha="center", va="bottom", fontsize=7,
                    transform=ax.get_xaxis_transform())
    ax.set_xlim(-0.5, n - 0.5)
    ax.set_xlabel("frame along the path", fontsize=8)
    ax.set_ylabel("ν_f (stable features)", fontsize=8)
    ax.tick_params(labelsize=8)
    ax.legend(fontsize=8, loc="upper right")
    return _png(fig)


# --------------------------------------------------------------------------- tables
def _fmt(x: float | None, spec: str, scale: float = 1.0) -> str:
    return "—" if x is None or not np.isfinite(x) else format(scale * x, spec)


def plan_cells(ev: Evaluation) -> list[tuple[str, str, str, str]]:
    """(attribute, heading, unit, formatted value) of each Table 2 column."""
    p = ev.metrics.plan
    return [(attr, head, unit, _fmt(getattr(p, attr), spec, scale)) for attr, head, unit, spec, scale in PLAN_COLUMNS]


def worst_elements(ev: Evaluation, scene: Scene, n: int = 10) -> dict[str, tuple[str, np.ndarray, int]]:
    """Title, element indices (at most ``n``) and total count of: unseen, lowest VR, worst SSD."""
    em = ev.metrics.elements
    targets = em.is_target
    unseen = np.flatnonzero(targets & ~em.visible)
    # observed-only first (closest to being seen, most pixels), then the unseen by class and name
    el = scene.elements
    unseen = unseen[np.lexsort((el.name[unseen].astype(str), el.ifc_class[unseen].astype(str),
                                -np.asarray(em.pixels_total[unseen], np.float64)))]
    vis = np.flatnonzero(targets & em.visible)
    lowest_vr = vis[np.lexsort((-np.nan_to_num(em.R[vis]), em.VR[vis]))]
    worst_ssd = vis[np.argsort(-np.nan_to_num(em.R[vis], nan=-np.inf), kind="stable")]
    return {
        "unseen": ("Target elements not seen by ≥ Ω px", unseen[:n], len(unseen)),
        "lowest-vr": ("Lowest redundant visibility VR_i", lowest_vr[:n], len(vis)),
        "worst-ssd": ("Coarsest surface sampling distance R_i", worst_ssd[:n], len(vis)),
    }


def _element_table(ev: Evaluation, scene: Scene, table_id: str, title: str, rows: np.ndarray, total: int) -> str:
    em, el = ev.metrics.elements, scene.elements
    names = ("visible", "observed only", "unseen", "occluder")
    cls = visibility_class(em)
    e = html.escape
    body = "".join(
        f"<tr><td><code>{e(str(el.global_id[i]))}</code></td><td>{e(str(el.name[i]))}</td><td>{e(str(el.ifc_class[i]))}</td>"
        f"<td>{e(str(el.storey[i]))}</td><td>{names[cls[i]]}</td><td class=num>{int(em.VR[i])}</td>"
        f"<td class=num>{_fmt(em.R[i], '.4f')}</td><td class=num>{_fmt(em.O[i], '.2f')}</td></tr>"
        for i in rows)
    shown = f"{len(rows)} of {total}" if total > len(rows) else f"{total}"
    if not len(rows):
        body = "<tr><td colspan=8 class=none>none</td></tr>"
    return (f"<section><h3>{e(title)} <small>({shown})</small></h3><table id=\"{table_id}\" class=elements>"
            "<thead><tr><th>GlobalId</th><th>name</th><th>IFC class</th><th>storey</th><th>visibility</th>"
            "<th>VR_i</th><th>R_i (m/px)</th><th>O_i (°)</th></tr></thead>"
            f"<tbody>{body}</tbody></table></section>")


# --------------------------------------------------------------------------- the viewer's data
def _hex(rgb) -> str:
    return "#" + "".join(f"{round(255 * float(c)):02x}" for c in rgb)


def _nullable(values: np.ndarray, cast: Callable = float) -> list:
    return [cast(v) if np.isfinite(v) else None for v in values]


def viewer_data(ev: Evaluation, scene: Scene, plan: Plan, colour_by: ColourBy,
                bounds: tuple[float, float] | None) -> dict:
    """What the page's script recolours from: per-element arrays, bounds, colours, camera positions."""
    em, el = ev.metrics.elements, scene.elements
    labels: dict[str, dict] = {}
    for metric in COLOUR_BY:
        label, unit, higher_better = METRIC_LABELS[metric]
        b = colour_bounds(em, metric, bounds if metric == colour_by else None)  # type: ignore[arg-type]
        labels[metric] = {"label": label, "unit": unit, "higher_better": higher_better,
                          "bounds": None if b is None else [float(b[0]), float(b[1])]}
    labels["visibility"]["classes"] = ["visible (≥ Ω px)", "observed only", "unseen", "occluder"]
    frame = ViewerFrame.of(scene)
    return {
        "colour_by": colour_by,
        "elements": {"global_id": el.global_id.tolist(), "name": el.name.tolist(), "ifc_class": el.ifc_class.tolist(),
                     "storey": el.storey.tolist(), "target": em.is_target.tolist()},
        "metrics": {"visibility": visibility_class(em).tolist(),
                    "vr": _nullable(element_values(em, "vr"), int),
                    "ssd": _nullable(element_values(em, "ssd")),
                    "orientation": _nullable(element_values(em, "orientation"))},
        "labels": labels,
        "colours": {"gradient": [_hex(c) for c in GRADIENT], "unseen": _hex(UNSEEN), "occluder": _hex(OCCLUDER),
                    "classes": [_hex(c) for c in (VISIBLE, OBSERVED_ONLY, UNSEEN, OCCLUDER)]},
        "cameras": np.round(frame.apply(plan.C_world), 4).tolist(),
        "missions": [[m.start, m.stop] for m in plan.missions] or [[0, len(plan)]],
    }


# --------------------------------------------------------------------------- the page
CSS = """
body{font:14px/1.45 system-ui,-apple-system,"Segoe UI",Roboto,sans-serif;color:#222;margin:0 auto;max-width:1180px;
padding:12px 18px}
h1{font-size:20px;margin:4px 0}h2{font-size:16px;margin:22px 0 6px}h3{font-size:14px;margin:14px 0 4px}
dl.meta{display:grid;grid-template-columns:max-content 1fr max-content 1fr;gap:1px 14px;margin:6px 0;font-size:13px}
dl.meta dt{color:#666}dl.meta dd{margin:0}
table{border-collapse:collapse;font-size:13px}th,td{padding:3px 8px;border-bottom:1px solid #ddd;text-align:left}
th{background:#f3f3f3}td.num,#plan-metrics td{text-align:right;font-variant-numeric:tabular-nums}
#plan-metrics td:first-child{text-align:left}small{color:#666;font-weight:normal}td.none{color:#888}
#viewer{position:relative;border:1px solid #ccc;margin-top:6px}
#viewer-canvas{height:540px;width:100%}#viewer-canvas canvas{display:block;width:100%;height:100%}
.viewer-error{display:flex;align-items:center;justify-content:center;color:#a00}
.controls{display:flex;flex-wrap:wrap;gap:8px 14px;align-items:center;padding:6px 8px;background:#f7f7f7;
border-bottom:1px solid #ddd;font-size:13px}
.controls input[type=number]{width:90px}#legend{display:flex;flex-wrap:wrap;gap:4px 10px;align-items:center}
.swatch{display:inline-flex;align-items:center;gap:4px}.swatch i{display:inline-block;width:14px;height:14px;
border:1px solid #999}.gradient{display:inline-block;width:140px;height:12px;border:1px solid #999}
#element-info{position:absolute;right:8px;bottom:8px;background:rgba(255,255,255,.9);border:1px solid #ccc;
margin:0;padding:4px 8px;display:grid;grid-template-columns:max-content auto;gap:0 8px;font-size:12px;max-width:420px}
#element-info:empty{display:none}#element-info dd{margin:0;overflow-wrap:anywhere}
img.plot{max-width:100%}footer{color:#888;font-size:12px;margin-top:24px}
"""


def html_report(ev: Evaluation, scene: Scene, plan: Plan, *, model_label: str = "", plan_label: str = "",
                colour_by: ColourBy = "visibility", bounds: tuple[float, float] | None = None,
                three_dir: str | Path | None = None, worst: int = 10) -> str:
    """The report page as one string; every script, picture and the model are inside it."""
    colour_by = check_colour_by(colour_by)
    colour_bounds(ev.metrics.elements, colour_by, bounds)  # refuse bad bounds before any work
    modules = three_modules(three_dir) | {"sightplan/colours": COLOURS_JS.read_text(encoding="utf-8")}
    glb = scene_glb(scene, ev.metrics, colour_by, bounds)
    e = html.escape
    p, s = ev.metrics.plan, ev.settings
    model_name = model_label or scene.source or "model"
    plan_name = plan_label or "plan"
    mp = s.metric
    meta = [
        ("model", f"{model_name} — {p.z} target elements of {scene.n_elements}, {len(scene.faces):,} triangles"),
        ("plan", f"{plan_name} — {len(plan)} frames, {len(plan.missions)} mission(s), "
                 f"camera(s) {', '.join(sorted(plan.cameras))}"),
        ("capture date", "undated (every element)" if scene.date is None else str(scene.date)[:10]),
        ("written", dt.datetime.now().astimezone().isoformat(timespec="seconds")),
        ("engine", f"{ev.engine}, scale s = {s.scale:g}, D_max = {s.d_max:g} m"),
        ("settings", f"Ω = {mp.omega:g} px, k = {mp.k}, Y = {mp.min_track}, Λ = {mp.min_features}"),
        ("features", f"{ev.n_features:,} ({s.feature_density:g} per m², seed {s.feature_seed})"),
        ("time", f"{ev.timings.get('total_s', 0.0):.1f} s, {ev.cache_hits} frames from the cache"),
    ]
    meta_html = "".join(f"<dt>{e(k)}</dt><dd>{e(v)}</dd>" for k, v in meta)
    cells = plan_cells(ev)
    table = ("<table id=\"plan-metrics\"><thead><tr><th>plan</th>"
             + "".join(f"<th title=\"{e(explain(GLOSSARY_KEYS[attr], mp))}\">{e(head)} <small>({e(unit)})</small>"
                       "</th>" for attr, head, unit, _ in cells)
             + f"</tr></thead><tbody><tr><td>{e(plan_name)}</td>"
             + "".join(f"<td data-metric=\"{attr}\">{value}</td>" for attr, _, _, value in cells)
             + "</tr></tbody></table>")
    definitions = "".join(f"<dt>{e(d.label)} <small>({e(d.unit)})</small></dt><dd>{e(explain(d.key, mp))}</dd>"
                          for d in GLOSSARY)
    summary = (f"{p.n_visible} of {p.z} target elements seen by ≥ Ω px, {p.n_observed} observed; "
               f"{_fmt(p.stable_share, '.1f', 100.0)} % of the {p.n_frames} frames stable (ν_f ≥ Λ).")
    options = "".join(f"<option value=\"{m}\"{' selected' if m == colour_by else ''}>{e(METRIC_LABELS[m][0])}</option>"
                      for m in COLOUR_BY)
    worst_html = "".join(_element_table(ev, scene, f"worst-{key}", title, rows, total)
                         for key, (title, rows, total) in worst_elements(ev, scene, worst).items())
    module_scripts = "\n".join(f"<script type=\"text/x-sightplan-module\" data-specifier=\"{e(key)}\">"
                               f"{_script_text(text)}</script>" for key, text in modules.items())
    viewer_js = _script_text((Path(__file__).with_name("viewer.js")).read_text(encoding="utf-8"))
    title = f"sightplan — {Path(model_name).name} × {Path(plan_name).name}"
    return f"""<!DOCTYPE html>
<html lang="en">
<head>
<meta charset="utf-8">
<meta name="viewport" content="width=device-width, initial-scale=1">
<meta name="generator" content="sightplan {e(__version__)}">
<title>{e(title)}</title>
<style>{CSS}</style>
</head>
<body>
<header>
<h1>{e(title)}</h1>
<dl class="meta">{meta_html}</dl>
</header>
<h2>Plan metrics</h2>
{table}
<details id="definitions"><summary>What the metrics mean</summary><dl>{definitions}</dl></details>
<p>{e(summary)}</p>
<h2>The model coloured by a metric <small>(drag to turn, wheel to zoom, right-drag to pan, click an element)</small></h2>
<div id="viewer" data-state="loading">
<div class="controls">
<label>colour by <select id="metric">{options}</select></label>
<label>bounds <input id="bound-lo" type="number" step="any"> – <input id="bound-hi" type="number" step="any"></label>
<button id="bound-reset" type="button">reset</button>
<label title="elements seen by ≥ Ω px turn faint, so that unseen ones inside show"><input id="xray" type="checkbox"> x-ray</label>
<span id="legend"></span>
</div>
<div id="viewer-canvas"></div>
<dl id="element-info"></dl>
</div>
<h2>Elements</h2>
<img class="plot" alt="histograms of the per-element metrics" src="{histograms_png(ev)}">
<h2>Stability along the path</h2>
<img class="plot" alt="stable features per frame along the path" src="{stability_png(ev, plan)}">
<h2>Worst elements</h2>
{worst_html}
<footer>sightplan {e(__version__)} — metrics of Ibrahim, Golparvar-Fard and El-Rayes (CACAIE 2021).
3D view by three.js (MIT licence), inlined.</footer>
<script type="application/json" id="sightplan-data">{_json_script(viewer_data(ev, scene, plan, colour_by, bounds))}</script>
<script type="application/octet-stream" id="sightplan-glb">{base64.b64encode(glb).decode("ascii")}</script>
{module_scripts}
<script>
(() => {{
  // The inlined modules become blob URLs under their bare specifiers, before any module runs.
  const imports = {{}};
  for (const s of document.querySelectorAll('script[type="text/x-sightplan-module"]')) {{
    imports[s.dataset.specifier] = URL.createObjectURL(new Blob([s.textContent], {{ type: 'text/javascript' }}));
  }}
  const map = document.createElement('script');
  map.type = 'importmap';
  map.textContent = JSON.stringify({{ imports }});
  document.currentScript.after(map);
}})();
</script>
<script type="module">
{viewer_js}
</script>
</body>
</html>
"""


def write_html(ev: Evaluation, scene: Scene, plan: Plan, path: str | Path, *, model_label: str = "",
               plan_label: str = "", colour_by: ColourBy = "visibility", bounds: tuple[float, float] | None = None,
               three_dir: str | Path | None = None) -> Path:
    """Write :func:`html_report` to ``path``."""
    text = html_report(ev, scene, plan, model_label=model_label, plan_label=plan_label, colour_by=colour_by,
                       bounds=bounds, three_dir=three_dir)
    return write_bytes(path, text)

