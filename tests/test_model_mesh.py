"""Mesh loading: box scenes made with trimesh, exported and read back with each grouping."""

from __future__ import annotations

import numpy as np
import pytest
import trimesh

from sightplan.errors import ModelError
from sightplan.model import load_model
from sightplan.model.mesh import load_mesh

BIG = (1.0, 2.0, 3.0)  # box A, centred at the origin
SMALL = (1.0, 1.0, 1.0)  # box B, centred at (5, 0, 10) after its node transform


def two_box_scene() -> trimesh.Scene:
    a = trimesh.creation.box(BIG)
    b = trimesh.creation.box(SMALL)
    scene = trimesh.Scene()
    scene.add_geometry(a, node_name="A", geom_name="a")
    scene.add_geometry(b, node_name="B", geom_name="b", transform=trimesh.transformations.translation_matrix((5, 0, 10)))
    return scene


def _element_bounds(scene, idx: int) -> np.ndarray:
    v = scene.vertices[scene.faces[scene.face_element == idx]].reshape(-1, 3)
    return np.stack([v.min(0), v.max(0)])


EXPECTED_BOUNDS = {
    "big": np.array([[-0.5, -1.0, -1.5], [0.5, 1.0, 1.5]]),
    "small": np.array([[4.5, -0.5, 9.5], [5.5, 0.5, 10.5]]),
}


@pytest.mark.parametrize("ext", ["obj", "glb", "ply"])
def test_objects_components_faces(tmp_path, ext):
    path = tmp_path / f"boxes.{ext}"
    two_box_scene().export(path)
    y_up = ext == "glb"

    def to_file_axes(b: np.ndarray) -> np.ndarray:  # undo the Y-up → Z-up rotation for comparison
        if not y_up:
            return b
        pts = np.column_stack([b[:, 0], b[:, 2], -b[:, 1]])
        return np.stack([pts.min(0), pts.max(0)])

    comp, comp_report = load_mesh(path, elements="components")
    assert comp.n_elements == 2 and len(comp.faces) == 24  # two closed boxes of 12 triangles
    boxes = sorted((to_file_axes(_element_bounds(comp, i)) for i in range(2)), key=lambda b: b[0, 0])
    np.testing.assert_allclose(boxes[0], EXPECTED_BOUNDS["big"], atol=1e-6)
    np.testing.assert_allclose(boxes[1], EXPECTED_BOUNDS["small"], atol=1e-6)
    areas = np.bincount(comp.face_element, weights=comp.face_areas())
    np.testing.assert_allclose(np.sort(areas), [6.0, 22.0])  # 6 × 1 m² and 2(2 + 3 + 6) m²
    assert comp_report.n_triangles == 24

    faces, _ = load_mesh(path, elements="faces")
    assert faces.n_elements == 24 and (faces.face_element == np.arange(24)).all()

    objects, report = load_mesh(path, elements="objects")
    expected_objects = 1 if ext == "ply" else 2  # PLY holds a single mesh
    assert objects.n_elements == expected_objects == report.n_elements
    assert objects.elements.is_target.all() and report.schema == ext
    np.testing.assert_allclose(objects.bounds(), comp.bounds(), atol=1e-9)
    if ext != "ply":
        names = sorted(objects.elements.global_id)
        assert names == (["A", "B"] if ext == "glb" else ["a", "b"])


def test_glb_is_turned_z_up_and_scaled(tmp_path):
    path = tmp_path / "boxes.glb"
    two_box_scene().export(path)
    scene, _ = load_mesh(path, scale=2.0)
    # file (Y-up) small box centre (5, 0, 10) → Z-up (5, -10, 0), times 2
    small = _element_bounds(scene, list(scene.elements.global_id).index("B"))
    np.testing.assert_allclose(small.mean(0), [10.0, -20.0, 0.0], atol=1e-6)
    np.testing.assert_allclose(np.ptp(small, axis=0), [2.0, 2.0, 2.0], atol=1e-6)
    kept, _ = load_mesh(path, up="z")
    np.testing.assert_allclose(_element_bounds(kept, list(kept.elements.global_id).index("B")).mean(0), [5, 0, 10], atol=1e-6)


def test_stl_via_load_model(tmp_path):
    path = tmp_path / "box.stl"
    trimesh.creation.box(BIG).export(path)
    scene, report = load_model(path, cache=False)
    assert scene.n_elements == 1 and len(scene.faces) == 12
    np.testing.assert_allclose(scene.bounds(), EXPECTED_BOUNDS["big"], atol=1e-6)


def test_bad_mesh_files(tmp_path):
    empty = tmp_path / "empty.obj"
    empty.write_bytes(b"")
    with pytest.raises(ModelError, match="empty"):
        load_mesh(empty)
    broken = tmp_path / "broken.obj"
    broken.write_text("v 1 2\nf 1 2 3\n")
    with pytest.raises(ModelError, match="broken.obj"):
        load_mesh(broken)
    glb = tmp_path / "garbage.glb"
    glb.write_bytes(b"glTF\x02\x00\x00\x00garbage")
    with pytest.raises(ModelError, match="cannot be read as a mesh"):
        load_mesh(glb)
    points = tmp_path / "points.obj"
    points.write_text("v 0 0 0\nv 1 0 0\nv 0 1 0\n")
    with pytest.raises(ModelError, match="no triangles"):
        load_mesh(points)
    with pytest.raises(ModelError, match="elements must be one of"):
        load_mesh(broken, elements="groups")
    with pytest.raises(ModelError, match="not found"):
        load_model(tmp_path / "missing.ply")
