"""Bridge template, facade grid on the real outline, lawn-mower double grid: counts and geometry by hand."""

from __future__ import annotations

import math

import numpy as np
import pytest
import trimesh

from sightplan.camera.catalogue import get_camera
from sightplan.errors import PlanError
from sightplan.model.scene import ElementTable, Scene
from sightplan.plan.checks import point_distances, segment_distances
from sightplan.plan.templates import bridge, facade_grid, lawnmower
from sightplan.plan.templates.facade import footprint_outlines

P4P = get_camera("p4p")  # tan(hfov/2) = 0.75, tan(vfov/2) = 0.5


def box(size, corner=(0.0, 0.0, 0.0)) -> trimesh.Trimesh:
    return trimesh.creation.box(size, trimesh.transformations.translation_matrix(np.add(corner, np.divide(size, 2))))


def scene_of(*meshes: trimesh.Trimesh) -> Scene:
    m = trimesh.util.concatenate(meshes)
    return Scene.from_arrays(m.vertices, m.faces, np.zeros(len(m.faces)), ElementTable.build(["model"]))


def heading_of(plan, rows) -> np.ndarray:
    fwd = plan.R_world_camera[rows][:, :, 2]
    return np.degrees(np.arctan2(fwd[:, 0], fwd[:, 1])) % 360.0


# ----------------------------------------------------------------------------------------------- bridge

def bridge_scene(pier_under_axis: bool = False) -> Scene:
    """A 60 × 10 m deck, 2 m thick, underside at z = 8, on two piers at x 28–32 (under its edges, or one under the axis)."""
    deck = box((60, 10, 2), (0, -5, 8))
    if pier_under_axis:
        return scene_of(deck, box((4, 2, 8), (28, -1, 0)))
    return scene_of(deck, box((4, 2, 8), (28, 3, 0)), box((4, 2, 8), (28, -5, 0)))


def test_bridge_straight_axis_by_hand():
    plan = bridge(bridge_scene(), P4P, [[0, 0], [60, 0]], offset_m=15, clearance_below_m=2.5)
    # side passes: s_h = 2·15·0.75·0.2 = 4.5 m → ceil(60/4.5) + 1 = 15 frames per pass;
    # s_v = 2·15·0.5·0.2 = 3 m from the minimum height (2 m above the ground, the piers' base) to the model's 10 m
    # top → ceil(8/3) + 1 = 4 layers, 8/3 m apart; each sees the deck (a level view from 2 m reaches 2 + 7.5 m at 15 m)
    # under the deck: 2·2.5·0.5·0.2 = 0.5 m → 60/0.5 + 1 = 121 frames at 8 − 2.5 = 5.5 m
    sizes = [m.stop - m.start for m in plan.missions]
    assert sizes == [15] * 8 + [121]
    assert len(plan) == 241
    assert plan.parameters["template"] == "bridge"
    layers = [2, 2 + 8 / 3, 2 + 16 / 3, 10]
    assert plan.parameters["heights_m"] == pytest.approx(layers)
    assert plan.parameters["deck_z"] == pytest.approx(8.0)
    assert plan.parameters["under_deck_z"] == pytest.approx(5.5)
    assert plan.parameters["dropped_frames"] == 0
    C = plan.C_world
    # left (y = +15) bottom → top, then right (y = −15) top → bottom, then under the deck; a snake along x
    expect_z = layers + layers[::-1] + [5.5]
    expect_y = [15] * 4 + [-15] * 4 + [0]
    for j, m in enumerate(plan.missions):
        part = C[m.start:m.stop]
        np.testing.assert_allclose(part[:, 1], expect_y[j])
        np.testing.assert_allclose(part[:, 2], expect_z[j])
        np.testing.assert_allclose([part[0, 0], part[-1, 0]], [0, 60] if j % 2 == 0 else [60, 0], atol=1e-9)
        assert np.abs(np.diff(part[:, 0])).max() <= (4.5 if j < 8 else 0.5) + 1e-9
    fwd = plan.R_world_camera[:, :, 2]
    np.testing.assert_allclose(fwd[:60], np.tile([0, -1, 0], (60, 1)), atol=1e-12)  # left side looks south at the axis
    np.testing.assert_allclose(fwd[60:120], np.tile([0, 1, 0], (60, 1)), atol=1e-12)  # right side looks north
    np.testing.assert_allclose(fwd[120:], np.tile([0, 0, 1], (121, 1)), atol=1e-12)  # under the deck: straight up
    # heading east (90°) tilted up by 90°: the camera's +Y (image down) is forward × right = (1, 0, 0), ahead
    np.testing.assert_allclose(plan.R_world_camera[120:, :, 1], np.tile([1, 0, 0], (121, 1)), atol=1e-12)
    # the under-deck pass keeps exactly the clearance: 2.5 m to the deck's underside, 3 m to the piers at |y| ≥ 3
    under = C[120:]
    assert segment_distances(bridge_scene(), under[:-1], under[1:]).min() == pytest.approx(2.5)


