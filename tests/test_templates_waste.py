"""Templates that waste nothing: every frame looks at a target, no waypoint below the minimum height, the terrain is
ground (not building), and an export of a plan that fails its checks is refused."""

from __future__ import annotations

import json
import math

import numpy as np
import pytest
import trimesh
from typer.testing import CliRunner

from sightplan.camera.catalogue import get_camera
from sightplan.engines import make_engine
from sightplan.geometry.poses import R_from_gimbal
from sightplan.model.scene import ElementTable, Scene
from sightplan.plan.checks import point_distances
from sightplan.plan.checks.feasibility import FlightSettings, check_plan, plan_flights
from sightplan.plan.ground import ground_z, targets_only
from sightplan.plan.site import with_site
from sightplan.plan.templates import bridge, facade_grid, lawnmower, orbit
from sightplan.plan.types import Plan

P4P = get_camera("p4p")  # tan(hfov/2) = 0.75, tan(vfov/2) = 0.5
TERRAIN_TOP = 1.0
HOUSE = (12.0, 8.0, 7.0)  # x, y, z size of the house, from (0, 0, 0): its base 1 m below the terrain's top


def _box(size, corner) -> trimesh.Trimesh:
    return trimesh.creation.box(size, trimesh.transformations.translation_matrix(np.add(corner, np.divide(size, 2))))


@pytest.fixture(scope="module")
def terrain() -> Scene:
    """A 12 × 8 × 7 m house (a target) sunk 1 m into an 80 × 80 m terrain block from z = −3 to 1 (IfcSite, an
    occluder), and a 1 m crate (IfcFurnishingElement, an occluder) on the terrain 30 m off the house."""
    parts = [(_box(HOUSE, (0, 0, 0)), "house", "IfcWall", True),
             (_box((80, 80, 4), (-34, -36, -3)), "terrain", "IfcSite", False),
             (_box((1, 1, 1), (-30, 30, TERRAIN_TOP)), "crate", "IfcFurnishingElement", False)]
    V, F, E, offset = [], [], [], 0
    for k, (m, *_rest) in enumerate(parts):
        V.append(m.vertices)
        F.append(m.faces + offset)
        E.append(np.full(len(m.faces), k))
        offset += len(m.vertices)
    table = ElementTable.build([p[1] for p in parts], name=[p[1] for p in parts], ifc_class=[p[2] for p in parts],
                               is_target=[p[3] for p in parts])
    return Scene.from_arrays(np.concatenate(V), np.concatenate(F), np.concatenate(E), table)


@pytest.fixture(scope="module")
def duplex() -> Scene:
    from sightplan.model.load import load_model

    return load_model("sample")[0]


def blind_frames(scene: Scene, plan: Plan) -> list[int]:
    """Frames whose low-resolution Embree view holds no target element: independent of the templates' own test."""
    out = []
    with make_engine("embree", scene) as eng:
        for i in range(len(plan)):
            ids, _ = eng.element_map(plan.camera_of(i), plan.R_world_camera[i], plan.C_world[i], scale=0.05)
            seen = np.unique(ids[ids >= 0])
            if not scene.targets[seen].any():
                out.append(i)
    return out


def templates(scene: Scene) -> dict[str, Plan]:
    lo, hi = targets_only(scene).bounds()
    mid_y = (lo[1] + hi[1]) / 2
    return {
        "facade box": facade_grid(scene, P4P, 8.0),
        "facade outline": facade_grid(scene, P4P, 8.0, footprint="outline"),
        "orbit": orbit(scene, P4P, safety_distance_m=8.0),
        "lawnmower": lawnmower(scene, P4P, gsd_m=0.005, oblique_pitch_deg=-60),
        "bridge": bridge(scene, P4P, [[lo[0] - 2, mid_y], [hi[0] + 2, mid_y]], 10.0, under_deck=False),
    }


@pytest.mark.parametrize("which", ["terrain", "duplex"])
def test_every_template_looks_at_targets_and_flies_above_the_minimum_height(which, request):
    scene = request.getfixturevalue(which)
    for name, plan in templates(scene).items():
        above = plan.C_world[:, 2] - ground_z(scene, plan.C_world)
        assert above.min() >= 2.0 - 1e-6, (name, above.min())
        assert blind_frames(scene, plan) == [], name
        assert plan.parameters["min_height_m"] == 2.0


