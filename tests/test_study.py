"""Correlation study (METRICS.md §8): the paper's published r values, hand-computed statistics, the CLI."""

from __future__ import annotations

import csv
import math
import os
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest
from typer.testing import CliRunner

import sightplan.cli.study_cmd  # noqa: F401  (registers `study`)
from sightplan.cli.main import app
from sightplan.study import (
    METRICS,
    QUALITIES,
    Study,
    StudyError,
    correlate,
    fit_line,
    parse_pair,
    pearson,
    read_study,
    strength,
)
from test_cli import error_text

TABLE2 = Path(__file__).resolve().parents[2] / "shared" / "spec" / "table2.csv"


@pytest.fixture(scope="module")
def table2() -> Path:
    if not TABLE2.exists():
        pytest.skip(f"{TABLE2} is not present")
    return TABLE2


def run_study(*args: str, cwd: Path) -> subprocess.CompletedProcess:
    """``sightplan study …`` in a fresh interpreter (importing the command module registers it)."""
    code = "import sightplan.cli.study_cmd; from sightplan.cli.main import app; app(prog_name='sightplan')"
    return subprocess.run([sys.executable, "-c", code, "study", *args], capture_output=True, text=True, cwd=cwd,
                          env={**os.environ, "COLUMNS": "120"}, timeout=300)


def assert_clean_error(res: subprocess.CompletedProcess, *words: str) -> None:
    assert res.returncode != 0, res.stdout
    assert "Traceback" not in res.stderr + res.stdout
    err = " ".join(error_text(res.stderr).split())  # the console may wrap the one message at the terminal width
    assert err.startswith("error:"), res.stderr
    for w in words:
        assert w.lower() in err.lower(), err


def write_csv(path: Path, rows: list[list[object]]) -> Path:
    with open(path, "w", newline="", encoding="utf-8") as fh:
        csv.writer(fh).writerows(rows)
    return path


# --- the paper's Table 2 ----------------------------------------------------------------------------------------


def test_table2_gives_the_papers_r_values(table2):
    s = read_study(table2)
    assert s.metrics == METRICS and s.qualities == QUALITIES and s.n_rows == 13
    assert len(s.pairs) == 24 and all(p.n == 13 for p in s.pairs)
    # the paper's published values (§4.3)
    assert round(s.r("VR", "Ce"), 2) == 0.65
    assert round(s.r("VC", "Ct"), 2) == 0.83
    assert round(s.r("R", "A"), 2) == 0.36
    assert round(s.r("O", "Ct"), 2) == -0.68
    assert s.pair("VR", "Ce").strength == "strong" and s.pair("R", "A").strength == "moderate"
    assert s.pair("O", "Ct").strength == "strong" and s.pair("VC", "A").strength == "weak"
    assert 0 < s.pair("VR", "Ce").p < 0.05
    assert s.strong()[0].metric == "VC" and s.strong()[0].quality == "Ct"
    assert s.labels[:2] == ["P1", "P2"]


def test_units_do_not_change_r(table2):
    s = read_study(table2)
    # sightplan's own names; percentages as fractions, every other column ×1000 (e.g. metres → millimetres)
    frac = {k: list(v / 100 if k in ("VC", "VC_bar", "Ce", "Cv", "Ct") else v * 1000) for k, v in s.columns.items()}
    t = correlate(frac)
    np.testing.assert_allclose(t.r_matrix(), s.r_matrix(), rtol=1e-12)


def test_tidy_table_csv(table2, tmp_path):
    s = read_study(table2)
    path = s.to_csv(tmp_path / "c.csv")
    rows = list(csv.DictReader(open(path, encoding="utf-8")))
    assert list(rows[0]) == ["metric", "quality", "n", "r", "p", "strength"]
    assert len(rows) == 24
    row = next(r for r in rows if r["metric"] == "VR" and r["quality"] == "Ce")
    assert row["n"] == "13" and row["strength"] == "strong" and abs(float(row["r"]) - 0.647) < 1e-3