def test_bridge_bent_axis_mitres_the_passes():
    # axis east 40 m then north 30 m; offset 10 m: the left (inside) pass runs (0,10)→(30,10)→(30,30): 30 + 20 = 50 m,
    # the right (outside) one (0,−10)→(50,−10)→(50,30): 50 + 40 = 90 m. s_h = 2·10·0.75·0.2 = 3 m:
    # ceil(50/3) + 1 = 18 and 90/3 + 1 = 31 frames
    # (the deck runs east only: frames on the northward piece that see none of it are kept here, drop_blind=False)
    plan = bridge(bridge_scene(), P4P, [[0, 0, 3], [40, 0, 3], [40, 30, 3]], offset_m=10, heights_m=[5], under_deck=False,
                  drop_blind=False)
    assert [m.stop - m.start for m in plan.missions] == [18, 31]
    left, right = (plan.C_world[m.start:m.stop] for m in plan.missions)
    on_first = np.isclose(left[:, 1], 10) & (left[:, 0] < 30 - 1e-9)
    on_second = np.isclose(left[:, 0], 30) & (left[:, 1] > 10 + 1e-9)
    assert on_first.sum() + on_second.sum() == 18  # every left frame on one of the two mitred pieces
    # frames every 50/17 m: the first 11 (up to 29.4 m along) lie on the first piece looking south, the rest look east
    assert on_first.sum() == 11
    np.testing.assert_allclose(heading_of(plan, np.flatnonzero(on_first)), 180.0)
    np.testing.assert_allclose(heading_of(plan, np.flatnonzero(on_second)), 90.0)
    # right pass is flown back (second pass of the snake): from (50, 30) down to (50, −10), then west to (0, −10)
    np.testing.assert_allclose(right[0, :2], [50, 30])
    np.testing.assert_allclose(right[-1, :2], [0, -10])
    r_heading = heading_of(plan, np.arange(18, 49))
    np.testing.assert_allclose(r_heading[np.isclose(right[:, 0], 50) & (right[:, 1] > -10 + 1e-9)], 270.0)
    np.testing.assert_allclose(r_heading[np.isclose(right[:, 1], -10) & (right[:, 0] < 40 - 1e-9)], 0.0)
    # distance to the axis: exactly 10 m on the inside; outside at least 10 m, most for the frame 51 m along,
    # (50, −9), 1 m past the mitre corner: √(10² + 9²) from the axis's bend at (40, 0)
    axis = np.array([[0, 0, 5], [40, 0, 5], [40, 30, 5]], float)
    seg = np.diff(axis, axis=0)

    def to_axis(p):
        t = np.clip(np.einsum("ikj,kj->ik", p[:, None, :] - axis[:-1], seg) / (seg ** 2).sum(1), 0, 1)
        return np.linalg.norm(p[:, None, :] - (axis[:-1] + t[..., None] * seg), axis=2).min(axis=1)

    np.testing.assert_allclose(to_axis(left), 10.0)
    assert to_axis(right).min() == pytest.approx(10.0)
    assert to_axis(right).max() == pytest.approx(math.hypot(10, 9))


