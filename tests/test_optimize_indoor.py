"""Indoor 360° plans: candidates in a box room with a column, counted and measured by hand (the room's walls are
planes, the column a square: distances in closed form); the selection against a cast of its own plan; every leg of
the walk measured again by sampling; a sealed partition that splits the walk; the checks, the exports, the command
line on the bundled Duplex, and bad input."""

from __future__ import annotations

import json

import numpy as np
import pytest
import trimesh

from sightplan.camera.models import EquirectangularCamera, PinholeCamera
from sightplan.errors import PlanError
from sightplan.evaluate import EvaluationSettings, evaluate
from sightplan.geo import Georeference
from sightplan.model.scene import ElementTable, Scene
from sightplan.optimize import (
    Budget,
    CoverageTable,
    IndoorSettings,
    OptimizeSettings,
    Storey,
    Targets,
    default_ssd,
    indoor_candidates,
    optimize,
    optimize_indoor,
    storey_levels,
    walk_order,
    walker_settings,
)
from sightplan.optimize.indoor import SSD_DISTANCE_M, TEMPLATE_NAME, open_path
from sightplan.plan.checks.feasibility import FlightSettings, check_plan
from sightplan.plan.checks.gate import default_settings, walked

PANO = EquirectangularCamera(512, 256, "test 360")
ROOM = (8.0, 6.0, 3.0)  # inside: x 0…8, y 0…6, z 0…3
WALL = 0.2
COLUMN = (3.8, 4.2, 2.8, 3.2)  # x0, x1, y0, y1: 0.4 m square in the middle
PARTITION = (3.9, 4.1)  # x0, x1 of a sealed wall across the room
CLEAR = 0.3
HEIGHT = 1.6
SPACING = 1.3


def _box(lo, hi) -> trimesh.Trimesh:
    lo, hi = np.asarray(lo, float), np.asarray(hi, float)
    m = trimesh.creation.box(hi - lo)
    m.apply_translation((lo + hi) / 2)
    return m


def room_scene(ceiling: float = ROOM[2], middle: str = "column", named: bool = True) -> Scene:
    """The room: floor and ceiling slabs (the ceiling belongs to the storey above, as in an IFC), four walls of its
    own each, and in the middle a column or a partition without a door."""
    X, Y, _ = ROOM
    parts = [("floor", "IfcSlab", "Level 1", _box((-WALL, -WALL, -WALL), (X + WALL, Y + WALL, 0))),
             ("ceiling", "IfcSlab", "Roof", _box((-WALL, -WALL, ceiling), (X + WALL, Y + WALL, ceiling + WALL))),
             ("south", "IfcWall", "Level 1", _box((-WALL, -WALL, 0), (X + WALL, 0, ceiling))),
             ("north", "IfcWall", "Level 1", _box((-WALL, Y, 0), (X + WALL, Y + WALL, ceiling))),
             ("west", "IfcWall", "Level 1", _box((-WALL, 0, 0), (0, Y, ceiling))),
             ("east", "IfcWall", "Level 1", _box((X, 0, 0), (X + WALL, Y, ceiling)))]
    if middle == "column":
        x0, x1, y0, y1 = COLUMN
        parts.append(("column", "IfcColumn", "Level 1", _box((x0, y0, 0), (x1, y1, ceiling))))
    else:
        parts.append(("partition", "IfcWall", "Level 1", _box((PARTITION[0], 0, 0), (PARTITION[1], Y, ceiling))))
    V, F, E = [], [], []
    offset = 0
    for k, (_, _, _, m) in enumerate(parts):
        V.append(m.vertices)
        F.append(m.faces + offset)
        E.append(np.full(len(m.faces), k))
        offset += len(m.vertices)
    table = ElementTable.build([p[0] for p in parts], name=[p[0] for p in parts], ifc_class=[p[1] for p in parts],
                               storey=[p[2] for p in parts] if named else None)
    return Scene.from_arrays(np.concatenate(V), np.concatenate(F), np.concatenate(E), table)


