"""The geometry layer's distances against trimesh's closest-point queries on random triangles."""

from __future__ import annotations

import numpy as np
import trimesh

from sightplan.geometry.distance import min_point_distances, min_segment_distances, point_triangle_sq


def test_point_triangle_distances_match_trimesh():
    rng = np.random.default_rng(7)
    tri = rng.normal(size=(200, 3, 3))
    tri[:5, 2] = tri[:5, 0] + 0.5 * (tri[:5, 1] - tri[:5, 0])  # a few degenerate (collinear) triangles
    points = rng.normal(scale=2.0, size=(50, 3))
    ours = np.array([[point_triangle_sq(p[0], p[1], p[2], t) for t in tri] for p in points])
    for k, t in enumerate(tri[5:], start=5):
        mesh = trimesh.Trimesh(t, [[0, 1, 2]], process=False)
        _, dist, _ = trimesh.proximity.closest_point(mesh, points)
        assert np.allclose(np.sqrt(ours[:, k]), dist, atol=1e-9), k
    lo, hi = tri.min(axis=1), tri.max(axis=1)
    upper = np.full(len(points), np.inf)
    assert np.allclose(min_point_distances(points, tri, lo, hi, upper), np.sqrt(ours.min(axis=1)))
    # a segment from a point to itself is that point
    assert np.allclose(min_segment_distances(points, points.copy(), tri, lo, hi, upper), np.sqrt(ours.min(axis=1)))