def test_bridge_under_deck_refused_where_it_cannot_be_placed():
    with pytest.raises(PlanError, match=r"no room for the under-deck pass 28\.0 m along the axis"):
        bridge(bridge_scene(pier_under_axis=True), P4P, [[0, 0], [60, 0]], 15, clearance_below_m=2.5)
    # a deck_z inside the deck puts the pass at 6.5 m, 1.5 m under the underside
    with pytest.raises(PlanError, match="comes 1.50 m from the model"):
        bridge(bridge_scene(), P4P, [[0, 0], [60, 0]], 15, clearance_below_m=2.5, deck_z=9.0)
    with pytest.raises(PlanError, match="nothing of the model above the axis"):
        bridge(bridge_scene(), P4P, [[0, 30], [60, 30]], 15)
    # the given underside is used as is; without the under-deck pass the pier is no obstacle
    assert bridge(bridge_scene(), P4P, [[0, 0], [60, 0]], 15, clearance_below_m=2.5, deck_z=8.0).parameters[
        "under_deck_z"] == pytest.approx(5.5)
    # 8 side passes (4 layers from the 2 m minimum height to the 10 m top, both sides) of 15 frames
    assert len(bridge(bridge_scene(pier_under_axis=True), P4P, [[0, 0], [60, 0]], 15, under_deck=False)) == 120


@pytest.mark.parametrize(("axis", "offset", "match"), [
    ([[0, 0]], 15, "at least two"),
    ([[0, 0], [0, 0, 0]], 15, "points of one length"),
    ([[0, 0], [10, 0], [10, 0]], 15, "point 2 repeats"),
    ([[0, 0], [60, 0]], 0, "positive"),
    ([[0, 0], [60, 0]], -5, "positive"),
    ([[0, 0], [60, 0], [0, 1]], 5, "turns by"),
    ([[0, 0], [60, 0], [60, 4], [0, 4]], 3, "too short"),
])
def test_bridge_refuses_bad_input(axis, offset, match):
    with pytest.raises(PlanError, match=match):
        bridge(bridge_scene(), P4P, axis, offset, under_deck=False)


def test_bridge_needs_a_pinhole_camera():
    with pytest.raises(PlanError, match="pinhole"):
        bridge(bridge_scene(), get_camera("theta-z1"), [[0, 0], [60, 0]], 15)


# ------------------------------------------------------------------------------------ facade on the outline

def rotated_box_scene(deg: float = 30.0) -> Scene:
    b = box((20, 10, 8))
    b.apply_transform(trimesh.transformations.rotation_matrix(math.radians(deg), [0, 0, 1], [10, 5, 0]))
    return scene_of(b)


def test_outline_of_a_rotated_box_and_an_l():
    (ring,), excess, _ = footprint_outlines(rotated_box_scene())
    assert excess == 0.0
    assert len(ring) == 4
    sides = np.linalg.norm(np.roll(ring, -1, axis=0) - ring, axis=1)
    np.testing.assert_allclose(sorted(sides), [10, 10, 20, 20])
    (ring,), _, _ = footprint_outlines(scene_of(box((30, 10, 6)), box((10, 20, 6), (0, 10, 0))), gap_m=0.25, detail_m=0.05)
    # the L's six corners anticlockwise (the west side's two collinear halves merged); area 30·10 + 10·20
    assert len(ring) == 6
    x, y = ring.T
    assert 0.5 * (x * np.roll(y, -1) - np.roll(x, -1) * y).sum() == pytest.approx(500.0)


def test_facade_outline_keeps_g_to_the_walls_of_a_rotated_box():
    g = 10.0
    scene = rotated_box_scene()
    top = scene.bounds()[1][2]  # 8 m
    box_plan = facade_grid(scene, P4P, g, footprint="box")
    out_plan = facade_grid(scene, P4P, g, footprint="outline")
    # box mode: the bounding box is 20·cos30 + 10·sin30 = 22.32 by 20·sin30 + 10·cos30 = 18.66 m;
    # s_h = 3 m: ceil(22.32/3) + 1 = 9 and ceil(18.66/3) + 1 = 8 columns; layers from the 2 m minimum height to the
    # 8 m top: ceil(6/2) + 1 = 4, + the top row = 5 per column
    assert [m.stop - m.start for m in box_plan.missions] == [45, 40, 45, 40]
    # outline mode: the real 20 and 10 m walls: ceil(20/3) + 1 = 8 and ceil(10/3) + 1 = 5 columns
    assert [m.stop - m.start for m in out_plan.missions] == [40, 25, 40, 25]
    assert out_plan.parameters["footprint"] == "outline"
    level = out_plan.C_world[:, 2] <= top + 1e-9
    np.testing.assert_allclose(point_distances(scene, out_plan.C_world[level]), g, rtol=1e-9)
    # the top row is g above the roof and g out from the wall: √2·g from the roof's edge
    np.testing.assert_allclose(point_distances(scene, out_plan.C_world[~level]), g * math.sqrt(2), rtol=1e-9)
    box_level = box_plan.C_world[:, 2] <= top + 1e-9
    d_box = point_distances(scene, box_plan.C_world[box_level])
    assert d_box.min() > g + 1e-3  # the box's sides stand off the rotated walls…
    # …by up to 10·√3: the south side's east end (21.16, −14.33) is 20 m from the long wall's south corner
    # (3.84, −4.33), 30° off the wall's outward normal: 20·cos 30° from the wall
    assert d_box.max() == pytest.approx(10 * math.sqrt(3))
    # perpendicular views: each edge's inner columns look along its inward normal, level
    first = out_plan.missions[0]  # the 20 m wall facing south-east: outward normal (sin30, −cos30)
    inner = np.arange(first.start, first.stop)[6:-6]
    inner = inner[out_plan.C_world[inner, 2] <= top + 1e-9]
    np.testing.assert_allclose(out_plan.R_world_camera[inner][:, :, 2],
                               np.tile([-0.5, math.cos(math.radians(30)), 0], (len(inner), 1)), atol=1e-12)