def test_facade_corner_columns_turn_inward():
    box = Scene.from_arrays(*(lambda m: (m.vertices, m.faces, np.zeros(len(m.faces))))(_box((20, 10, 8), (0, 0, 0))),
                            ElementTable.build(["box"]))
    plan = facade_grid(box, P4P, 10.0)
    fwd = plan.R_world_camera[:, :, 2]
    south_west = np.isclose(plan.C_world[:, 0], 0) & np.isclose(plan.C_world[:, 1], -10) & (plan.C_world[:, 2] <= 8)
    # the south side's west column at (0, −10) looks north-east, toward the side's middle: heading 45°
    np.testing.assert_allclose(fwd[south_west], np.tile([math.sqrt(0.5), math.sqrt(0.5), 0], (south_west.sum(), 1)),
                               atol=1e-12)
    assert plan.parameters["dropped_frames"] == 0


def test_duplex_demo_grid_drops_nothing_and_starts_above_the_ground(duplex):
    plan = facade_grid(duplex, P4P, 8.0, 0.8)
    base = duplex.bounds()[0][2]  # −1.55 m: the Duplex's footings, below its ground
    assert base == pytest.approx(-1.55, abs=0.01)
    assert plan.C_world[:, 2].min() == pytest.approx(0.0 + 2.0)  # 2 m above its entrance doors' sills (z = 0)
    assert plan.parameters["dropped_frames"] == 0


def test_terrain_is_ground_not_building(terrain):
    g = 8.0
    plan = facade_grid(terrain, P4P, g)
    house = targets_only(terrain)
    assert house.bounds().tolist() == [[0, 0, 0], list(HOUSE)]  # neither the terrain nor the crate
    top = plan.C_world[:, 2] > HOUSE[2] + 1e-9
    # every level waypoint stands exactly g from the house's walls (not 13 m: the terrain's box is not the house's)
    np.testing.assert_allclose(point_distances(house, plan.C_world[~top]), g, rtol=1e-9)
    # the bottom row is 2 m above the terrain's top, not at the house's sunk base nor at the block's bottom
    assert plan.C_world[:, 2].min() == pytest.approx(TERRAIN_TOP + 2.0)
    # layers from 3 to 7 m, s_v = 2·8·0.5·0.2 = 1.6 m: ceil(4/1.6) + 1 = 4; plus the top row: 5 per column.
    # s_h = 2·8·0.75·0.2 = 2.4 m: ceil(12/2.4) + 1 = 6 and ceil(8/2.4) + 1 = 5 columns
    assert [m.stop - m.start for m in plan.missions] == [6 * 5, 5 * 5, 6 * 5, 5 * 5]
    report = plan_flights(terrain, plan, FlightSettings(safety_distance_m=g, position_error_m="none"))
    assert report.ok, report.violations
    sited = with_site(report.plan, terrain, replace_takeoff=True)
    assert sited.parameters["takeoff_m"][2] == pytest.approx(TERRAIN_TOP)  # on the terrain, not under it
    # the pilot stands 1.5 m above the terrain at the south-west corner of the grid's region
    np.testing.assert_allclose(report.plan.missions[0].ground_station, [-g, -g, TERRAIN_TOP + 1.5])


def test_check_flags_waypoints_and_legs_below_the_minimum_height(terrain):
    # one mission on the house's south side, 8 m out: 3 m, 0.5 m (under the terrain's top) and 5 m above z = 0
    C = np.array([[2.0, -8.0, 3.0], [6.0, -8.0, 0.5], [10.0, -8.0, 5.0]])
    plan = Plan.build(P4P, R_from_gimbal(np.zeros(3), np.zeros(3)), C)
    report = check_plan(terrain, plan, FlightSettings(safety_distance_m=5.0, aircraft=None, position_error_m="none"))
    assert "waypoint 1 is less than 2 m above the ground (lowest -0.50 m)" in report.violations
    np.testing.assert_allclose(report.height_above_ground_m, [2.0, -0.5, 4.0])
    assert report.missions[0].height_ok is False
    # over a 2 m high ridge between two waypoints 3 m above the terrain, the straight leg dips to 1 m above it
    ridge = Scene.from_arrays(*_stack(_box((60, 60, 4), (-30, -30, -3)), _box((1, 60, 2), (-0.5, -30, 1))),
                              ElementTable.build(["terrain", "ridge"], ifc_class=["IfcSite", "IfcGeographicElement"],
                                                 is_target=[False, False]))
    leg = Plan.build(P4P, R_from_gimbal(np.zeros(2), np.zeros(2)), [[-10.0, 0.0, 4.0], [10.0, 0.0, 4.0]])
    found = check_plan(ridge, leg, FlightSettings(safety_distance_m=0.5, aircraft=None, vlos_radius_m=None,
                                                    position_error_m="none")).violations
    assert found == ("leg 0→1 comes down to +1.00 m above the ground (minimum 2 m)",)


def _stack(*meshes):
    m = trimesh.util.concatenate(meshes)
    counts = [len(x.faces) for x in meshes]
    return m.vertices, m.faces, np.repeat(np.arange(len(meshes)), counts)