def clearance(P: np.ndarray, middle: str = "column") -> np.ndarray:
    """Distance from points inside the room, between floor and ceiling, to the model, in closed form: the nearest
    of the four wall planes, the floor, the ceiling, and the column's square (or the partition's slab)."""
    P = np.atleast_2d(P)
    x, y, z = P.T
    d = np.minimum.reduce([x, ROOM[0] - x, y, ROOM[1] - y, z, ROOM[2] - z])
    if middle == "column":
        x0, x1, y0, y1 = COLUMN
        dx = np.maximum.reduce([x0 - x, np.zeros_like(x), x - x1])
        dy = np.maximum.reduce([y0 - y, np.zeros_like(y), y - y1])
        inside = (dx == 0) & (dy == 0)
        d_col = np.where(inside, -np.minimum.reduce([x - x0, x1 - x, y - y0, y1 - y]), np.hypot(dx, dy))
        return np.minimum(d, d_col)
    return np.minimum(d, np.where((x > PARTITION[0]) & (x < PARTITION[1]), 0.0,
                                  np.minimum(np.abs(x - PARTITION[0]), np.abs(x - PARTITION[1]))))


def leg_clearance(a: np.ndarray, b: np.ndarray, middle: str = "column") -> float:
    """The least :func:`clearance` of 2,001 points along the leg a→b (every 4 mm on a 8 m leg)."""
    t = np.linspace(0.0, 1.0, 2001)[:, None]
    return float(clearance(a + t * (b - a), middle).min())


@pytest.fixture(scope="module")
def room() -> Scene:
    return room_scene()


def test_storeys_stand_on_their_slabs(room):
    """Level 1 stands on its floor slab's top (z = 0); the ceiling slab is the roof storey's floor (z = 3.2).
    Without storey names (a mesh) the levels are where upward faces cover 4 m² or more: the floor's top (53.76 m²),
    the tops of the walls and the column at 3.0 m (5.92 m²) and the ceiling slab's top at 3.2 m (53.76 m²); the
    last two, 0.2 m apart, are one level, the larger's. The candidates are the same 24."""
    assert storey_levels(room) == [Storey("Level 1", 0.0), Storey("Roof", ROOM[2] + WALL)]
    mesh = room_scene(named=False)
    assert storey_levels(mesh) == [Storey("level +0.00 m", 0.0), Storey("level +3.20 m", 3.2)]
    c = indoor_candidates(mesh, PANO, spacing_m=SPACING, height_m=HEIGHT, clearance_m=CLEAR)
    assert len(c.plan) == 24 and [m.name for m in c.plan.missions] == ["level +0.00 m"]


def test_candidates_stand_in_free_space_at_camera_height(room):
    """The grid, 1.3 m, centred on Level 1's extent (−0.2…8.2 × −0.2…6.2): x = 4 ± {0, 1.3, 2.6, 3.9} =
    0.1, 1.4, …, 7.9 and y = 3 ± {0, 1.3, 2.6} = 0.4, …, 5.6: 35 positions. x = 0.1 and 7.9 stand 0.1 m from a wall
    (10 positions), (4.0, 3.0) inside the column: 24 left. The roof storey's 35 positions (1.6 m over the ceiling
    slab) are outside."""
    c = indoor_candidates(room, PANO, spacing_m=SPACING, height_m=HEIGHT, clearance_m=CLEAR)
    C = c.plan.C_world
    assert len(c.plan) == 24
    assert c.dropped == {"outside the building": 35, "over no floor": 0, "nearer the model than the clearance": 11}
    assert np.allclose(C[:, 2], HEIGHT)
    assert ((C[:, 0] > 0) & (C[:, 0] < ROOM[0]) & (C[:, 1] > 0) & (C[:, 1] < ROOM[1])).all()
    assert clearance(C).min() >= CLEAR
    x0, x1, y0, y1 = COLUMN
    assert not ((C[:, 0] >= x0) & (C[:, 0] <= x1) & (C[:, 1] >= y0) & (C[:, 1] <= y1)).any()
    assert sorted(np.round(np.unique(C[:, 0]), 6).tolist()) == [1.4, 2.7, 4.0, 5.3, 6.6]
    assert sorted(np.round(np.unique(C[:, 1]), 6).tolist()) == [0.4, 1.7, 3.0, 4.3, 5.6]
    assert [(m.name, m.stop - m.start) for m in c.plan.missions] == [("Level 1", 24)]
    # a larger clearance drops the ring at 0.4 m from the south and north walls too: 24 − 2 × 5 = 14
    assert len(indoor_candidates(room, PANO, spacing_m=SPACING, height_m=HEIGHT, clearance_m=0.45).plan) == 14


