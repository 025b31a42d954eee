"""Flight options shared by ``sightplan plan`` and ``sightplan check``, and the feasibility printout."""

from __future__ import annotations

import json
from pathlib import Path
from typing import Annotated

import typer
from rich.console import Console
from rich.table import Table

VlosOpt = Annotated[float, typer.Option("--vlos-radius", help="Visual line-of-sight radius around the pilot (m); 0: no check")]
StationOpt = Annotated[list[str] | None, typer.Option(
    "--ground-station", help="Pilot position: 'x,y,z' in the model frame (m), or 'lat,lon' (WGS 84 degrees, or a "
                             "'geo:lat,lon' link from a phone's map) on the ground of a georeferenced model; repeat "
                             "for candidates. Default: the four corners of the plan's region")]
AltitudeOpt = Annotated[float, typer.Option("--altitude-limit", help="FAA §107.51 altitude limit (m); 0: no check")]
MinHeightOpt = Annotated[float | None, typer.Option(
    "--min-height", help="Least height of a waypoint above the ground under it (the terrain, else the model's base), "
                         "in m. Default 2; none for a walked route")]


PositionErrorOpt = Annotated[str | None, typer.Option(
    "--position-error", help="How far the aircraft may stray from its planned point, 'H,V' metres, or 'gnss' (±1.5 m, "
                             "±0.5 m) or 'rtk' (±0.1 m). The safety, minimum-height and altitude checks hold at its "
                             "worst. Default: the aircraft's (gnss; rtk for the -rtk presets), none for a walked route")]
GroundZOpt = Annotated[float | None, typer.Option(
    "--ground-z", help="Height of the site's ground in the model frame (m), instead of the terrain or the building's "
                       "outside ground level that sightplan finds; a flight-app mission takes off there too, not at "
                       "its file's home")]


def parse_point(text: str, what: str):
    """'x,y,z' → (3,) array, or a PlanError naming ``what``."""
    import numpy as np

    from ..errors import PlanError

    try:
        xyz = [float(v) for v in text.split(",")]
    except ValueError:
        xyz = []
    if len(xyz) != 3 or not all(np.isfinite(xyz)):
        raise PlanError(f"{what} {text!r} must be three numbers 'x,y,z' in metres")
    return np.array(xyz)


def parse_stations(texts: list[str] | None, scene=None, georeference=None):
    """--ground-station values → (n, 3) model points, or None: 'x,y,z' as given, 'lat,lon' or 'geo:lat,lon'
    at :data:`~sightplan.plan.ground.GROUND_STATION_HEIGHT_M` above the ground there, placed by ``georeference``
    (a plan's), else the scene's."""
    import numpy as np

    from ..errors import PlanError

    if not texts:
        return None
    out, geodetic = np.zeros((len(texts), 3)), np.zeros(len(texts), bool)
    for k, text in enumerate(texts):
        body = text.strip()
        geodetic[k] = body.lower().startswith("geo:")
        if geodetic[k]:
            body = body[4:].split(";")[0]  # geo:lat,lon[,alt][;u=…] (RFC 5870): the altitude is not the ground's
        try:
            values = [float(v) for v in body.split(",")]
        except ValueError:
            values = []
        geodetic[k] |= len(values) == 2
        want = (2, 3) if geodetic[k] else (3,)
        if len(values) not in want or not np.isfinite(values).all():
            raise PlanError(f"ground station {text!r} must be 'x,y,z' in metres (model frame) or 'lat,lon' in degrees")
        out[k, :len(values)] = values
    if geodetic.any():
        from ..geo import Georeference, resolve_georeference
        from ..plan.ground import stations_from_geodetic

        if scene is None:
            raise PlanError("a ground station given by latitude/longitude needs the model")
        geo = resolve_georeference(georeference, Georeference.from_scene_metadata(scene.metadata),
                                   what="a ground station given by latitude/longitude")
        out[geodetic] = stations_from_geodetic(scene, geo, out[geodetic, :2])
    return out


def parse_gimbal(text: str | None):
    """--gimbal 'RATE,SETTLE' → :class:`~sightplan.flight.simulate.Gimbal` (None: the default)."""
    import math

    from ..errors import PlanError
    from ..flight.simulate import Gimbal

    if text is None:
        return None
    try:
        rate, settle = (float(v) for v in text.split(","))
    except ValueError:
        rate = settle = math.nan
    if not (math.isfinite(rate) and math.isfinite(settle) and 0 < rate <= 1000 and 0 <= settle <= 60):
        raise PlanError(f"--gimbal {text!r} must be 'DEG_PER_S,SECONDS': a slew rate above 0 (°/s) and a settling "
                        "time of 0 to 60 s, e.g. 30,0.5")
    return Gimbal(rate_deg_s=rate, settle_s=settle)