def test_orbit_defaults_from_the_targets_box(terrain):
    plan = orbit(terrain, P4P, safety_distance_m=8.0)
    # radius: half the house's diagonal, √(12² + 8²)/2 = 7.21 m, plus 8 m, over cos(180°/21) for the 21 frames a ring
    # (eq. 11: 2·0.75·0.2 = 0.3 rad a step, ceil(2π/0.3) = 21) so the legs keep 8 m from the corners; centred on (6, 4)
    r = (math.hypot(12, 8) / 2 + 8) / math.cos(math.pi / 21)
    np.testing.assert_allclose(np.hypot(plan.C_world[:, 0] - 6, plan.C_world[:, 1] - 4), r)
    # heights: 2 m above the terrain (3 m) to 8 m above the roof (15 m), at most 2·r·0.5·0.2 = 3.08 m apart: 5 rings
    heights = sorted(set(np.round(plan.C_world[:, 2], 9)))
    np.testing.assert_allclose(heights, np.linspace(3, 15, 5))
    assert len(plan.missions) == 5 and len(plan) == 5 * 21
    assert point_distances(targets_only(terrain), plan.C_world).min() >= 8.0
    with pytest.raises(Exception, match="below the minimum height"):
        orbit(terrain, P4P, [30.0], [2.5])


def _cli(*args):
    from sightplan.cli.main import app

    return CliRunner().invoke(app, list(args), env={"COLUMNS": "200"})


def test_export_refuses_a_plan_that_fails_its_checks(tmp_path):
    plan_file = tmp_path / "plan.json"
    res = _cli("plan", "facade", "sample", "--safety-distance", "8", "-o", str(plan_file))
    assert res.exit_code == 0, res.output
    assert "dropped no frame" in res.output  # nothing of the demo grid looks away from the Duplex
    d = json.loads(plan_file.read_text())
    assert d["parameters"]["checks"]["violations"] == []
    takeoff_z = d["parameters"]["takeoff_m"][2]
    res = _cli("export", str(plan_file), "--format", "geojson", "-o", str(tmp_path / "ok.geojson"))
    assert res.exit_code == 0, res.output
    assert (tmp_path / "ok.geojson").exists()
    # frame 5 lowered to 0.5 m above the take-off point: refused, one error line, nothing written
    d["frames"][5]["position"][2] = takeoff_z + 0.5
    d["waypoints"][5][2] = takeoff_z + 0.5
    bad = tmp_path / "low.json"
    bad.write_text(json.dumps(d))
    out = tmp_path / "low.geojson"
    res = _cli("export", str(bad), "--format", "geojson", "-o", str(out))
    assert res.exit_code == 2
    errors = [line for line in res.output.splitlines() if line.startswith("error:")]
    assert len(errors) == 1
    assert "waypoint 5 is less than 2 m above the take-off point (lowest +0.50 m)" in " ".join(res.output.split())
    assert not out.exists()
    # with --model the plan is checked again: the same waypoint is too low above the ground as well
    res = _cli("export", str(bad), "--format", "geojson", "-o", str(out), "--model", "sample")
    assert res.exit_code == 2 and not out.exists()
    assert "waypoint 5 is less than 2 m above the ground" in " ".join(res.output.split())
    res = _cli("export", str(bad), "--format", "geojson", "-o", str(out), "--force")
    assert res.exit_code == 0, res.output
    assert out.exists() and "despite" in res.output


def test_export_refuses_recorded_violations(tmp_path):
    plan_file = tmp_path / "far.json"
    # a 30 m VLOS radius, the missions not split for it: the long sides' far ends are out of sight of the pilot;
    # the plan records it
    res = _cli("plan", "facade", "sample", "--safety-distance", "8", "--vlos-radius", "30", "--aircraft", "none",
               "--no-split", "-o", str(plan_file))
    assert res.exit_code == 0, res.output
    recorded = json.loads(plan_file.read_text())["parameters"]["checks"]["violations"]
    assert recorded and "VLOS radius" in recorded[0]
    out = tmp_path / "far.kml"
    # (not split, its missions have no ground station: the take-off point is given)
    res = _cli("export", str(plan_file), "--format", "kml", "-o", str(out), "--takeoff", "0,-30,-1.55")
    assert res.exit_code == 2 and not out.exists()
    assert recorded[0] in " ".join(res.output.split())


