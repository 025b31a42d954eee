"""Optimised plans: candidate views cast once, a submodular selection over their Observations, an LKH route, and
the flight checks' split into missions. :func:`optimize` runs it all; each piece works on its own. With a 360°
camera, :func:`optimize_indoor` (:mod:`.indoor`): positions in each storey's free space, walked storey by storey."""

from .budget import Budget, longest_prefix
from .candidates import CandidateSet, aimed_views, candidate_views, surface_anchors
from .compare import Comparison, Scored, best_of, compare_with_best_template, only_met, score_templates, template_grid
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
from .targets import BOUND_RTOL, ElementTargets, Rule, Targets

__all__ = ["BOUND_RTOL", "Budget", "CandidateSet", "Comparison", "CoverageTable", "ElementTargets", "FeatureIndex",
           "IndoorCandidates", "IndoorResult", "IndoorSettings", "OptimizeResult", "OptimizeSettings", "PlanScore",
           "Rule", "Runs", "Scored", "Selection", "Storey", "Targets", "Walk", "aimed_views", "best_of",
           "candidate_views", "compare_with_best_template", "default_ssd", "greedy", "indoor_candidates",
           "longest_prefix", "only_met", "open_path", "optimize", "optimize_indoor", "order_views", "ordered_plan",
           "remove_redundant", "score_plan", "score_templates", "stable_runs", "storey_levels", "surface_anchors",
           "template_grid", "walk_order", "walker_settings"]
