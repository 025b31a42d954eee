"""An optimised plan beside the best template of a grid: like for like and at equal minutes.

The grid (:func:`template_grid`) is the facade grid (box and outline footprints), the orbit and the lawn-mower (the
safety distance plus the position error's reach above the targets' top, where the templates place their frames) at
60, 70 and 80 % overlap, each planned with the optimiser's camera and flight settings, split and flight-checked, and
scored against the optimiser's targets (:func:`~.run.score_plan`). The best template passes the flight checks and
meets the most targets, then takes the fewest minutes; one that fails the checks (line of sight, battery, safety)
cannot be flown as planned, so it is chosen only when none passes. Beside it the optimiser runs twice more, its
candidates already cast:

- **like for like**: every target the best template does not meet is skipped, so the plan meets what the template
  meets; its frames and minutes against the template's;
- **at equal minutes**: a budget of the template's minutes, every target; its targets met against the template's.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass, replace

import numpy as np

from ..camera.models import Camera
from ..errors import PlanError
from ..model.scene import Scene
from ..plan.checks.feasibility import FeasibilityReport, FlightSettings
from ..plan.checks.safety import placement_distance
from ..plan.ground import targets_only
from ..plan.types import Plan
from .budget import Budget
from .result import OptimizeResult
from .run import OptimizeSettings, PlanScore, optimize, score_plan
from .targets import ElementTargets, Rule, Targets

OVERLAPS = (0.6, 0.7, 0.8)
#: progress(stage, done, total) while the templates are planned and scored
SCORING = "planning and scoring the templates"
LIKE_FOR_LIKE = "optimised, the template's targets"
EQUAL_MINUTES = "optimised at the template's minutes"


@dataclass(frozen=True)
class Scored:
    """A plan with its flight report and its score against the optimiser's targets."""

    label: str
    plan: Plan
    report: FeasibilityReport
    score: PlanScore

    @property
    def minutes(self) -> float | None:
        t = self.report.total_time_s
        return None if t is None else t / 60

    @property
    def met(self) -> int:
        return int(self.score.met.sum())


@dataclass(frozen=True)
class Comparison:
    """The grid's templates (``templates``; ``failed``: label → why a template or an optimiser run could not be
    made), the best one, and the optimiser like for like (None when the template meets no target) and at the
    template's minutes (None when the template has no flight time)."""

    templates: tuple[Scored, ...]
    failed: dict
    best: Scored | None
    like_for_like: Scored | None
    equal_minutes: Scored | None


def template_grid(scene: Scene, flight: FlightSettings) -> list[tuple[str, str, dict]]:
    """(label, template, parameters) of every template the comparison plans (module docstring)."""
    top = float(targets_only(scene).bounds()[1][2] - scene.bounds()[0][2])
    clear = placement_distance(flight.safety_distance_m, flight.error)  # over the top as far as the facades stand
    grid = []
    for overlap in OVERLAPS:
        for footprint in ("box", "outline"):
            grid.append((f"facade {footprint} {overlap:.0%}", "facade", {"overlap": overlap, "footprint": footprint}))
        grid.append((f"orbit {overlap:.0%}", "orbit", {"overlap": overlap}))
        grid.append((f"lawnmower {overlap:.0%}", "lawnmower", {"overlap": overlap, "side_overlap": overlap,
                                                               "altitude_m": top + clear}))
    return grid


def best_of(rows: list[Scored] | tuple[Scored, ...]) -> Scored | None:
    """The template that passes the flight checks and meets the most targets, then takes the fewest minutes."""
    if not rows:
        return None
    return max(rows, key=lambda r: (r.report.ok, r.met, -(r.minutes if r.minutes is not None else np.inf)))


def score_templates(scene: Scene, camera: Camera, et: ElementTargets, flight: FlightSettings, *, scale: float,
                    engine: str = "auto", cache_dir: object = None,
                    progress: Callable[[str, int, int], None] | None = None) -> tuple[list[Scored], dict]:
    """Every template of :func:`template_grid` planned, checked and scored; and label → the reason for those that
    cannot be planned here."""
    from ..plan.templates.registry import plan_from_template

    grid = template_grid(scene, flight)
    rows, failed = [], {}
    for n, (label, name, params) in enumerate(grid):
        try:
            plan, report = plan_from_template(name, scene, camera, params, flight)
        except PlanError as exc:
            failed[label] = str(exc)
        else:
            rows.append(Scored(label, plan, report, score_plan(scene, plan, et, scale=scale, engine=engine,
                                                               cache_dir=cache_dir)))
        if progress is not None:
            progress(SCORING, n + 1, len(grid))
    return rows, failed


def only_met(targets: Targets, scene: Scene, et: ElementTargets, met: np.ndarray) -> Targets:
    """``targets`` with every active target outside ``met`` skipped (a rule by GlobalId each)."""
    gid = scene.elements.global_id
    skip = tuple(Rule(match=(("global_id", str(gid[i])),), skip=True) for i in np.flatnonzero(et.active & ~met))
    return replace(targets, rules=targets.rules + skip)


def compare_with_best_template(scene: Scene, camera: Camera, targets: Targets, result: OptimizeResult, *,
                               flight: FlightSettings, settings: OptimizeSettings,
                               progress: Callable[[str, int, int], None] | None = None) -> Comparison:
    """The grid's templates scored against ``result``'s targets, the best one, and the optimiser like for like and
    at the best template's minutes (module docstring), with the settings ``result`` was made with."""
    et = result.targets
    rows, failed = score_templates(scene, camera, et, flight, scale=settings.scale, engine=settings.engine,
                                   cache_dir=settings.cache_dir, progress=progress)
    best = best_of(rows)
    like = equal = None

    def run(label: str, goal: Targets, budget: Budget) -> Scored | None:
        try:
            res = optimize(scene, camera, goal, budget, flight=flight, settings=settings, progress=progress)
        except PlanError as exc:
            failed[label] = str(exc)
            return None
        return Scored(label, res.plan, res.report, score_plan(scene, res.plan, et, scale=settings.scale,
                                                              engine=settings.engine, cache_dir=settings.cache_dir))

    if best is not None and best.met > 0:
        like = run(LIKE_FOR_LIKE, only_met(targets, scene, et, best.score.met), Budget())
    if best is not None and best.minutes:
        equal = run(EQUAL_MINUTES, targets, Budget(minutes=best.minutes))
    return Comparison(tuple(rows), failed, best, like, equal)