def test_web_export_refuses_a_plan_that_fails_its_checks(tmp_path):
    pytest.importorskip("fastapi")
    pytest.importorskip("httpx")
    from fastapi.testclient import TestClient

    from sightplan.model.load import sample_model_path
    from sightplan.web.app import create_app
    from sightplan.web.config import ServerConfig
    from web_support import wait_job

    with TestClient(create_app(ServerConfig(data_dir=tmp_path / "data", workers=1))) as client:
        project = client.post("/api/projects", json={"name": "Duplex"}).json()["id"]
        with open(sample_model_path(), "rb") as fh:
            r = client.post(f"/api/projects/{project}/models", files={"file": ("Duplex A.ifc", fh)})
        assert wait_job(client, r.json()["job"]["id"])["status"] == "done"
        model = r.json()["model"]["id"]
        r = client.post(f"/api/projects/{project}/plans",
                        json={"model_id": model, "template": "facade", "safety_distance_m": 8})
        assert r.status_code == 201, r.text
        good = r.json()["id"]
        export = f"/api/projects/{project}/plans/{{}}/versions/1/export"
        assert client.get(export.format(good), params={"format": "geojson"}).status_code == 200
        d = client.get(f"/api/projects/{project}/plans/{good}/versions/1").json()
        d["frames"][5]["position"][2] = d["parameters"]["takeoff_m"][2] + 0.5
        r = client.post(f"/api/projects/{project}/plans/upload", data={"model_id": str(model)},
                        files={"file": ("low.json", json.dumps(d).encode())})
        assert r.status_code == 201, r.text
        low = r.json()["id"]
        r = client.get(export.format(low), params={"format": "geojson"})
        assert r.status_code == 409
        assert "waypoint 5 is less than 2 m above the ground" in r.json()["detail"]
        r = client.get(export.format(low), params={"format": "geojson", "force": "true"})
        assert r.status_code == 200 and json.loads(r.content)["type"] == "FeatureCollection"


def test_a_one_frame_mission_joins_its_neighbour_and_batteries_are_counted_by_time():
    from sightplan.plan.checks.battery import Aircraft, split_by_battery
    from sightplan.plan.checks.feasibility import battery_count, merge_single_frames
    from sightplan.plan.types import Mission

    C = np.array([[float(x), -20.0, 5.0] for x in range(6)])
    plan = Plan.build(P4P, R_from_gimbal(np.zeros(6), np.zeros(6)), C,
                      missions=(Mission("ring 1 (1)", 0, 3, (0.0, 0.0, 1.5)), Mission("ring 1 (2)", 3, 4, (9.0, 0.0, 1.5)),
                                Mission("ring 2", 4, 6, (9.0, 0.0, 1.5))))
    merged = merge_single_frames(plan)
    # the one-frame part flies from the same station as the next mission: one flight of frames 3–5
    assert [(m.name, m.start, m.stop) for m in merged.missions] == [("ring 1 (1)", 0, 3), ("ring 2", 3, 6)]
    # a battery of 100 s usable: a 1 m leg at 1 m/s with 1 m/s² takes 1 + 1 = 2 s, a d m leg d + 1 s, a photo 10 s.
    # Nine frames 1 m apart, 20 to 28 m from the station: k frames from d m away take (d + 1) + 2(k − 1) +
    # (d + k) + 10k s: 4 from 20 m 91 s (5: 104 s), 4 from 24 m 99 s, then frame 8 alone
    ac = Aircraft("slow", 1.0, 1.0, 1.0, flight_time_s=100.0, capture_s=10.0, reserve=0.0)
    line = Plan.build(P4P, R_from_gimbal(np.zeros(9), np.zeros(9)),
                      np.array([[0.0, float(y), 0.0] for y in range(9)]) + [0.0, 20.0, 0.0])
    split, times = split_by_battery(line, np.zeros(3), ac)
    # the one-frame tail takes frames from the part before it: 3 from 24 m (86 s) and 2 from 27 m (79 s)
    assert [m.stop - m.start for m in split.missions] == [4, 3, 2]
    assert [round(t.time_s) for t in times] == [91, 86, 79]
    assert all(t.time_s <= 100.0 for t in times)
    # three flights of 91, 86 and 79 s: each needs its own battery; two 40 s flights share one
    assert battery_count(times, ac) == 3
    assert battery_count([type("M", (), {"time_s": 40.0, "start": 0, "stop": 1})()] * 2, ac) == 1


def test_runaway_parameters_are_refused_before_anything_is_built():
    """The report's runaway requests: an orbit every 0.0001° and a facade grid at 0.5 m with 99 % overlap."""
    from sightplan.camera.catalogue import get_camera
    from sightplan.errors import PlanError
    from sightplan.model.load import load_model
    from sightplan.plan.templates import facade_grid, orbit

    scene, _ = load_model("sample")
    cam = get_camera("p4p")
    with pytest.raises(PlanError, match="3,600,000 frames, more than the 100,000"):
        orbit(scene, cam, [20.0], [6.0], step_deg=0.0001)
    with pytest.raises(PlanError, match="facade grid at 0.5 m with 99% overlap would make"):
        facade_grid(scene, cam, 0.5, overlap=0.99)
