"""Optimised plans: candidate views cast once, a submodular selection over their Observations, an LKH route, and
the flight checks' split into missions. :func:`optimize` runs it all; each piece works on its own."""

from .candidates import CandidateSet, aimed_views, candidate_views, surface_anchors
from .route import order_views, ordered_plan
from .run import Budget, OptimizeResult, OptimizeSettings, PlanScore, default_ssd, optimize, score_plan
from .select import CoverageTable, Runs, Selection, greedy, remove_redundant, stable_runs
from .targets import ElementTargets, Rule, Targets

__all__ = ["Budget", "CandidateSet", "CoverageTable", "ElementTargets", "OptimizeResult", "OptimizeSettings", "PlanScore", "Rule",
           "Runs", "Selection", "Targets", "aimed_views", "candidate_views", "default_ssd", "greedy", "optimize", "order_views",
           "ordered_plan", "remove_redundant", "score_plan", "stable_runs", "surface_anchors"]
