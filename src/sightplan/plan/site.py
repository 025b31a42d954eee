"""Where a plan stands on Earth: the model's georeference and the take-off point, recorded in the plan's parameters
for the exports."""

from __future__ import annotations

from dataclasses import replace

import numpy as np
from numpy.typing import ArrayLike, NDArray

from ..model.scene import Scene
from .types import Mission, Plan


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


def mission_takeoffs(plan: Plan, takeoff_m: ArrayLike, per_mission: bool = True) -> list[NDArray[np.float64]]:
    """(3,) model-frame take-off point of each mission (``plan.missions``, or the whole plan as one): under its ground
    station when ``per_mission`` and it has one, else ``takeoff_m``.

    ``takeoff_m`` is the ground under the first mission's station (:func:`~sightplan.plan.site.with_site`), and
    stations stand at one height above the ground, so a station's take-off height is ``takeoff_m``'s plus its
    height above the first station's (0 on flat ground)."""
    T = np.asarray(takeoff_m, float).reshape(3)
    missions = plan.missions or (Mission("mission 1", 0, len(plan)),)

    def station(m: Mission) -> NDArray[np.float64] | None:
        gs = None if m.ground_station is None else np.asarray(m.ground_station, float).reshape(-1)
        return gs if gs is not None and gs.shape == (3,) and np.isfinite(gs).all() else None

    first = station(missions[0])
    out = []
    for m in missions:
        gs = station(m)
        if per_mission and gs is not None:
            out.append(np.array([gs[0], gs[1], T[2] + (gs[2] - first[2] if first is not None else 0.0)]))
        else:
            out.append(T.copy())
    return out