def aircraft_from_option(name: str):
    """An Aircraft (or Rover) preset, or one read from a JSON file; None for 'none'."""
    from ..errors import PlanError
    from ..plan.checks import battery

    if name.lower() == "none":
        return None
    presets = {**battery.AIRCRAFT, **getattr(battery, "ROVERS", {})}
    if name in presets:
        return presets[name]
    path = Path(name)
    if path.suffix.lower() == ".json" and path.exists():
        try:
            d = json.loads(path.read_text(encoding="utf-8"))
        except (OSError, ValueError) as exc:
            raise PlanError(f"cannot read the aircraft file {path}: {exc}") from None
        base = presets.get(d.pop("preset", ""), None) if isinstance(d, dict) else None
        try:
            if base is not None:
                from dataclasses import replace

                return replace(base, **d)
            return battery.Aircraft(**{"name": path.stem, **d})
        except TypeError as exc:
            raise PlanError(f"{path.name}: not an aircraft description ({exc}); fields: name, horizontal_speed, "
                            "vertical_speed, accel, flight_time_s, capture_s, reserve, or 'preset' plus changes") from None
    raise PlanError(f"unknown aircraft {name!r}: use one of {', '.join(presets)}, a JSON file, or 'none'")


def flight_settings(safety_distance: float, vlos_radius: float, ground_station: list[str] | None, aircraft: str,
                    altitude_limit: float, min_height: float | None = None, position_error: str | None = None,
                    scene=None, georeference=None):
    from ..plan.checks.feasibility import FlightSettings

    stations = parse_stations(ground_station, scene, georeference)
    return FlightSettings(safety_distance_m=safety_distance, vlos_radius_m=vlos_radius or None, ground_stations=stations,
                          altitude_limit_m=altitude_limit or None, aircraft=aircraft_from_option(aircraft),
                          min_height_m=min_height, position_error_m=position_error)


def default_flight_settings(walked: bool, safety_distance: float | None, vlos_radius: float | None,
                            ground_station: list[str] | None, aircraft: str | None, altitude_limit: float | None,
                            drone_safety_m: float | None = None, min_height: float | None = None,
                            position_error: str | None = None, scene=None, georeference=None):
    """:func:`flight_settings` with the defaults of a drone flight, or of a walked or driven route
    (:func:`~sightplan.plan.templates.registry.default_flight`), for the options not given (None);
    ``drone_safety_m`` replaces a drone's default distance to the model."""
    from ..plan.templates.registry import default_flight

    d = default_flight(walked)
    if drone_safety_m is not None and not walked:
        d["safety_distance_m"] = drone_safety_m
    given = (safety_distance, vlos_radius, aircraft, altitude_limit, min_height)
    defaults = (d["safety_distance_m"], d["vlos_radius_m"], d["aircraft"], d["altitude_limit_m"], d["min_height_m"])
    safety, vlos, craft, limit, low = (x if v is None else v for v, x in zip(given, defaults))
    return flight_settings(safety, vlos, ground_station, craft, limit, low, position_error,  # type: ignore[arg-type]
                           scene, georeference)


def _minutes(t: float | None) -> str:
    return "—" if t is None else f"{t / 60:.1f}"


def _both(a: bool | None, b: bool | None) -> bool | None:
    return None if a is None and b is None else (a is not False and b is not False)


def _flag(v: bool | None) -> str:
    return "—" if v is None else ("[green]ok" if v else "[bold red]no")


def print_feasibility(console: Console, report, title: str, max_violations: int = 20) -> None:
    """Missions with their ground station, time, distance and verdicts; totals; the violations."""
    plan = report.plan
    t = Table("mission", "frames", "from", "pilot x,y", "min", "km", "batt.", "sight", "clear", "alt.",
              title=title, title_justify="left", caption="from: resume waypoint; pilot: ground station (m); "
              "min/km: flight from and back to the pilot; alt.: altitude limit and minimum height", caption_justify="left")
    for m in report.missions:
        gs = "—" if m.line_of_sight_ok is None else ",".join(f"{v:.0f}" for v in m.ground_station[:2])
        t.add_row(m.name, str(m.stop - m.start), str(m.start), gs, _minutes(m.time_s),
                  "—" if m.distance_m is None else f"{m.distance_m / 1000:.2f}", _flag(m.battery_ok), _flag(m.line_of_sight_ok),
                  _flag(m.safety_ok), _flag(_both(m.altitude_ok, m.height_ok)))
    console.print(t)
    n_wp = len(plan.waypoints) if len(plan.waypoints) else len(plan)
    batteries = report.batteries
    if batteries is None:
        batteries = sum(m.battery_ok is not None for m in report.missions)
    total = report.total_time_s
    console.print(f"{n_wp} waypoints, {len(plan)} frames, {len(report.missions)} missions"
                  + (f" ({batteries} {'battery' if batteries == 1 else 'batteries'}), {total / 60:.1f} min of flight"
                     if total is not None else "")
                  + f"; least clearance {report.safety.waypoint_m.min():.2f} m")
    h, v = report.error_m
    if report.ground is not None and report.missions and report.missions[0].line_of_sight_ok is not None:
        console.print(f"ground: {report.ground.reason}", highlight=False)
    if report.paths:
        rise = max(p.return_z_m - p.takeoff_m[2] for p in report.paths)
        console.print(f"checked from take-off to landing: each mission's climb, flight out, return (at most "
                      f"{rise:.1f} m above its take-off) and landing"
                      + (f", at the worst of ±{h:g} m horizontal and ±{v:g} m vertical position error" if h or v else ""),
                      highlight=False)
    if report.violations:
        console.print(f"[bold red]{len(report.violations)} violation(s):")
        for v in report.violations[:max_violations]:
            console.print(f"  • {v}", highlight=False)
        if len(report.violations) > max_violations:
            console.print(f"  … and {len(report.violations) - max_violations} more (see --json)")
    else:
        console.print("[green]no violations: every mission keeps its distance, sight line, altitude, height and battery")