def test_the_walk_orders_a_grid_and_never_passes_the_column(room):
    """LKH's open path through a row of points is the row in order; through a ring round the column, every leg
    keeps the clearance, measured again by sampling."""
    row = np.array([[x, 1.0, HEIGHT] for x in (5.0, 1.0, 3.0, 2.0, 4.0)])
    w = walk_order(room, row, CLEAR)
    assert w.order.tolist() in ([1, 3, 2, 4, 0], [0, 4, 2, 3, 1]) and len(w.cuts) == 0
    # the ring: legs across the column are forbidden, so the walk goes round
    ring = np.array([[4 + 1.2 * np.cos(t), 3 + 1.2 * np.sin(t), HEIGHT] for t in np.linspace(0, 2 * np.pi, 8,
                                                                                                  endpoint=False)])
    w = walk_order(room, ring[[0, 4, 2, 6, 1, 5, 3, 7]], CLEAR)
    P = ring[[0, 4, 2, 6, 1, 5, 3, 7]][w.order]
    assert len(w.cuts) == 0 and w.forbidden >= 4  # at least the four diameters
    assert min(leg_clearance(a, b) for a, b in zip(P[:-1], P[1:])) >= CLEAR
    # two points either side of the column and two by the north wall: the shortest walk (8.4 m) would cross the
    # column between the first two; the clear ones (10.5 m) go round it
    P = np.array([[2.7, 3.0, HEIGHT], [5.3, 3.0, HEIGHT], [1.4, 5.6, HEIGHT], [6.6, 5.6, HEIGHT]])
    w = walk_order(room, P, CLEAR)
    assert len(w.cuts) == 0 and w.forbidden == 1 and abs(w.order.tolist().index(0) - w.order.tolist().index(1)) > 1
    assert min(leg_clearance(a, b) for a, b in zip(P[w.order][:-1], P[w.order][1:])) >= CLEAR
    assert open_path(np.array([[0, 5], [5, 0]])) == [0, 1]
    # a group of every other point of the row (x = 1, 3, 5) is walked in one stretch, which the plain row is not
    w = walk_order(room, row, CLEAR, groups=[np.array([1, 2, 0])])
    where = np.sort(np.flatnonzero(np.isin(w.order, [0, 1, 2])))
    assert where.tolist() in ([0, 1, 2], [2, 3, 4]) and len(w.cuts) == 0


@pytest.fixture(scope="module")
def cache(tmp_path_factory):
    return tmp_path_factory.mktemp("cache")


STAGES_SEEN: list[str] = []


@pytest.fixture(scope="module")
def result(room, cache):
    """Through ``optimize`` itself: a 360° camera is planned indoors."""
    return optimize(room, PANO, Targets(k=2), settings=OptimizeSettings(scale=1.0, spacing_m=SPACING, cache_dir=cache),
                    progress=lambda stage, i, n: STAGES_SEEN.append(stage))


def test_progress_and_summary_speak_as_the_optimisers_do(result):
    from sightplan.optimize.run import STAGES

    assert set(STAGES_SEEN) == {"casting candidates", "selecting", "routing"}
    assert sorted(STAGES_SEEN, key=STAGES.index) == STAGES_SEEN  # reported in the declared order
    s = result.summary()
    assert {"frames", "missions", "batteries", "minutes", "targets", "met", "candidates", "removed",
            "unstable_frames", "blind_frames", "ok", "violations"} <= set(s)
    assert s["frames"] == len(result.plan) and s["storeys"] == ["Level 1"] and s["walks"] == 1
    assert [st["name"] for st in result.plan.parameters["storeys"]] == ["Level 1", "Roof"]  # the roof's all outside
    assert s["candidates_dropped"]["outside the building"] == 35
    json.dumps(s)  # plain numbers, for the web app's job record


