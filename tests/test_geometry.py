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


def test_a_written_glb_reads_back_in_trimesh_y_up_with_its_colours():
    import io

    from sightplan.geometry.axes import y_up_to_z_up, z_up_to_y_up
    from sightplan.geometry.glb import primitive_glb

    rng = np.random.default_rng(3)
    v = rng.uniform(-5, 5, size=(30, 3)) + [1000.0, 2000.0, 50.0]
    assert np.allclose(y_up_to_z_up(z_up_to_y_up(v)), v)
    faces = rng.integers(0, 30, size=(20, 3))
    mesh = trimesh.load(io.BytesIO(primitive_glb(v, v.mean(axis=0), triangles=faces)), file_type="glb", force="mesh",
                        process=False)
    assert np.allclose(mesh.vertices, z_up_to_y_up(v), atol=1e-3) and np.array_equal(mesh.faces, faces)
    colours = rng.integers(0, 256, size=(30, 3)).astype(np.uint8)
    cloud = trimesh.load(io.BytesIO(primitive_glb(v, v.mean(axis=0), colours=colours)), file_type="glb")
    geometry = next(iter(cloud.geometry.values()))
    points = trimesh.transform_points(geometry.vertices, cloud.graph[cloud.graph.nodes_geometry[0]][0])
    assert np.allclose(points, z_up_to_y_up(v), atol=1e-3)
    assert np.array_equal(np.asarray(geometry.colors)[:, :3], colours)
