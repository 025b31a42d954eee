"""``sightplan info MODEL``."""

from __future__ import annotations

import json
from typing import Annotated

import typer
from rich.table import Table

from .errors import friendly_errors
from .main import app, console


@app.command()
@friendly_errors
def info(
    model: Annotated[str, typer.Argument(help="IFC or mesh file; 'sample' for the bundled Duplex model")],
    as_json: Annotated[bool, typer.Option("--json", help="Print the summary as JSON")] = False,
    cache: Annotated[bool, typer.Option(help="Reuse the model cache")] = True,
) -> None:
    """Summarise a model: elements by class, discipline and storey; bounds; triangles; the load report."""
    from ..model.load import load_model
    from ..model.summary import summarize

    with console.status("loading the model…"):
        scene, report = load_model(model, cache=cache)
    s = summarize(scene, report)
    if as_json:
        typer.echo(json.dumps(s, indent=2, default=str))
        return
    console.print_json(json.dumps({k: v for k, v in s.items() if not isinstance(v, dict | list)}, default=str))
    for key, value in s.items():
        if isinstance(value, dict) and value and all(isinstance(v, int | float) for v in value.values()):
            t = Table(key.replace("_", " "), "count", title_justify="left")
            for name, count in sorted(value.items(), key=lambda kv: -kv[1]):
                t.add_row(str(name), str(count))
            console.print(t)
        elif isinstance(value, list) and value:
            t = Table(*(list(value[0]) if isinstance(value[0], dict) else ["value"]), title=key.replace("_", " "),
                      title_justify="left")
            for row in value[:50]:
                t.add_row(*([str(v) for v in row.values()] if isinstance(row, dict) else [str(row)]))
            if len(value) > 50:
                t.add_row(f"… {len(value) - 50} more", *[""] * (len(t.columns) - 1))
            console.print(t)