def test_a_frame_budget_is_kept(room, cache):
    r = optimize_indoor(room, PANO, Targets(k=2), Budget(frames=2),
                        settings=IndoorSettings(scale=1.0, spacing_m=SPACING, cache_dir=cache))
    assert len(r.plan) == 2 and 1 <= r.n_met < 7 and r.plan.parameters["budget"]["frames"] == 2
    # two frames cannot hold a run of five that registers: the views are kept alone, reported below the floor
    assert r.stability_views == 0 and r.unstable_frames == 2
    # a walker stands 3 s per frame at 0.8 m/s: in 0.15 min (9 s) two frames 1.3 m or more apart take 7.6 s or more,
    # three take 13.6 s or more; the longest prefix of the greedy order that fits is kept
    r = optimize_indoor(room, PANO, Targets(k=2), Budget(minutes=0.15),
                        settings=IndoorSettings(scale=1.0, spacing_m=SPACING, cache_dir=cache))
    again = check_plan(room, r.plan, walker_settings(CLEAR))
    assert len(r.plan) == 2 and again.total_time_s <= 9.0 and again.ok


def test_the_selection_meets_the_walls_and_a_cast_of_its_plan_agrees(room, result):
    et = Targets(k=2).resolve(room, default_ssd(PANO, SSD_DISTANCE_M))
    walls = np.isin(room.elements.name, ["south", "north", "west", "east", "column"])
    assert result.met[walls].all()
    ev = evaluate(room, result.plan, EvaluationSettings(scale=1.0), cache_dir=False)  # no cache: cast again
    table = CoverageTable.build(ev.observations, et)
    assert (table.met(np.arange(len(result.plan))) == result.met).all()
    served = np.bincount(np.concatenate([table.serves(f) for f in range(len(result.plan))]), minlength=room.n_elements)
    assert (served[walls] >= 2).all()
    # every frame sees a target: the waste is none, counted again from the cast
    assert result.blind_frames == 0 and result.candidates_blind == 0
    assert (ev.metrics.frames.pixels_on_targets > 0).all()
    assert 2 <= len(result.plan) < result.candidates == 24


def test_the_plan_is_a_walk_the_checks_pass(room, result, tmp_path):
    plan = result.plan
    assert plan.parameters["template"] == TEMPLATE_NAME and walked(plan)
    assert default_settings(plan).aircraft is not None and default_settings(plan).vlos_radius_m is None
    report = check_plan(room, plan, walker_settings(CLEAR))  # the checks, run again independently
    assert report.ok, report.violations
    assert result.report.ok and result.summary()["violations"] == []
    assert np.allclose(plan.C_world[:, 2], HEIGHT) and clearance(plan.C_world).min() >= CLEAR
    for m in plan.missions:
        P = plan.C_world[m.start:m.stop]
        assert all(leg_clearance(a, b) >= CLEAR - 1e-9 for a, b in zip(P[:-1], P[1:]))
    assert [m.name for m in plan.missions] == ["Level 1"]
    assert list(plan.frame_names) == [f"pano_{i + 1:04d}" for i in range(len(plan))]
    # the map exports take it (a walked plan records no take-off point: one on the floor is given)
    from sightplan.export import export_plan

    geo = Georeference.from_origin(52.0, 5.0)
    for fmt in ("geojson", "kml"):
        (path,) = export_plan(plan, fmt, tmp_path / f"walk.{fmt}", geo, [1.0, 1.0, 0.0])
        assert path.stat().st_size > 0
    features = json.loads((tmp_path / "walk.geojson").read_text())["features"]
    frames = [f for ft in features if ft["properties"]["kind"] == "waypoint" for f in ft["properties"]["frames"]]
    assert frames == list(plan.frame_names)


def test_a_sealed_partition_splits_the_walk_in_two(tmp_path):
    """A wall across the room without a door: no leg may cross it, so the walk is two, one each side."""
    scene = room_scene(middle="partition")
    r = optimize_indoor(scene, PANO, Targets(k=2), settings=OptimizeSettings(scale=1.0, spacing_m=SPACING,
                                                                             cache_dir=tmp_path))
    plan = r.plan
    assert [m.name for m in plan.missions] == ["Level 1, walk 1", "Level 1, walk 2"]
    sides = [set(np.sign(plan.C_world[m.start:m.stop, 0] - 4.0).tolist()) for m in plan.missions]
    assert sorted(map(sorted, sides)) == [[-1.0], [1.0]]
    for m in plan.missions:
        P = plan.C_world[m.start:m.stop]
        assert all(leg_clearance(a, b, "partition") >= CLEAR for a, b in zip(P[:-1], P[1:]))
    assert check_plan(scene, plan, walker_settings(CLEAR)).ok and r.forbidden_legs > 0


