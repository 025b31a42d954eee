"""The steps around :func:`~sightplan.export.export_plan` that every caller takes: find the take-off point, check
the mission asked for, write the files."""

from __future__ import annotations

from pathlib import Path

import numpy as np
from numpy.typing import NDArray

from ..errors import PlanError
from ..geo import Georeference
from ..model.scene import Scene
from ..plan.types import Plan
from . import Autopilot, ExportedFile, ExportFormat, export_plan


def takeoff_point(plan: Plan, scene: Scene | None, *, hint: str) -> NDArray[np.float64]:
    """The take-off point the plan records (``takeoff_m``), else the south-west pilot station of the plan's region
    (:func:`~sightplan.plan.checks.feasibility.corner_stations`) on the site's ground; without either a PlanError
    ending with ``hint`` (what the caller can give)."""
    if plan.parameters.get("takeoff_m") is not None:
        return np.asarray(plan.parameters["takeoff_m"], float)
    if scene is None:
        raise PlanError(f"the plan records no take-off point: {hint}")
    from ..plan.checks.feasibility import corner_stations
    from ..plan.checks.gate import recorded_settings
    from ..plan.ground import ground_z

    settings = recorded_settings(plan)
    takeoff = corner_stations(scene, plan, safety_m=settings.safety_distance_m, error_m=settings.error)[0]
    takeoff[2] = float(ground_z(scene, takeoff[None, :2])[0])
    return takeoff


def export_files(plan: Plan, fmt: ExportFormat, path: str | Path, georef: Georeference, takeoff_m: NDArray,
                 *, speed_m_s: float = 5.0, mission: int | None = None, mission_label: str = "mission",
                 autopilot: Autopilot | None = None, aircraft: str | None = None, per_mission_takeoff: bool = True,
                 report: list[ExportedFile] | None = None, faithful: bool = True, gimbal=None) -> list[Path]:
    """:func:`export_plan` with ``mission`` numbered from 1 (None: all), refused with a PlanError naming it as
    ``mission_label`` when the plan has no such mission. ``autopilot``: for ``qgc`` and ``wpl``; ``aircraft``: for
    ``wpml``; ``per_mission_takeoff`` (each mission from its own ground station) and ``report``: see :func:`export_plan`."""
    if mission is not None and not 1 <= mission <= len(plan.missions):
        raise PlanError(f"{mission_label} {mission}: the plan has {len(plan.missions)} mission(s), numbered from 1")
    return export_plan(plan, fmt, path, georef, takeoff_m, speed_m_s=speed_m_s,
                       mission=None if mission is None else mission - 1, autopilot=autopilot, aircraft=aircraft,
                       per_mission_takeoff=per_mission_takeoff, report=report, faithful=faithful, gimbal=gimbal)
