"""Whether a plan may go to a flight app: the flight checks it fails, for ``sightplan export`` and the web app.

``sightplan plan``, ``sightplan check -o`` and the web app record the checks they ran in the
plan's parameters (``checks``: the settings and the violations). :func:`export_violations`
checks the plan again when the model is at hand, with the recorded settings (a plan without
a record gets the defaults of ``sightplan check``); without the model it takes the recorded
violations. Either way it adds the waypoints less than the minimum height above the
take-off point, which needs no model.
"""

from __future__ import annotations

from dataclasses import asdict, replace

import numpy as np
from numpy.typing import NDArray

from ...model.scene import Scene
from ..site import mission_takeoffs
from ..types import Mission, Plan
from .battery import ROVERS, Aircraft, Rover
from .feasibility import FeasibilityReport, FlightSettings, _runs, _span, check_plan

CHECKS_KEY = "checks"


def settings_record(settings: FlightSettings) -> dict:
    """The flight settings as JSON."""
    craft = settings.aircraft
    return {"safety_distance_m": settings.safety_distance_m, "vlos_radius_m": settings.vlos_radius_m,
            "altitude_limit_m": settings.altitude_limit_m, "min_height_m": settings.min_height_m,
            "position_error_m": list(settings.error),
            "ground_stations": None if settings.ground_stations is None
            else np.asarray(settings.ground_stations, float).tolist(),
            "aircraft": None if craft is None else {"kind": "rover" if isinstance(craft, Rover) else "aircraft",
                                                    **asdict(craft)}}


def settings_from_record(record: dict) -> FlightSettings:
    """:class:`FlightSettings` from :func:`settings_record`'s JSON."""
    craft = record.get("aircraft")
    if craft is not None:
        fields = {k: v for k, v in craft.items() if k != "kind"}
        craft = Rover(**fields) if craft.get("kind") == "rover" else Aircraft(**fields)
    stations = record.get("ground_stations")
    return FlightSettings(safety_distance_m=float(record["safety_distance_m"]), vlos_radius_m=record.get("vlos_radius_m"),
                          ground_stations=None if stations is None else np.asarray(stations, float),
                          altitude_limit_m=record.get("altitude_limit_m"), aircraft=craft,
                          min_height_m=record.get("min_height_m"), position_error_m=record.get("position_error_m"))


#: the ``template`` parameter of the plans walked or driven on the ground: an indoor route, an optimised indoor plan
WALKED_TEMPLATES = frozenset({"indoor_route", "optimised_indoor"})


def walked(plan: Plan) -> bool:
    """A route walked or driven on the ground: no line of sight, no altitude limit, no minimum height."""
    return plan.parameters.get("template") in WALKED_TEMPLATES


def default_settings(plan: Plan) -> FlightSettings:
    """The settings ``sightplan check`` uses by default: a drone's, or a walker's for a walked route."""
    if walked(plan):
        return FlightSettings(safety_distance_m=0.3, vlos_radius_m=None, altitude_limit_m=None,
                              aircraft=ROVERS["walker-360"], min_height_m=None)
    return FlightSettings(safety_distance_m=5.0)


def record_checks(plan: Plan, report: FeasibilityReport, settings: FlightSettings) -> Plan:
    """The plan with the checks that ``report`` ran (settings and violations) in its parameters."""
    from ..trajectory import TRAJECTORY_KEY

    checks = {"ok": report.ok, "violations": list(report.violations), "settings": settings_record(settings)}
    if report.ground is not None:
        checks["ground"] = report.ground.to_dict()
    params = {**plan.parameters, CHECKS_KEY: checks}
    if report.paths:
        params[TRAJECTORY_KEY] = {"missions": [p.to_dict() for p in report.paths]}
    else:
        params.pop(TRAJECTORY_KEY, None)
    return replace(plan, parameters=params)


def recorded_settings(plan: Plan) -> FlightSettings:
    """The settings the plan's checks were recorded with, else :func:`default_settings`."""
    rec = plan.parameters.get(CHECKS_KEY)
    if isinstance(rec, dict) and isinstance(rec.get("settings"), dict):
        try:
            return settings_from_record(rec["settings"])
        except (TypeError, KeyError, ValueError):
            pass
    return default_settings(plan)


def takeoff_heights(plan: Plan, takeoff_m: NDArray, per_mission: bool = True) -> NDArray[np.float64]:
    """(n,) the take-off height each frame's flight starts from (:func:`~sightplan.plan.site.mission_takeoffs`)."""
    out = np.empty(len(plan))
    missions = plan.missions or (Mission("mission 1", 0, len(plan)),)
    for m, start in zip(missions, mission_takeoffs(plan, takeoff_m, per_mission)):
        out[m.start:m.stop] = start[2]
    return out


def export_violations(plan: Plan, takeoff_m: NDArray | None = None, scene: Scene | None = None,
                      per_mission: bool = True) -> list[str]:
    """The flight checks ``plan`` fails (see the module docstring); empty when it may be exported. ``takeoff_m``:
    the take-off point (the first mission's, each mission's own with ``per_mission``, as the exports take it)."""
    settings = recorded_settings(plan)
    if scene is not None:
        found = list(check_plan(scene, plan, settings).violations)
    else:
        rec = plan.parameters.get(CHECKS_KEY)
        found = [str(v) for v in rec.get("violations", [])] if isinstance(rec, dict) else []
    min_h = settings.min_height_m
    if takeoff_m is not None and min_h is not None and not walked(plan) and not isinstance(settings.aircraft, Rover):
        rel = plan.C_world[:, 2] - takeoff_heights(plan, takeoff_m, per_mission)
        for a, b in _runs(rel < min_h - 1e-6):
            found.append(f"{_span(a, b)} less than {min_h:g} m above the take-off point (lowest {rel[a:b].min():+.2f} m)")
    return found
