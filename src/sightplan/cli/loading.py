"""Loading a model from the CLI, with a progress bar while IfcOpenShell tessellates."""

from __future__ import annotations

from rich.console import Console
from rich.progress import BarColumn, Progress, TaskProgressColumn, TextColumn, TimeElapsedColumn


def load_with_progress(console: Console, model: str, cache: bool):
    """(scene, report) of ``model``; a cache hit shows no bar."""
    from ..model.load import load_model, resolve_model_path

    name = resolve_model_path(model).name
    with Progress(TextColumn(f"[bold]loading {name}"), BarColumn(), TaskProgressColumn(), TimeElapsedColumn(),
                  console=console, transient=True) as bar:
        task = bar.add_task("tessellating", total=1.0)
        is_ifc = name.lower().endswith((".ifc", ".ifczip"))
        extra = {"progress": lambda share: bar.update(task, completed=share)} if is_ifc else {}
        return load_model(model, cache=cache, **extra)
