"""Pair selection for structure from motion (sightplan.loop.pairs) on a synthetic four-sided facade grid: the views
round each corner of a box building are linked by several pairs, opposite sides by none, and the list is far shorter
than every pair. The depth maps are the engine's own, at 96 × 64 px."""

from __future__ import annotations

import math

import numpy as np
import pytest

from sightplan.camera.models import PinholeCamera
from sightplan.engines import make_engine
from sightplan.engines.registry import available_engines
from sightplan.loop.pairs import coarse_depth, frame_samples, overlap_pairs, shared_samples
from sightplan.model.scene import ElementTable, Scene

pytestmark = pytest.mark.skipif(not available_engines(), reason="no visibility engine")

X, Y, H = 6.0, 4.0, 6.0  # the building: x in ±X, y in ±Y, z in 0…H
G = 6.0  # the grid's distance from the walls
CAM = PinholeCamera(96, 64, 64.0, 64.0, 48.0, 32.0, "small")  # 74° across, as a P4P


def box_scene() -> Scene:
    """Four walls, a roof and the ground around them, one element each."""
    rects = [((-X, -Y, 0), (X, -Y, 0), (X, -Y, H), (-X, -Y, H)), ((X, -Y, 0), (X, Y, 0), (X, Y, H), (X, -Y, H)),
             ((X, Y, 0), (-X, Y, 0), (-X, Y, H), (X, Y, H)), ((-X, Y, 0), (-X, -Y, 0), (-X, -Y, H), (-X, Y, H)),
             ((-X, -Y, H), (X, -Y, H), (X, Y, H), (-X, Y, H)), ((-30, -30, 0), (30, -30, 0), (30, 30, 0), (-30, 30, 0))]
    vertices, faces = [], []
    for k, corners in enumerate(rects):
        vertices += corners
        faces += [[4 * k, 4 * k + 1, 4 * k + 2], [4 * k, 4 * k + 2, 4 * k + 3]]
    names = ["south", "east", "north", "west", "roof", "ground"]
    return Scene.from_arrays(np.array(vertices, float), np.array(faces), np.repeat(np.arange(6), 2),
                             ElementTable.build(names))


def looking(heading: np.ndarray | list, pitch_deg: float = 0.0) -> np.ndarray:
    """World-from-camera rotation looking along the horizontal ``heading`` tilted down by ``pitch_deg``."""
    h = np.asarray(heading, float) / np.linalg.norm(heading)
    p = math.radians(pitch_deg)
    z = np.array([h[0] * math.cos(p), h[1] * math.cos(p), -math.sin(p)])
    x = np.cross(z, [0.0, 0.0, 1.0])
    x /= np.linalg.norm(x)
    return np.column_stack([x, np.cross(z, x), z])


def facade_grid() -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """A facade grid as the template flies it, side by side (south, east, north, west): columns 2 m apart at G from
    the wall, rows at 2 and 4 m looking at it, the end columns turned 45° inward, and a top row 2 m above the roof
    looking down at 45°. Returns R (n, 3, 3), C (n, 3) and each frame's side (n,)."""
    R, C, side = [], [], []
    for s, (origin, along, normal, length) in enumerate((
            ((-X, -Y), (1, 0), (0, -1), 2 * X), ((X, -Y), (0, 1), (1, 0), 2 * Y),
            ((X, Y), (-1, 0), (0, 1), 2 * X), ((-X, Y), (0, -1), (-1, 0), 2 * Y))):
        o, a, nrm = np.array(origin, float), np.array(along, float), np.array(normal, float)
        stops = np.linspace(0.0, length, int(round(length / 2)) + 1)
        for t in stops:
            base = o + t * a + G * nrm
            heading = -nrm if 0 < t < length else -nrm + (a if t == 0 else -a)
            for z in (2.0, 4.0):
                R.append(looking(heading))
                C.append([base[0], base[1], z])
                side.append(s)
            R.append(looking(-nrm, 45.0))
            C.append([base[0], base[1], H + 2.0 + G])
            side.append(s)
    return np.array(R), np.array(C), np.array(side)


@pytest.fixture(scope="module")
def grid():
    scene = box_scene()
    R, C, side = facade_grid()
    with make_engine("auto", scene) as engine:
        depths = [engine.shaded_view(CAM, R[i], C[i])[1] for i in range(len(C))]
    return R, C, side, depths


def test_the_samples_lie_on_the_surfaces_the_frame_sees(grid):
    R, C, side, depths = grid
    pts = frame_samples(CAM, R[1], C[1], coarse_depth(depths[1], 3), 3)  # the south side's first column, upper row
    assert len(pts) > 200
    on_wall = np.abs(pts[:, 1] + Y) < 1e-3
    on_ground = np.abs(pts[:, 2]) < 1e-3
    assert (on_wall | on_ground).all() and on_wall.mean() > 0.5


def test_each_corner_is_linked_by_several_pairs_and_opposite_sides_by_none(grid):
    R, C, side, depths = grid
    n = len(C)
    shared = shared_samples([CAM] * n, R, C, depths)
    assert shared.shape == (n, n) and (np.diag(shared) == 0).all() and ((shared >= 0) & (shared <= 1)).all()
    pairs = overlap_pairs(shared, R[:, :, 2])
    links = {}
    for i, j in pairs:
        key = tuple(sorted((int(side[i]), int(side[j]))))
        links[key] = links.get(key, 0) + 1
    for corner in ((0, 1), (1, 2), (2, 3), (0, 3)):
        assert links.get(corner, 0) >= 20, links
    assert links.get((0, 2), 0) == 0 and links.get((1, 3), 0) == 0  # opposite walls share no surface
    assert len(pairs) < n * (n - 1) // 4
    # every frame is linked, and the graph is one piece
    seen = {0}
    frontier = [0]
    adjacent = {i: set() for i in range(n)}
    for i, j in pairs:
        adjacent[i].add(j)
        adjacent[j].add(i)
    while frontier:
        for j in adjacent[frontier.pop()] - seen:
            seen.add(j)
            frontier.append(j)
    assert len(seen) == n


def test_turned_partners_join_views_that_look_different_ways():
    """Frames 0–2 look north and 3–4 are turned 60°, each group overlapping most within itself: with one best
    partner each the groups stay apart; one turned partner each joins them where they overlap enough (0 with 3 and
    4), and never under the minimum overlap (1 and 2 with the turned frames)."""
    north = looking([0.0, 1.0])
    turned = looking([math.sin(math.radians(60)), math.cos(math.radians(60))])
    shared = np.array([[0, 0.9, 0.8, 0.3, 0.2], [0.9, 0, 0.9, 0.02, 0.01], [0.8, 0.9, 0, 0.01, 0.01],
                       [0.3, 0.02, 0.01, 0, 0.9], [0.2, 0.01, 0.01, 0.9, 0]])
    axes = np.array([north] * 3 + [turned] * 2)[:, :, 2]
    assert overlap_pairs(shared, axes, k=1, k_turned=0) == [(0, 1), (1, 2), (3, 4)]
    assert overlap_pairs(shared, axes, k=1, k_turned=1) == [(0, 1), (0, 3), (0, 4), (1, 2), (3, 4)]