# --- statistics by hand -------------------------------------------------------------------------------------------


def test_pearson_by_hand():
    # x = [1,2,3,4], y = [2,4,5,9]: x̄ = 2.5, ȳ = 5; dx = (−1.5, −0.5, 0.5, 1.5), dy = (−3, −1, 0, 4)
    # Sxy = 4.5 + 0.5 + 0 + 6 = 11, Sxx = 5, Syy = 9 + 1 + 0 + 16 = 26  →  r = 11 / √130 = 0.964764
    r, p = pearson([1, 2, 3, 4], [2, 4, 5, 9])
    assert r == pytest.approx(11 / math.sqrt(130), abs=1e-12)
    # t = r √(n−2) / √(1−r²) with 2 dof; two-sided p = 1 − t/√(t²+2) for Student's t with 2 dof
    t = r * math.sqrt(2) / math.sqrt(1 - r * r)
    assert p == pytest.approx(1 - t / math.sqrt(t * t + 2), rel=1e-9)


def test_pearson_undefined():
    assert pearson([1, 2], [3, 4]) == (None, None)
    assert pearson([1, 1, 1], [1, 2, 3]) == (None, None)


@pytest.mark.parametrize(("r", "label"), [(0.5, "strong"), (-0.5, "strong"), (0.83, "strong"), (0.4999, "moderate"),
                                          (-0.25, "moderate"), (0.2499, "weak"), (0.0, "weak"), (None, "n/a"),
                                          (float("nan"), "n/a")])
def test_strength_classes(r, label):
    assert strength(r) == label


def test_band_has_zero_width_for_points_on_a_line():
    x = np.array([0.0, 1.0, 2.5, 4.0, 7.0])
    fit = fit_line(x, 3.0 - 2.0 * x)
    assert fit.slope == pytest.approx(-2.0) and fit.intercept == pytest.approx(3.0)
    yhat, lo, hi = fit.band(np.linspace(-5, 10, 31))
    np.testing.assert_allclose(hi - lo, 0.0, atol=1e-12)
    np.testing.assert_allclose(yhat, 3.0 - 2.0 * np.linspace(-5, 10, 31))


def test_band_half_width_at_the_mean():
    # x = 1..5, y = (1, 3, 2, 5, 4): x̄ = ȳ = 3, Sxy = 8, Sxx = 10 → slope 0.8, intercept 0.6;
    # residuals (−0.4, 0.8, −1.0, 1.2, −0.6), SSE = 3.6, s = √(3.6/3) = √1.2; t(0.975, 3 dof) = 3.182446 (tables)
    # at x̄ the band is ŷ ± t·s/√n = 3 ± 3.182446·√1.2/√5 = 3 ± 1.559074
    fit = fit_line([1, 2, 3, 4, 5], [1, 3, 2, 5, 4])
    assert (fit.slope, fit.intercept) == pytest.approx((0.8, 0.6))
    assert fit.s == pytest.approx(math.sqrt(1.2))
    yhat, lo, hi = fit.band(3.0)
    assert float(yhat) == pytest.approx(3.0)
    assert float(hi - yhat) == pytest.approx(3.182446 * math.sqrt(1.2) / math.sqrt(5), abs=1e-5)
    assert float(hi - yhat) == pytest.approx(1.559074, abs=1e-5)
    # narrowest at x̄, wider away from it, symmetric about it
    halves = fit.half_width(np.array([1.0, 2.0, 3.0, 4.0, 5.0]))
    assert halves[2] == halves.min() and halves[0] == pytest.approx(halves[4]) and halves[0] > halves[1]
    assert fit.half_width(3.0, level=0.99) > fit.half_width(3.0)


def test_fit_line_needs_three_points():
    with pytest.raises(StudyError):
        fit_line([1, 2], [1, 2])


# --- reading tables -----------------------------------------------------------------------------------------------


