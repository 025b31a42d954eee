"""Loading a model from the CLI, with a progress bar while IfcOpenShell tessellates."""

from __future__ import annotations

from collections.abc import Callable, Iterator, Mapping
from contextlib import contextmanager

from rich.console import Console
from rich.progress import BarColumn, MofNCompleteColumn, Progress, TaskProgressColumn, TextColumn, TimeElapsedColumn


def _eta(seconds: float | None) -> str:
    if seconds is None:
        return ""
    seconds = int(round(seconds))
    return f"ETA {seconds // 3600}:{seconds // 60 % 60:02d}:{seconds % 60:02d}"


@contextmanager
def stage_bars(console: Console, names: Mapping[str, str] | None = None
               ) -> Iterator[Callable[[str, int, int], None]]:
    """A progress(stage, done, total) callback that shows one bar per stage (titled ``names[stage]`` or the stage),
    cleared when the block ends."""
    with Progress(TextColumn("[bold]{task.description}"), BarColumn(), MofNCompleteColumn(), TimeElapsedColumn(),
                  console=console, transient=True) as bar:
        tasks: dict[str, int] = {}

        def progress(stage: str, done: int, total: int) -> None:
            if stage not in tasks:
                tasks[stage] = bar.add_task((names or {}).get(stage, stage), total=max(total, 1))
            bar.update(tasks[stage], completed=done, total=max(total, 1))

        yield progress


def load_with_progress(console: Console, model: str, cache: bool, mesh_elements: str = "objects",
                       mesh_scale: float = 1.0, patch_area: float | None = None):
    """(scene, report) of ``model``; a cache hit shows no bar. ``mesh_*`` apply to mesh files only; ``patch_area``
    (m²) to meshes grouped in patches and to point clouds.

    An IFC file shows its phases as they come: reading the file (from the first second), then products
    tessellated / total with an ETA, then assembling the scene."""
    from ..model.load import MESH_EXTENSIONS, load_model, resolve_model_path
    from ..model.pointcloud import is_point_cloud

    name = resolve_model_path(model).name
    with Progress(TextColumn("[bold]{task.description}"), BarColumn(), TaskProgressColumn(),
                  TextColumn("{task.fields[count]}"), TimeElapsedColumn(), TextColumn("{task.fields[eta]}"),
                  console=console, transient=True) as bar:
        task = bar.add_task(f"loading {name}", total=1.0, count="", eta="")
        is_ifc = name.lower().endswith((".ifc", ".ifczip"))

        def status(s) -> None:  # a LoadProgress
            if s.phase == "tessellating":
                bar.update(task, description=f"tessellating {name}", total=max(s.total, 1), completed=s.done,
                           count=f"{s.done:,}/{s.total:,} products", eta=_eta(s.eta_s))
            elif s.phase in ("reading", "assembling"):  # no count: a pulsing bar
                bar.update(task, description=f"{s.phase} {s.message}", total=None, count="", eta="")

        extra: dict = {"status": status} if is_ifc else {}
        if name.lower().endswith(tuple(MESH_EXTENSIONS)):
            extra = {"elements": mesh_elements, "scale": mesh_scale}
            if patch_area is not None and mesh_elements == "patches":
                extra["patch_area_m2"] = patch_area
        cloud = name.lower().endswith((".las", ".laz")) or (name.lower().endswith(".ply")
                                                             and is_point_cloud(resolve_model_path(model)))
        if cloud:
            extra = {"scale": mesh_scale} | ({"patch_area_m2": patch_area} if patch_area is not None else {})
        return load_model(model, cache=cache, **extra)


def georef_kwargs(scene) -> dict:
    """A flight-app mission (latitude/longitude) is placed with the model's georeference, taking off from its file's
    reference, else from the site's ground (:func:`~sightplan.plan.load.scene_placement`)."""
    from ..plan.load import scene_placement

    return scene_placement(scene)


def print_warnings(console: Console, warnings) -> None:
    """Each warning on a line of its own, in yellow."""
    for warning in warnings:
        console.print(f"[yellow]warning:[/] {warning}", highlight=False)


def warn_if_far(console: Console, scene, plan, limit_m: float = 5000.0) -> None:
    """A warning when the plan's frames lie kilometres from the model: another place, frame or unit."""
    import numpy as np

    lo, hi = scene.bounds()
    gap = np.linalg.norm(np.maximum(lo - plan.C_world, 0) + np.maximum(plan.C_world - hi, 0), axis=1)
    if len(gap) and float(np.median(gap)) > limit_m:
        console.print(f"[yellow]warning:[/] the plan's frames lie a median {np.median(gap) / 1000:.1f} km from the model: "
                      "is the plan in the model's frame (georeference, --transform, units)?", highlight=False)
