"""Loading a model from the CLI, with its stages named as they come (:mod:`.stages`)."""

from __future__ import annotations

from collections.abc import Callable, Iterator, Mapping
from contextlib import contextmanager

from rich.console import Console

from .stages import StageDisplay

LOAD_STAGES = {"reading": "reading", "tessellating": "tessellating products", "assembling": "assembling the scene",
               "ties": "finding tie pairs", "loading": "loading"}


def _eta(seconds: float | None) -> str:
    if seconds is None:
        return ""
    seconds = int(round(seconds))
    return f"ETA {seconds // 3600}:{seconds // 60 % 60:02d}:{seconds % 60:02d}"


@contextmanager
def stage_bars(console: Console, names: Mapping[str, str] | None = None
               ) -> Iterator[Callable[[str, int, int], None]]:
    """A progress(stage, done, total) callback that shows each stage (titled ``names[stage]`` or the stage): a bar
    each on a terminal, cleared when the block ends; plain lines elsewhere."""
    with StageDisplay(console, names) as display:
        yield display


def load_with_progress(console: Console, model: str, cache: bool, mesh_elements: str = "objects",
                       mesh_scale: float = 1.0, patch_area: float | None = None):
    """(scene, report) of ``model``; a cache hit shows nothing. ``mesh_*`` apply to mesh files only; ``patch_area``
    (m²) to meshes grouped in patches and to point clouds.

    The phases show as they come: reading the file, then for an IFC the products tessellated / total with an
    ETA and the product finished last ("after IfcWall …"), the scene assembled, then the tie pairs found."""
    from ..model.load import MESH_EXTENSIONS, load_model, resolve_model_path
    from ..model.pointcloud import is_point_cloud

    name = resolve_model_path(model).name
    with StageDisplay(console, LOAD_STAGES) as display:
        def status(s) -> None:  # a LoadProgress
            if s.phase == "tessellating":
                display("tessellating", s.done, s.total, "; ".join(x for x in (_eta(s.eta_s), s.message) if x))
            elif s.phase != "done":
                display(s.phase, 0, 0, s.message)

        extra: dict = {}
        if name.lower().endswith(tuple(MESH_EXTENSIONS)):
            extra = {"elements": mesh_elements, "scale": mesh_scale}
            if patch_area is not None and mesh_elements == "patches":
                extra["patch_area_m2"] = patch_area
        cloud = name.lower().endswith((".las", ".laz")) or (name.lower().endswith(".ply")
                                                             and is_point_cloud(resolve_model_path(model)))
        if cloud:
            extra = {"scale": mesh_scale} | ({"patch_area_m2": patch_area} if patch_area is not None else {})
        return load_model(model, cache=cache, status=status, **extra)


def georef_kwargs(scene) -> dict:
    """A flight-app mission (latitude/longitude) is placed with the model's georeference, taking off from its file's
    reference, else from the site's ground (:func:`~sightplan.plan.load.scene_placement`)."""
    from ..plan.load import scene_placement

    return scene_placement(scene)


def print_warnings(console: Console, warnings) -> None:
    """Each warning on a line of its own, in yellow."""
    for warning in warnings:
        console.print(f"[yellow]warning:[/] {warning}", highlight=False)


def refuse_if_far(scene, plan) -> None:
    """One error when a frame, waypoint or ground station lies farther from the model than a plan may reach
    (``$SIGHTPLAN_MAX_REACH_M``, default 5 km), as the server refuses it: such a plan is in another place, frame or
    unit, and every check, metric and export of it would be about nothing."""
    from ..plan.domain import PlanError, check_plan_near_model

    try:
        check_plan_near_model(plan, *scene.bounds())
    except PlanError as exc:
        raise PlanError(f"{exc}; is the plan in the model's frame (georeference, --transform, units)?") from None
