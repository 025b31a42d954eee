"""``with_site``: the model's georeference and the take-off point recorded on a plan for its exports."""

from __future__ import annotations

from dataclasses import replace

import pytest

from sightplan.camera.catalogue import get_camera
from sightplan.geo import Georeference
from sightplan.model.load import load_model
from sightplan.plan.site import with_site
from sightplan.plan.templates import orbit
from sightplan.plan.types import Mission


def test_takeoff_is_the_first_ground_station_on_the_ground_and_a_recorded_one_is_kept():
    scene, _ = load_model("sample")
    base_z = 0.0  # the Duplex's ground: its entrance doors' sills, not its footings' base (−1.55 m)
    plan = orbit(scene, get_camera("p4p"), [25], [8.0], step_deg=30)
    plan = replace(plan, missions=(Mission("ring", 0, len(plan), ground_station=(-20.0, 5.0, 1.5)),))
    sited = with_site(plan, scene)
    assert sited.parameters["takeoff_m"] == pytest.approx([-20.0, 5.0, base_z])
    assert sited.parameters["georeference"] == Georeference.from_scene_metadata(scene.metadata).to_dict()  # the model's
    recorded = replace(plan, parameters={**plan.parameters, "takeoff_m": [1.0, 2.0, 3.0]})
    assert with_site(recorded, scene).parameters["takeoff_m"] == [1.0, 2.0, 3.0]  # a flight app's own take-off
    assert with_site(recorded, scene, replace_takeoff=True).parameters["takeoff_m"] == pytest.approx([-20.0, 5.0, base_z])
    no_station = replace(plan, missions=(Mission("ring", 0, len(plan)),))
    assert "takeoff_m" not in with_site(no_station, scene).parameters