def test_aliases_and_blanks(tmp_path):
    path = write_csv(tmp_path / "mine.csv", [
        ["Name", "vc", "VC_BAR_PCT", "r_m", "Ct", "ce_pct", "notes"],
        ["a", 0.1, 20, 0.01, 0.2, "", "x"],
        ["b", 0.4, 45, 0.02, 0.5, 10, "y"],
        ["c", 0.5, 50, 0.015, 0.45, "NA", ""],
        ["d", 0.9, 95, 0.03, 0.8, 40, ""],
        ["e", 0.7, "", 0.02, 0.75, 30, ""],
    ])
    s = read_study(path)
    assert s.metrics == ("VC", "VC_bar", "R") and s.qualities == ("Ce", "Ct")
    assert s.labels == ["a", "b", "c", "d", "e"]
    assert s.pair("VC", "Ct").n == 5 and s.pair("VC_bar", "Ct").n == 4 and s.pair("VC", "Ce").n == 3
    assert s.pair("VC_bar", "Ce").n == 2 and s.r("VC_bar", "Ce") is None and s.pair("VC_bar", "Ce").strength == "n/a"
    labels, x, y = s.xy("VC", "Ce")
    assert labels == ["b", "d", "e"] and list(x) == [0.4, 0.9, 0.7] and list(y) == [10, 40, 30]
    assert s.r("VC", "Ct") == pytest.approx(pearson([0.1, 0.4, 0.5, 0.9, 0.7], [0.2, 0.5, 0.45, 0.8, 0.75])[0])
    assert "VC_BAR_PCT" in s.label("VC_bar")


def test_semicolon_table(tmp_path):
    path = tmp_path / "semi.csv"
    path.write_text("dataset;VR;Ce\nA;1;2\nB;2;4\nC;3;5\nD;4;9\n", encoding="utf-8")
    assert read_study(path).r("VR", "Ce") == pytest.approx(11 / math.sqrt(130))


def test_two_columns_for_one_metric():
    with pytest.raises(StudyError, match="both give"):
        correlate({"VC": [1, 2, 3], "VC_pct": [1, 2, 3], "Ct": [1, 2, 4]})


def test_parse_pair(table2):
    s = read_study(table2)
    assert parse_pair("VR:Ce", s) == ("VR", "Ce")
    assert parse_pair("ce_pct:vr", s) == ("VR", "Ce")
    assert parse_pair("VCbar_pct:Ct", s) == ("VC_bar", "Ct")
    for bad in ("VR", "VR:T", "Ce:Ct", "VR:nope"):
        with pytest.raises(StudyError):
            parse_pair(bad, s)
    assert isinstance(Study.from_csv(table2), Study)


# --- command line -------------------------------------------------------------------------------------------------


def test_cli_writes_everything(table2, tmp_path):
    out = tmp_path / "study"
    res = CliRunner().invoke(app, ["study", str(table2), "--out", str(out), "--pair", "R:A"], env={"COLUMNS": "120"})
    assert res.exit_code == 0, res.output
    assert "strong pairs" in res.output and "+0.83" in res.output and "-0.68" in res.output
    assert "VR – Ce: r = +0.65" in res.output
    names = {p.name for p in out.iterdir()}
    assert {"correlations.csv", "heatmap.png", "study.html", "scatter_VR_Ce.png", "scatter_VC_Ct.png",
            "scatter_O_Ct.png", "scatter_R_A.png"} <= names
    assert len([n for n in names if n.startswith("scatter_")]) == 8  # 7 strong pairs and R:A
    for png in out.glob("*.png"):
        assert png.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    page = (out / "study.html").read_text(encoding="utf-8")
    assert page.count("data:image/png;base64,") == 9 and "<img" in page and "src='scatter" not in page
    assert "class='strong'" in page and "class='moderate'" in page and "+0.65" in page


def test_cli_bad_pair(table2, tmp_path):
    res = CliRunner().invoke(app, ["study", str(table2), "--out", str(tmp_path / "o"), "--pair", "VR:VC"])
    assert res.exit_code == 2 and "--pair" in res.stderr and "Traceback" not in res.output


