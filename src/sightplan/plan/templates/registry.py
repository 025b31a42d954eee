"""Every template by name, built and checked one way: the dispatch the command line and the web API share.

Each template module declares a :class:`~.base.Template` named ``TEMPLATE``; :data:`TEMPLATES` holds them all,
found by walking this package, so adding a template is adding its module. :func:`build_template` makes a
template's frames from a scene, a camera and its parameters; :func:`plan_from_template` then splits and checks them
with flight settings (a drone's defaults, or a walker's for a walked route: :func:`default_flight`), against the
model and whatever else stands on the site, and records the site (georeference, take-off point) on the plan.
``sightplan plan`` and ``POST /api/projects/{id}/plans`` both call it, so a plan made either way is the same plan.
"""

from __future__ import annotations

import importlib
import pkgutil
from dataclasses import replace
from pathlib import Path
from typing import Any

from ...camera.models import Camera
from ...errors import PlanError
from ...model.scene import Scene
from ..checks.feasibility import FeasibilityReport, FlightSettings, check_plan, plan_flights
from ..checks.gate import record_checks
from ..checks.safety import placement
from ..ground import MIN_HEIGHT_M
from ..site import with_site
from ..types import Plan
from .base import Params, Template


def _discover() -> dict[str, Template]:
    found = []
    for module in pkgutil.iter_modules([str(Path(__file__).parent)]):
        declared = getattr(importlib.import_module(f"{__package__}.{module.name}"), "TEMPLATE", None)
        if isinstance(declared, Template):
            found.append(declared)
    names = [t.name for t in found]
    if len(set(names)) != len(names):
        raise RuntimeError(f"two templates share a name: {sorted(names)}")
    return {t.name: t for t in sorted(found, key=lambda t: (t.order, t.name))}


#: every template, in the order lists show them
TEMPLATES: dict[str, Template] = _discover()
TEMPLATE_NAMES = tuple(TEMPLATES)
WALKED = frozenset(n for n, t in TEMPLATES.items() if t.walked)  # no line of sight, altitude limit or minimum height
DRONE_SAFETY_M = 10.0  # a template's default distance to the model (and the flight check's)


def template(name: str) -> Template:
    """The template called ``name``; a PlanError lists the others."""
    if name not in TEMPLATES:
        raise PlanError(f"unknown template {name!r}: use one of {', '.join(TEMPLATES)}")
    return TEMPLATES[name]


def default_flight(walked: bool) -> dict:
    """The flight settings a template is checked with when the user gives none: a drone's (10 m from the model,
    500 m line of sight, a Phantom 4 Pro's battery, the 120 m limit, 2 m over the ground), or for a walked route a
    walker's (0.3 m clearance, a 360° camera walker's battery, no line of sight, no limits). 0 means no check."""
    if walked:
        return {"safety_distance_m": 0.3, "vlos_radius_m": 0.0, "aircraft": "walker-360", "altitude_limit_m": 0.0,
                "min_height_m": None}
    return {"safety_distance_m": DRONE_SAFETY_M, "vlos_radius_m": 500.0, "aircraft": "p4p", "altitude_limit_m": 120.0,
            "min_height_m": MIN_HEIGHT_M}


def build_template(name: str, scene: Scene, camera: Camera, p: Params | dict[str, Any], safety_distance_m: float,
                   min_height_m: float | None, error_m: tuple[float, float] = (0.0, 0.0)) -> Plan:
    """The frames of template ``name`` around ``scene`` (before any flight check) with parameters ``p`` (its
    dataclass, or a dict of its fields); a PlanError names what is missing or wrong.

    With a position error ``error_m`` (h, v), a flown template places its frames so that they pass the checks at
    that error: at :func:`~sightplan.plan.checks.safety.placement_distance` from the model (the safety distance
    plus √(h² + v²) plus 1 cm) and at least the minimum height plus v plus 1 cm above the ground."""
    t = template(name)
    if isinstance(p, dict):
        p = t.make(p)
    if not isinstance(p, t.params):
        raise PlanError(f"the {name} template takes {t.params.__name__}, not {type(p).__name__}")
    if t.walked or not any(error_m):
        return t.build(scene, camera, p, safety_distance_m, min_height_m if min_height_m is not None else 0.0)
    g, low = placement(safety_distance_m, min_height_m, error_m)
    plan = t.build(scene, camera, p, g, low if low is not None else 0.0)
    params = {**plan.parameters, "placed_at_m": g, "position_error_m": list(error_m)}
    if "safety_distance_m" in params:
        params["safety_distance_m"] = float(safety_distance_m)
    return replace(plan, parameters=params)


def plan_from_template(name: str, scene: Scene, camera: Camera, p: Params | dict[str, Any], settings: FlightSettings, *,
                       obstacles: Scene | None = None, split: bool = True) -> tuple[Plan, FeasibilityReport]:
    """The template's plan, split into missions that keep line of sight and fit a battery (``split``) or only
    checked, against ``obstacles`` (default: the scene; with a reality model, both), with the checks recorded and
    the site (georeference, take-off under the first mission's ground station) set; and the feasibility report."""
    frames = build_template(name, scene, camera, p, settings.safety_distance_m, settings.min_height_m, settings.error)
    report = (plan_flights if split else check_plan)(obstacles if obstacles is not None else scene, frames, settings)
    return with_site(record_checks(report.plan, report, settings), scene, replace_takeoff=True), report