def test_facade_outline_trims_the_inside_corner_of_an_l():
    g = 5.0  # s_h = 2·5·0.75·0.2 = 1.5 m, s_v = 1 m
    scene = scene_of(box((30, 10, 6)), box((10, 20, 6), (0, 10, 0)))
    plan = facade_grid(scene, P4P, g, footprint="outline")
    # edges anticlockwise from the south: 30, 10, inner 20 → 15 (offsets y = 15 and x = 15 meet at (15, 15)),
    # inner 20 → 15, 10, 30 m: 21, 8, 11, 11, 8, 21 columns; 6 m high, layers from the 2 m minimum height:
    # 4/1 + 1 = 5 layers + top row = 6 per column
    assert [m.stop - m.start for m in plan.missions] == [c * 6 for c in (21, 8, 11, 11, 8, 21)]
    level = plan.C_world[:, 2] <= 6 + 1e-9
    np.testing.assert_allclose(point_distances(scene, plan.C_world[level]), g, rtol=1e-9)
    corner = np.isclose(plan.C_world[:, 0], 15) & np.isclose(plan.C_world[:, 1], 15)
    assert corner.sum() == 2 * 6  # the inside corner ends both inner edges' passes
    inner_north = plan.missions[2]
    np.testing.assert_allclose(plan.C_world[inner_north.start:inner_north.stop, 1], 15.0)
    rows = np.arange(inner_north.start, inner_north.stop)
    inner_cols = rows[(plan.C_world[rows, 0] > 15.1) & (plan.C_world[rows, 0] < 29.9) & level[rows]]
    np.testing.assert_allclose(heading_of(plan, inner_cols), 180.0)  # looking south at the inner wall


def test_facade_outline_skips_a_notch_narrower_than_twice_g():
    g = 5.0
    # a U: base 30 × 10, arms 12 m wide, a 6 m notch between them 15 m deep
    scene = scene_of(box((30, 10, 6)), box((12, 15, 6), (0, 10, 0)), box((12, 15, 6), (18, 10, 0)))
    plan = facade_grid(scene, P4P, g, footprint="outline")
    # the notch's three walls are never 5 m from the opposite wall: only 30, 25, 12, 12, 25 m edges are flown:
    # 21, ceil(25/1.5) + 1 = 18, ceil(12/1.5) + 1 = 9, 9, 18 columns of 6 frames (5 layers from 2 m, the top row)
    assert sorted(m.stop - m.start for m in plan.missions) == sorted(c * 6 for c in (21, 18, 9, 9, 18))
    level = plan.C_world[:, 2] <= 6 + 1e-9
    assert point_distances(scene, plan.C_world[level]).min() == pytest.approx(g)
    for m in plan.missions:  # nothing flown within a mission comes nearer than g (the top row's hop included)
        c = plan.C_world[m.start:m.stop]
        assert segment_distances(scene, c[:-1], c[1:]).min() >= g - 1e-9


