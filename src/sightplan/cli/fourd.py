"""4D options shared by the commands: a schedule, link rules, and the capture date."""

from __future__ import annotations

from pathlib import Path
from typing import Annotated

import numpy as np
import typer
from rich.console import Console

from ..errors import SightplanError

ScheduleOpt = Annotated[str | None, typer.Option(
    help="Schedule: MS Project XML (.xml), Primavera P6 (.xer), CSV, an IFC with a work schedule, or 'model' for the "
         "model's own IfcWorkSchedule")]
RulesOpt = Annotated[Path | None, typer.Option(help="TOML rules linking tasks to elements by class, storey, name, property")]
ActualOpt = Annotated[bool, typer.Option("--prefer-actual", help="Actual start/finish dates win over planned ones")]
DateOpt = Annotated[str | None, typer.Option(help="Capture date YYYY-MM-DD: only elements built by then exist")]
BasisOpt = Annotated[str, typer.Option(help="Which schedule date builds an element: finish or start")]
RealityOpt = Annotated[Path | None, typer.Option(
    help="Reality model of the site as it stands (mesh, PLY/LAS/LAZ point cloud) in the model's frame: it hides and "
         "obstructs, but is not scored")]
UnscheduledOpt = Annotated[str, typer.Option(help="Elements no schedule dates: present at every date, or absent")]


def link_with_schedule(console: Console, scene, model: str, schedule: str | None, rules: Path | None,
                       prefer_actual: bool):
    """The undated scene with element dates from ``schedule`` (and ``rules``); the link report is printed."""
    if schedule is None and rules is None:
        return scene
    from ..model.load import IFC_EXTENSIONS, resolve_model_path
    from ..schedule import link_schedule, read_schedule

    model_path = resolve_model_path(model)
    ifc = model_path if model_path.suffix.lower() in IFC_EXTENSIONS else None
    tasks = read_schedule(schedule if schedule is not None else "model", model_path=ifc)
    scene, report = link_schedule(scene, tasks, rules, model_path=ifc, prefer_actual=prefer_actual)
    for line in report.describe():
        console.print(line, highlight=False)
    return scene


def check_date_options(basis: str, unscheduled: str) -> None:
    from ..errors import ScheduleError

    if basis not in ("finish", "start"):
        raise ScheduleError(f"--date-basis must be 'finish' or 'start', got {basis!r}")
    if unscheduled not in ("present", "absent"):
        raise ScheduleError(f"--unscheduled must be 'present' or 'absent', got {unscheduled!r}")


def scene_at(console: Console, scene, date: str | None, basis: str, unscheduled: str):
    """The scene at ``date`` (unchanged without one), with a line saying how much stands."""
    check_date_options(basis, unscheduled)
    if date is None:
        return scene
    el = scene.elements
    if np.isnat(el.start).all() and np.isnat(el.finish).all():
        raise SightplanError(f"--date {date} needs the elements' dates: give --schedule FILE (or --schedule model for "
                             "the model's own work schedule); without one every element would count as built")
    scene = scene.at(date, basis=basis, unscheduled=unscheduled)  # type: ignore[arg-type]
    console.print(f"capture date {date}: {int(scene.targets.sum())} target elements built")
    return scene


def with_reality(console: Console, scene, reality: Path | None):
    """The scene plus a reality model as occluders (unchanged without one)."""
    if reality is None:
        return scene
    from ..model.reality import combine, load_reality

    real = load_reality(reality)
    console.print(f"reality model {reality.name}: {real.n_elements} patches, {len(real.faces):,} triangles, as occluders")
    return combine(scene, real, "occluder")


def dated_scene(console: Console, scene, model: str, schedule: str | None, rules: Path | None, prefer_actual: bool,
                date: str | None, basis: str, unscheduled: str):
    """The scene dated by its schedule (:func:`link_with_schedule`) and taken at ``date`` (:func:`scene_at`)."""
    return scene_at(console, link_with_schedule(console, scene, model, schedule, rules, prefer_actual), date, basis,
                    unscheduled)
