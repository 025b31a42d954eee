"""Capture plans: the Plan type and its JSON format. Loading a plan or pose file of any format is
:func:`sightplan.plan.load.load_plan` (the readers are in :mod:`sightplan.formats`)."""

from ..geometry.poses import R_from_gimbal, gimbal_from_R
from .format import plan_from_dict, plan_to_dict, read_plan, write_plan
from .types import Mission, Plan

__all__ = [
    "Mission",
    "Plan",
    "R_from_gimbal",
    "gimbal_from_R",
    "plan_from_dict",
    "plan_to_dict",
    "read_plan",
    "write_plan",
]