def test_facade_outline_closes_a_gap_too_narrow_to_fly():
    g = 5.0  # gaps narrower than 2·g/20 = 0.5 m are closed
    scene = scene_of(box((10, 10, 6)), box((10, 10, 6), (10.2, 0, 0)))
    plan = facade_grid(scene, P4P, g, footprint="outline")
    # one 20.2 × 10 m outline: ceil(20.2/1.5) + 1 = 15 and ceil(10/1.5) + 1 = 8 columns of 5 layers (2 to 6 m) + the
    # top row
    assert [(m.name, m.stop - m.start) for m in plan.missions] == [
        ("facade edge 1", 90), ("facade edge 2", 48), ("facade edge 3", 90), ("facade edge 4", 48)]
    level = plan.C_world[:, 2] <= 6 + 1e-9
    d = point_distances(scene, plan.C_world[level])
    assert d.min() == pytest.approx(g) and d.max() <= math.hypot(g, 0.1) + 1e-9  # √(g² + 0.1²) across the gap


def test_facade_outline_goes_around_a_fin_seen_edge_on():
    # a 3 m vertical plate without thickness on the east wall of a 20 × 10 × 8 box: it projects to a line, not an
    # area, yet the outline must keep g from it
    fin = trimesh.Trimesh(vertices=[[20, 5, 0], [23, 5, 0], [23, 5, 8], [20, 5, 8]], faces=[[0, 1, 2], [0, 2, 3]])
    scene = scene_of(box((20, 10, 8)), fin)
    plan = facade_grid(scene, P4P, 10.0, footprint="outline")
    level = plan.C_world[:, 2] <= 8 + 1e-9
    assert point_distances(scene, plan.C_world[level]).min() >= 10.0 - 1e-9
    # the east wall's offset (x = 30, y 0–10) lies within √(7² + 5²) = 8.6 m of the fin's tip: not flown. South and
    # north (8 columns of 5: 4 layers from 2 m and the top row) and west (5 columns) are, 10 m out (10.1 m: the thin
    # fin was simplified, g/100 added)
    assert [m.stop - m.start for m in plan.missions] == [40, 40, 25]
    assert plan.C_world[level, 0].max() <= 20.0 + 1e-9
    np.testing.assert_allclose(plan.C_world[level, 1].min(), -10.1)


def test_facade_outline_refuses_bad_footprint_names():
    with pytest.raises(PlanError, match="'box' or 'outline'"):
        facade_grid(rotated_box_scene(), P4P, 10, footprint="hull")  # type: ignore[arg-type]


# ------------------------------------------------------------------------------------- lawn-mower double grid

def test_lawnmower_double_grid_by_hand():
    scene = scene_of(box((20, 10, 8)))
    plain = lawnmower(scene, P4P, altitude_m=38.0)
    plan = lawnmower(scene, P4P, altitude_m=38.0, oblique_pitch_deg=-60)
    # nadir part as before: 3 lines × 3 frames. Crossed lines: 13.5 m apart over 10 m of y → 2 lines (y = 0, 10);
    # frames 6 m apart over 20 m of x → ceil(20/6) + 1 = 5 (x = 0, 5, 10, 15, 20). The last frame of each line looks
    # out past the box's end (from x = 20 east, from x = 0 west: the view's steepest ray, 86.6° down, meets the roof
    # 1.8 m ahead): it sees nothing and is dropped
    assert [(m.name, m.stop - m.start) for m in plan.missions] == [("lawn-mower", 9), ("lawn-mower crossed", 8)]
    assert plan.parameters["dropped_frames"] == 2
    np.testing.assert_array_equal(plan.C_world[:9], plain.C_world)
    np.testing.assert_array_equal(plan.R_world_camera[:9], plain.R_world_camera)
    crossed = plan.C_world[9:]
    np.testing.assert_allclose(crossed[:4], [[x, 0, 38] for x in (0, 5, 10, 15)])  # east along y = 0…
    np.testing.assert_allclose(crossed[4:], [[x, 10, 38] for x in (20, 15, 10, 5)])  # …then west along y = 10
    c, s = math.cos(math.radians(60)), math.sin(math.radians(60))
    fwd = plan.R_world_camera[9:, :, 2]
    np.testing.assert_allclose(fwd[:4], np.tile([c, 0, -s], (4, 1)), atol=1e-12)  # looking ahead, 60° down
    np.testing.assert_allclose(fwd[4:], np.tile([-c, 0, -s], (4, 1)), atol=1e-12)
    assert plan.parameters["oblique_pitch_deg"] == -60.0
    assert "oblique_pitch_deg" not in plain.parameters
    with pytest.raises(PlanError, match="oblique pitch"):
        lawnmower(scene, P4P, altitude_m=38.0, oblique_pitch_deg=10)
