"""``sightplan study TABLE.csv``: correlate plan metrics with reconstruction quality over several data sets."""

from __future__ import annotations

from pathlib import Path
from typing import Annotated

import typer
from rich.table import Table

from .base import app, console
from .errors import friendly_errors

_STYLE = {"strong": "bold green", "moderate": "yellow", "weak": "dim", "n/a": "dim"}


@app.command("study")
@friendly_errors
def study_command(
    table: Annotated[Path, typer.Argument(help="CSV, one row per data set, with plan-metric columns (VC, VC_bar, VR, R, "
                                               "O, T) and quality columns (A, Ce, Cv, Ct); the paper's Table 2 names "
                                               "(VC_pct, R_m, Ce_pct, …) work too")],
    out: Annotated[Path, typer.Option(help="Folder for correlations.csv, heatmap.png, the scatter plots and study.html")]
        = Path("sightplan-study"),
    pair: Annotated[list[str] | None, typer.Option(help="Also plot this METRIC:QUALITY pair, e.g. VR:Ce (repeatable)")]
        = None,
    collect: Annotated[list[Path] | None, typer.Option(
        help="First write TABLE from these folders, each with an evaluate report.json and a validate validation.json "
             "(repeat, one per data set)")] = None,
) -> None:
    """Pearson r and p of every plan metric against every quality measure, with a heat map and scatter plots."""
    from ..study import DISPLAY, MODERATE, STRONG, parse_pair, read_study, write_study

    if collect:
        from ..study import collect_table

        console.print(f"wrote {collect_table(collect, table)} from {len(collect)} folders")
    study = read_study(table)
    extra = [parse_pair(p, study) for p in pair or []]
    t = Table("", *(DISPLAY[q] for q in study.qualities), title=f"Pearson r — {table.name}, {study.n_rows} data sets",
              title_justify="left")
    for m in study.metrics:
        cells = []
        for q in study.qualities:
            p = study.pair(m, q)
            text = "—" if p.r is None else f"{p.r:+.2f}"
            if p.n != study.n_rows:
                text += f" ({p.n})"
            cells.append(f"[{_STYLE[p.strength]}]{text}[/]")
        t.add_row(DISPLAY[m], *cells)
    console.print(t)
    console.print(f"strong |r| ≥ {STRONG}, moderate {MODERATE} ≤ |r| < {STRONG}; (n): rows with both values, "
                  "where some were blank", highlight=False)
    strong = study.strong()
    if strong:
        console.print("strong pairs:")
        for p in strong:
            console.print(f"  {DISPLAY[p.metric]} – {DISPLAY[p.quality]}: r = {p.r:+.2f}, p = {p.p:.3g}, n = {p.n}",
                          highlight=False)
    else:
        console.print("no strong pairs (|r| ≥ 0.5)")
    paths = write_study(study, out, extra)
    console.print("wrote " + ", ".join(str(p) for p in paths.values()), highlight=False)
