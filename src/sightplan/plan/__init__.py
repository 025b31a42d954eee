"""Capture plans: the Plan type, its JSON format, and imports of flown captures."""

from ..geometry.poses import R_from_gimbal, gimbal_from_R
from .format import plan_from_dict, plan_to_dict, read_plan, write_plan
from .io_colmap import read_colmap
from .io_csv import read_csv_plan
from .io_opensfm import read_opensfm
from .load import PLAN_FORMATS, PlanFormat, apply_similarity, load_plan
from .types import Mission, Plan

__all__ = [
    "PLAN_FORMATS",
    "Mission",
    "Plan",
    "PlanFormat",
    "R_from_gimbal",
    "apply_similarity",
    "gimbal_from_R",
    "load_plan",
    "plan_from_dict",
    "plan_to_dict",
    "read_colmap",
    "read_csv_plan",
    "read_opensfm",
    "read_plan",
    "write_plan",
]
