"""Optimised plans: candidate views cast once, a submodular selection over their Observations, an LKH route, and
the flight checks' split into missions. :func:`optimize` runs it all; each piece works on its own. With a 360°
camera, :func:`optimize_indoor` (:mod:`.indoor`): positions in each storey's free space, walked storey by storey."""

from .budget import Budget, longest_prefix
from .candidates import CandidateSet, aimed_views, candidate_views, surface_anchors
from .indoor import (
    IndoorCandidates,
    IndoorResult,
    IndoorSettings,
    Storey,
    Walk,
    indoor_candidates,
    open_path,
    optimize_indoor,
    storey_levels,
    walk_order,
    walker_settings,
)
from .result import OptimizeResult
from .route import order_views, ordered_plan
from .run import OptimizeSettings, PlanScore, default_ssd, optimize, score_plan
from .select import CoverageTable, FeatureIndex, Runs, Selection, greedy, remove_redundant, stable_runs
from .targets import ElementTargets, Rule, Targets

__all__ = ["Budget", "CandidateSet", "CoverageTable", "ElementTargets", "FeatureIndex", "IndoorCandidates", "IndoorResult",
           "IndoorSettings", "OptimizeResult", "OptimizeSettings", "PlanScore", "Rule", "Runs", "Selection", "Storey",
           "Targets", "Walk", "aimed_views", "candidate_views", "default_ssd", "greedy", "indoor_candidates", "longest_prefix",
           "open_path", "optimize", "optimize_indoor", "order_views", "ordered_plan", "remove_redundant", "score_plan",
           "stable_runs", "storey_levels", "surface_anchors", "walk_order", "walker_settings"]
