"""Every template by name, built and checked one way: the dispatch the command line and the web API share.

:func:`build_template` makes a template's frames from a scene, a camera and its :class:`TemplateParams`;
:func:`plan_from_template` then splits and checks them with flight settings (a drone's defaults, or a walker's for a
walked route: :func:`default_flight`), against the model and whatever else stands on the site, and records the
site (georeference, take-off point) on the plan. ``sightplan plan`` and ``POST /api/projects/{id}/plans`` both call
it, so a plan made either way is the same plan.
"""

from __future__ import annotations

from dataclasses import dataclass

from ...camera.models import Camera
from ...errors import PlanError
from ...model.scene import Scene
from ..checks.feasibility import FeasibilityReport, FlightSettings, check_plan, plan_flights
from ..checks.gate import record_checks
from ..ground import MIN_HEIGHT_M
from ..site import with_site
from ..types import Plan
from .bridge import bridge
from .facade import facade_grid
from .indoor import indoor_route, indoor_routes
from .lawnmower import lawnmower
from .orbit import orbit

TEMPLATE_NAMES = ("facade", "orbit", "lawnmower", "bridge", "route")
WALKED = frozenset({"route"})  # walked or driven indoors: no line of sight to keep, no altitude limit, no minimum height
DRONE_SAFETY_M = 10.0  # a template's default distance to the model (and the flight check's)


def default_flight(walked: bool) -> dict:
    """The flight settings a template is checked with when the user gives none: a drone's (10 m from the model,
    500 m line of sight, a Phantom 4 Pro's battery, the 120 m limit, 2 m over the ground), or for a walked route a
    walker's (0.3 m clearance, a 360° camera walker's battery, no line of sight, no limits). 0 means no check."""
    if walked:
        return {"safety_distance_m": 0.3, "vlos_radius_m": 0.0, "aircraft": "walker-360", "altitude_limit_m": 0.0,
                "min_height_m": None}
    return {"safety_distance_m": DRONE_SAFETY_M, "vlos_radius_m": 500.0, "aircraft": "p4p", "altitude_limit_m": 120.0,
            "min_height_m": MIN_HEIGHT_M}


@dataclass(frozen=True)
class TemplateParams:
    """A template's parameters, as the command line and the web API give them (each template reads its own).

    overlap: image overlap (all but route); footprint: facade's 'box' or 'outline'; radius_m, height_m: orbit's
    rings (radii and heights) or bridge's side-pass heights; step: orbit's degrees or route's metres between
    frames; aim: orbit's 'centre' or 'surface'; altitude_m, gsd_m, side_overlap, oblique_pitch_deg: lawnmower's;
    axis: bridge's points (x, y) in order; under_deck, deck_z_m: bridge's; points: route's polyline (x, y, z);
    routes: several walked polylines with their names (from a routes file), instead of ``points``.
    """

    overlap: float = 0.8
    footprint: str = "box"
    radius_m: tuple[float, ...] = ()
    height_m: tuple[float, ...] = ()
    step: float | None = None
    aim: str = "centre"
    altitude_m: float | None = None
    gsd_m: float | None = None
    side_overlap: float = 0.7
    oblique_pitch_deg: float | None = None
    axis: tuple[tuple[float, float], ...] = ()
    under_deck: bool = True
    deck_z_m: float | None = None
    points: tuple[tuple[float, float, float], ...] = ()
    routes: tuple[list, list[str]] | None = None


def build_template(name: str, scene: Scene, camera: Camera, p: TemplateParams, safety_distance_m: float,
                   min_height_m: float | None) -> Plan:
    """The frames of template ``name`` around ``scene`` (before any flight check); a PlanError names what is
    missing or wrong."""
    low = min_height_m if min_height_m is not None else 0.0
    if name == "facade":
        if p.footprint not in ("box", "outline"):
            raise PlanError(f"the footprint must be 'box' or 'outline', got {p.footprint!r}")
        return facade_grid(scene, camera, safety_distance_m, p.overlap, footprint=p.footprint, min_height_m=low)
    if name == "orbit":
        return orbit(scene, camera, list(p.radius_m) or None, list(p.height_m) or None, step_deg=p.step,
                     overlap=p.overlap, aim=p.aim, safety_distance_m=safety_distance_m, min_height_m=low)
    if name == "lawnmower":
        return lawnmower(scene, camera, altitude_m=p.altitude_m, gsd_m=p.gsd_m, front_overlap=p.overlap,
                         side_overlap=p.side_overlap, oblique_pitch_deg=p.oblique_pitch_deg, min_height_m=low)
    if name == "bridge":
        if len(p.axis) < 2:
            raise PlanError("a bridge needs its axis: at least two points (x, y), in order")
        return bridge(scene, camera, [list(a) for a in p.axis], safety_distance_m, heights_m=list(p.height_m) or None,
                      under_deck=p.under_deck, overlap=p.overlap, deck_z=p.deck_z_m, min_height_m=low)
    if name == "route":
        if (len(p.points) < 2 and p.routes is None) or p.step is None:
            raise PlanError("a route needs at least two points (x, y, z), or a routes file, and a step in metres")
        if p.routes is not None:
            polylines, names = p.routes
            return indoor_routes(camera, polylines, p.step, names=names)
        return indoor_route(camera, [list(q) for q in p.points], p.step)
    raise PlanError(f"unknown template {name!r}: use one of {', '.join(TEMPLATE_NAMES)}")


def plan_from_template(name: str, scene: Scene, camera: Camera, p: TemplateParams, settings: FlightSettings, *,
                       obstacles: Scene | None = None, split: bool = True) -> tuple[Plan, FeasibilityReport]:
    """The template's plan, split into missions that keep line of sight and fit a battery (``split``) or only
    checked, against ``obstacles`` (default: the scene; with a reality model, both), with the checks recorded and
    the site (georeference, take-off under the first mission's ground station) set; and the feasibility report."""
    frames = build_template(name, scene, camera, p, settings.safety_distance_m, settings.min_height_m)
    report = (plan_flights if split else check_plan)(obstacles if obstacles is not None else scene, frames, settings)
    return with_site(record_checks(report.plan, report, settings), scene, replace_takeoff=True), report