def test_cli_subprocess_end_to_end(table2, tmp_path):
    res = run_study(str(table2), cwd=tmp_path)
    assert res.returncode == 0, res.stderr
    assert "strong pairs" in res.stdout
    rows = list(csv.DictReader(open(tmp_path / "sightplan-study" / "correlations.csv", encoding="utf-8")))
    assert len(rows) == 24


def test_missing_file(tmp_path):
    assert_clean_error(run_study("nope.csv", cwd=tmp_path), "no such file", "nope.csv")


def test_no_metric_or_quality_columns(tmp_path):
    path = write_csv(tmp_path / "other.csv", [["x", "y"], [1, 2], [2, 3], [3, 5]])
    assert_clean_error(run_study(str(path), cwd=tmp_path), "other.csv", "VC_bar", "Ce_pct", "found: x, y")
    only_metrics = write_csv(tmp_path / "m.csv", [["VC", "VR"], [1, 2], [2, 3], [3, 5]])
    assert_clean_error(run_study(str(only_metrics), cwd=tmp_path), "no quality column")


def test_too_few_rows(tmp_path):
    path = write_csv(tmp_path / "two.csv", [["dataset", "VR", "Ce"], ["a", 1, 2], ["b", 2, 3]])
    assert_clean_error(run_study(str(path), cwd=tmp_path), "2 data sets", "at least 3")


def test_non_numeric_cell(tmp_path):
    path = write_csv(tmp_path / "bad.csv", [["dataset", "VR", "Ce_pct"], ["a", 1, 2], ["b", 2, "high"], ["c", 3, 4]])
    assert_clean_error(run_study(str(path), cwd=tmp_path), "line 3", "(b)", "Ce_pct", "'high'")


def test_empty_file(tmp_path):
    path = tmp_path / "empty.csv"
    path.write_text("", encoding="utf-8")
    assert_clean_error(run_study(str(path), cwd=tmp_path), "empty")


def test_collect_builds_the_table_from_evaluate_and_validate_outputs(tmp_path):
    import json

    from sightplan.study import StudyError, collect_table, read_study

    values = [(30.0, 50.0, 10.0, 0.01, 20.0, 400.0, 0.05, 0.2, 0.9, 0.4),
              (40.0, 60.0, 14.0, 0.02, 25.0, 500.0, 0.06, 0.3, 0.8, 0.5),
              (50.0, 80.0, 20.0, 0.015, 30.0, 450.0, 0.09, 0.5, 0.95, 0.7)]
    folders = []
    for k, v in enumerate(values):
        d = tmp_path / f"site{k}"
        d.mkdir()
        (d / "report.json").write_text(json.dumps({"metrics": dict(zip(
            ("VC_pct", "VC_bar_pct", "VR", "R_m_per_px", "O_deg", "T"), v[:6]))}))
        (d / "validation.json").write_text(json.dumps({"metrics": dict(zip(("A_m", "Ce", "Cv", "Ct"), v[6:]))}))
        folders.append(d)
    study = read_study(collect_table(folders, tmp_path / "table.csv"))
    assert study.n_rows == 3 and set(study.metrics) == {"VC", "VC_bar", "VR", "R", "O", "T"}
    # VR = 10, 14, 20 against Ce = 0.2, 0.3, 0.5: r = 0.99718 (by hand: deviations −4.67, −0.67, 5.33 and
    # −0.133, −0.033, 0.167; Σxy = 1.5333, Σx² = 50.667, Σy² = 0.046667)
    assert study.r("VR", "Ce") == pytest.approx(1.5333333 / math.sqrt(50.666667 * 0.0466667), abs=1e-5)
    (folders[1] / "validation.json").unlink()
    with pytest.raises(StudyError, match="sightplan validate"):
        collect_table(folders, tmp_path / "t2.csv")