def test_bad_input_is_one_clear_error(room):
    low = room_scene(ceiling=1.7)  # a camera 1.6 m up stands 0.1 m under the ceiling
    with pytest.raises(PlanError, match="no free storey space") as e:
        indoor_candidates(low, PANO)
    assert "nearer the model than the clearance" in str(e.value)
    with pytest.raises(PlanError, match="360°"):
        indoor_candidates(room, PinholeCamera(64, 48, 50.0, 50.0, 32.0, 24.0, "p"))
    with pytest.raises(PlanError, match="spacing"):
        indoor_candidates(room, PANO, spacing_m=0)
    with pytest.raises(PlanError, match="walker or rover"):
        optimize(room, PANO, flight=FlightSettings(safety_distance_m=10.0))
    from sightplan.plan.types import Plan

    with pytest.raises(PlanError, match="afresh"):
        optimize(room, PANO, start=Plan.build(PANO, np.eye(3)[None], [[1.0, 1.0, 1.6]]))
    from sightplan.optimize import OptimizeSettings

    with pytest.raises(PlanError, match="cluster"):
        optimize(room, PANO, flight=walker_settings(CLEAR), settings=OptimizeSettings(cluster="local:1"))


def test_the_command_line_plans_the_duplex_indoors(tmp_path):
    """`sightplan optimize sample --camera theta-z1`: a walked plan on the Duplex's two storeys that `sightplan
    check` passes as a walk."""
    from typer.testing import CliRunner

    from sightplan.cli.main import app
    from sightplan.plan.format import read_plan

    out = tmp_path / "indoor.json"
    runner = CliRunner()
    r = runner.invoke(app, ["optimize", "sample", "--camera", "theta-z1", "--scale", "0.05", "--spacing", "1.5",
                            "--no-cache", "-o", str(out)], env={"COLUMNS": "200"})
    assert r.exit_code == 0, r.output
    assert "0 frames that see no target" in r.output and "no violations" in r.output
    assert "template grid" not in r.output and "best template" not in r.output  # the templates are flown outside
    plan = read_plan(out)
    assert plan.parameters["template"] == TEMPLATE_NAME and plan.parameters["spacing_m"] == 1.5
    assert {m.name.split(",")[0] for m in plan.missions} == {"Level 1", "Level 2"}
    floors = {s["name"]: s["floor_z"] for s in plan.parameters["storeys"]}
    assert floors["Level 1"] == 0.0 and floors["Level 2"] == 3.1  # the slabs' tops
    assert set(np.round(plan.C_world[:, 2], 6)) == {1.6, 4.7}
    r = runner.invoke(app, ["check", str(out), "sample", "--json", str(tmp_path / "c.json")], env={"COLUMNS": "200"})
    assert r.exit_code == 0, r.output
    d = json.loads((tmp_path / "c.json").read_text())
    assert all(m["line_of_sight_ok"] is None and m["altitude_ok"] is None for m in d["missions"])


def test_a_walk_kilometres_long_keeps_its_costs_within_what_lkh_takes(room):
    """Sixty positions along 5 km either side of the room: in centimetres a forbidden leg (the walk through the room)
    would cost 3·10⁷, past what LKH takes (its 32-bit costs times 100); in coarser units the walk is found, each
    side in order, with the one cut across the room."""
    from sightplan.optimize.route import LKH_MAX_COST

    xs = np.random.default_rng(0).permutation(np.concatenate([np.linspace(-2500, -20, 30), np.linspace(30, 2500, 30)]))
    P = np.stack([xs, np.full(60, 3.0), np.full(60, HEIGHT)], axis=1)
    assert 5020 * 100 * 60 > LKH_MAX_COST
    w = walk_order(room, P, CLEAR)
    assert len(w.cuts) == 1
    x = xs[w.order]
    for side in (x[:w.cuts[0]], x[w.cuts[0]:]):
        assert (np.sign(side) == np.sign(side[0])).all() and len(set(np.sign(np.diff(side)).tolist())) == 1
