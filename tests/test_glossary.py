"""Every metric is explained, from one source (:mod:`sightplan.metrics.glossary`): the documentation's table, the command
line's table, the web page's labels (every metric column of its tables) and the HTML report."""

from __future__ import annotations

import re
from pathlib import Path

from sightplan.metrics.glossary import BY_KEY, GLOSSARY, explain, glossary
from sightplan.metrics.params import MetricParams

ROOT = Path(__file__).resolve().parents[1]
STATIC = ROOT / "src" / "sightplan" / "web" / "static"


def test_the_documentation_states_every_definition_as_the_library_does():
    readme = (ROOT / "docs" / "metrics.md").read_text(encoding="utf-8")
    for d in GLOSSARY:
        assert f"| {d.label} | {d.unit} | {explain(d.key)} |" in readme, d.key


def test_definitions_carry_the_thresholds_in_force():
    p = MetricParams(omega=400, k=5, min_track=7, min_features=80)
    assert "Ω = 400 px" in explain("VC_pct", p) and "k = 5" in explain("R_m_per_px", p)
    assert "Y = 7" in explain("T", p) and "Λ = 80" in explain("stable_frames_pct", p)
    assert glossary(p)["VR"] == {"label": "VR", "unit": "frames", "text": explain("VR", p)}


def test_every_metric_column_of_the_page_has_a_definition():
    source = (STATIC / "evaluations.js").read_text(encoding="utf-8")
    block = source[source.index("const METRIC_COLUMNS"):source.index("];", source.index("const METRIC_COLUMNS"))]
    keys = re.findall(r"\['(\w+)',", block)
    assert keys == ["VC_pct", "VC_bar_pct", "VR", "R_m_per_px", "O_deg", "T", "stable_frames_pct"]
    assert set(keys) <= set(BY_KEY)
    # the element card's metrics too, under the names the page gives them
    assert {"VR_i", "R_i", "O_i"} <= set(BY_KEY)


def test_the_html_report_and_the_command_line_explain_every_plan_metric(tmp_path):
    from test_cli import run_cli

    res = run_cli("evaluate", "sample", "--scale", "0.05", "--ring-frames", "8", "--no-picture",
                  "--html", "r.html", "--out", "out", cwd=tmp_path)
    assert res.returncode == 0, res.stdout + res.stderr
    text = " ".join(res.stdout.split())  # the console wraps the table
    for key in ("VR", "R_m_per_px", "O_deg", "T", "stable_frames_pct"):
        assert explain(key).split(":")[0] in text, key
    html = (tmp_path / "r.html").read_text(encoding="utf-8")
    assert 'id="definitions"' in html
    for d in GLOSSARY:
        assert explain(d.key).replace("'", "&#x27;") in html, d.key
