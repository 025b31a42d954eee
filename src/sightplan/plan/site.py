"""Where a plan stands on Earth: the model's georeference and the take-off point, recorded in the plan's parameters
for the exports."""

from __future__ import annotations

from dataclasses import replace

from ..model.scene import Scene
from .types import Plan


def with_site(plan: Plan, scene: Scene, *, replace_takeoff: bool = False) -> Plan:
    """The plan with the model's georeference (unless it records its own) and its take-off point: the first
    mission's ground station, on the ground under it (the terrain's surface, else the model's base).

    A take-off point the plan records already (from a flight app's file) is kept unless ``replace_takeoff``: after
    the plan was split again, its first mission's ground station is the take-off point."""
    from ..geo import Georeference

    params = dict(plan.parameters)
    geo = Georeference.from_scene_metadata(scene.metadata)
    if geo is not None and "georeference" not in params:
        params["georeference"] = geo.to_dict()
    station = plan.missions[0].ground_station if plan.missions and plan.missions[0].ground_station else None
    if station is not None and (replace_takeoff or "takeoff_m" not in params):
        from .ground import ground_z

        ground = float(ground_z(scene, [station[:2]])[0])
        params["takeoff_m"] = [float(station[0]), float(station[1]), ground]
    return replace(plan, parameters=params)
