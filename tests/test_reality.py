"""Reality models: surface patches, point clouds meshed by voxels, and BIM + reality scenes.

Reference numbers come from geometry built here (a grid plane, a box and its exact mesh,
a wall behind an occluder), from trimesh's proximity queries and from laspy/trimesh as
independent writers of the files read back.
"""

from __future__ import annotations

import importlib.util
import struct
from dataclasses import replace

import laspy
import numpy as np
import pytest
import trimesh
from scipy.sparse import coo_matrix
from scipy.sparse.csgraph import connected_components

from sightplan.camera.models import PinholeCamera
from sightplan.errors import ModelError
from sightplan.evaluate import EvaluationSettings, evaluate, pixel_counts
from sightplan.model import load_model
from sightplan.model.mesh import load_mesh
from sightplan.model.patches import PATCH_CLASS, patch_faces
from sightplan.model.pointcloud import default_spacing, is_point_cloud, points_to_mesh, read_point_cloud
from sightplan.model.reality import combine, load_reality
from sightplan.model.scene import ElementTable, Scene
from sightplan.plan.ring import ring_plan
from sightplan.plan.types import Plan

BOX = (10.0, 6.0, 4.0)  # the box of the point cloud tests, standing on z = 0, centred on x = y = 0
GEO_OFFSET = np.array([500_000.0, 5_700_000.0, 100.0])  # a UTM-like origin for the LAS file
N_POINTS = 60_000


# --------------------------------------------------------------------------- helpers
def grid_plane(n: int = 10) -> tuple[np.ndarray, np.ndarray]:
    """An n × n m plane at z = 0, two triangles per 1 m² cell."""
    i, j = np.meshgrid(np.arange(n + 1), np.arange(n + 1), indexing="ij")
    vertices = np.column_stack([i.ravel(), j.ravel(), np.zeros(i.size)]).astype(float)
    v = (np.arange(n)[:, None] * (n + 1) + np.arange(n)[None, :]).ravel()
    faces = np.concatenate([np.column_stack([v, v + n + 1, v + n + 2]), np.column_stack([v, v + n + 2, v + 1])])
    return vertices, faces


def is_connected(vertices: np.ndarray, faces: np.ndarray) -> bool:
    mesh = trimesh.Trimesh(vertices, faces, process=True)
    adj = mesh.face_adjacency
    graph = coo_matrix((np.ones(len(adj)), (adj[:, 0], adj[:, 1])), shape=(len(mesh.faces),) * 2)
    return connected_components(graph, directed=False)[0] == 1


def box_mesh() -> trimesh.Trimesh:
    box = trimesh.creation.box(BOX)
    box.apply_translation((0, 0, BOX[2] / 2))
    return box


def one_element_scene(vertices, faces, name: str = "box", ifc_class: str = "") -> Scene:
    table = ElementTable.build([name], name=[name], ifc_class=[ifc_class])
    return Scene.from_arrays(vertices, faces, np.zeros(len(faces), np.int32), table)


@pytest.fixture(scope="module")
def box_points() -> np.ndarray:
    points, _ = trimesh.sample.sample_surface(box_mesh(), N_POINTS, seed=7)
    return np.asarray(points)


def write_las(path, points: np.ndarray) -> None:
    """LAS 1.2 with millimetre integers and the header offset at the points' floor (real coordinates = X·scale + offset)."""
    header = laspy.LasHeader(point_format=3, version="1.2")
    header.offsets = np.floor(points.min(axis=0))
    header.scales = np.array([0.001, 0.001, 0.001])
    las = laspy.LasData(header)
    las.x, las.y, las.z = points[:, 0], points[:, 1], points[:, 2]
    las.write(str(path))


@pytest.fixture(scope="module")
def cloud_files(tmp_path_factory, box_points) -> dict:
    folder = tmp_path_factory.mktemp("clouds")
    files = {"ply": folder / "box.ply", "las": folder / "box.las", "laz": folder / "box.laz"}
    trimesh.PointCloud(box_points).export(files["ply"])
    write_las(files["las"], box_points + GEO_OFFSET)
    write_las(files["laz"], box_points + GEO_OFFSET)
    return files


# --------------------------------------------------------------------------- patches
def test_plane_splits_into_four_patches_of_25_m2():
    vertices, faces = grid_plane()
    assert len(faces) == 200
    face_element, n = patch_faces(vertices, faces, 25.0)
    assert n == 4 and face_element.dtype == np.int32 and set(face_element) == {0, 1, 2, 3}
    areas = np.bincount(face_element, trimesh.Trimesh(vertices, faces, process=False).area_faces)
    assert areas.sum() == pytest.approx(100.0, abs=1e-9)
    # equal-area cuts fall between faces: two cut levels, each off by at most one 0.5 m² triangle
    np.testing.assert_allclose(areas, 25.0, atol=2 * 0.5)
    for p in range(n):
        assert is_connected(vertices, faces[face_element == p])
    again, _ = patch_faces(vertices, faces, 25.0)
    np.testing.assert_array_equal(again, face_element)
    assert face_element[0] == 0  # numbered in the order of their first face


def test_patch_area_that_does_not_divide_evenly():
    vertices, faces = grid_plane()
    face_element, n = patch_faces(vertices, faces, 30.0)
    areas = np.bincount(face_element, trimesh.Trimesh(vertices, faces, process=False).area_faces)
    assert n == 3  # round(100 / 30)
    np.testing.assert_allclose(areas, 100 / 3, atol=2 * 0.5)


@pytest.mark.parametrize("patch_area", [0.5, 5.0, 25.0, 1000.0])
def test_box_sides_never_share_a_patch(patch_area):
    box = trimesh.creation.box(BOX).subdivide().subdivide()  # 32 triangles of 0.75 m² per side
    face_element, n = patch_faces(box.vertices, box.faces, patch_area, normal_angle_deg=30.0)
    normals = box.face_normals
    for p in range(n):
        assert np.allclose(normals[face_element == p], normals[face_element == p][0])
    if patch_area >= 100:
        assert n == 6


def test_small_box_sides_stay_apart_even_below_the_small_patch_share():
    box = trimesh.creation.box((1.0, 1.0, 1.0))  # 1 m² sides, far below a 25 m² patch
    face_element, n = patch_faces(box.vertices, box.faces, 25.0)
    assert n == 6
    assert all(len(set(map(tuple, np.round(box.face_normals[face_element == p], 9)))) == 1 for p in range(n))


def test_load_mesh_with_patches(tmp_path):
    path = tmp_path / "box.obj"
    trimesh.creation.box(BOX).subdivide().export(path)
    scene, report = load_mesh(path, elements="patches", patch_area_m2=15.0)
    assert scene.elements.global_id[0] == "patch 00001" and set(scene.elements.ifc_class) == {PATCH_CLASS}
    assert set(scene.elements.discipline) == {""} and scene.elements.is_target.all()
    assert report.n_elements == scene.n_elements == 2 * (4 + 3 + 2)  # round(60/15), round(40/15), round(24/15) per side
    with pytest.raises(ModelError, match="apply to elements='patches'"):
        load_mesh(path, elements="objects", patch_area_m2=15.0)
    with pytest.raises(ModelError, match="patch area"):
        load_mesh(path, elements="patches", patch_area_m2=0.0)
    # the cache key holds the patch options
    a, _ = load_model(path, elements="patches", patch_area_m2=15.0)
    b, _ = load_model(path, elements="patches", patch_area_m2=60.0)
    assert a.content_hash != b.content_hash and b.n_elements == 6


# --------------------------------------------------------------------------- point clouds
def test_read_point_cloud_ply_las_laz(cloud_files, box_points):
    ply = read_point_cloud(cloud_files["ply"])
    assert ply.normals is None
    np.testing.assert_allclose(ply.points, box_points, atol=1e-5)  # float32 in the file
    for kind in ("las", "laz"):
        las = read_point_cloud(cloud_files[kind])
        # real coordinates: integer · 0.001 + offset, so within half a millimetre
        np.testing.assert_allclose(las.points, box_points + GEO_OFFSET, rtol=0, atol=0.0005 + 1e-9)
    assert all(is_point_cloud(p) for p in cloud_files.values())


def test_ply_normals_are_read(tmp_path):
    path = tmp_path / "normals.ply"
    path.write_text("ply\nformat ascii 1.0\nelement vertex 2\nproperty double x\nproperty double y\nproperty double z\n"
                    "property float nx\nproperty float ny\nproperty float nz\nend_header\n1 2 3 0 0 1\n4 5 6 1 0 0\n")
    cloud = read_point_cloud(path)
    np.testing.assert_array_equal(cloud.points, [[1, 2, 3], [4, 5, 6]])
    np.testing.assert_array_equal(cloud.normals, [[0, 0, 1], [1, 0, 0]])


def test_voxel_surface_lies_about_half_a_spacing_from_the_box(box_points):
    spacing = default_spacing(box_points)
    vertices, faces = points_to_mesh(box_points)
    truth = box_mesh()
    rng = np.random.default_rng(0)
    sample = vertices[rng.choice(len(vertices), 3000, replace=False)]
    _, d, _ = trimesh.proximity.closest_point(truth, sample)
    # node rounding puts a node within ½ spacing of the surface and the 0.5 level lies about ½
    # spacing beyond the outermost node: offsets in [0, 1] spacing, about ½ on average
    assert d.mean() <= 0.6 * spacing
    assert np.percentile(d, 99) <= 1.0 * spacing
    # and no part of the box is missing: true surface points lie near the reconstruction
    recon = trimesh.Trimesh(vertices, faces, process=False)
    probes, _ = trimesh.sample.sample_surface(truth, 1000, seed=3)
    _, back, _ = trimesh.proximity.closest_point(recon, probes)
    assert np.percentile(back, 99) <= 1.0 * spacing
    # winding normals face away from the occupied shell: outward on the outer surface
    normals = recon.face_normals
    centres = recon.triangles_center - truth.centroid
    outer = (np.abs(centres) > np.array(BOX) / 2 - 1e-9).any(axis=1)
    assert ((normals[outer] * centres[outer]).sum(axis=1) > 0).mean() > 0.95


def _frame_pixels(scene: Scene, plan: Plan) -> np.ndarray:
    ev = evaluate(scene, plan, EvaluationSettings(scale=0.5, feature_density=0.0), cache_dir=False)
    return pixel_counts(ev.observations)[:, scene.targets].sum(axis=1)


def test_point_cloud_coverage_matches_the_box(cloud_files, box_points):
    truth = box_mesh()
    truth_scene = one_element_scene(truth.vertices, truth.faces)
    plan = ring_plan(truth_scene, PinholeCamera(320, 240, 300, 300, 160, 120, "small"), n_frames=8, distance_m=8.0)
    expected = _frame_pixels(truth_scene, plan)
    assert (expected > 5000).all()
    for kind in ("ply", "las"):
        origin = GEO_OFFSET if kind == "las" else None
        scene = load_reality(cloud_files[kind], origin_m=origin, cache=False)
        assert scene.elements.is_target.all() and scene.elements.global_id[0] == "patch 00001"
        got = _frame_pixels(scene, plan)
        ratio = got / expected
        # the surface sits ~½ spacing (≈ 4 cm) outside the 4–10 m box: a few % more pixels, never fewer
        assert np.all(np.abs(ratio - 1) < 0.05), ratio
        assert 0.99 < got.sum() / expected.sum() < 1.04


def test_load_model_reads_point_clouds_with_cache(cloud_files, tmp_path):
    scene, report = load_model(cloud_files["ply"], cache_dir=tmp_path, patch_area_m2=20.0)
    assert report.schema == "ply" and not report.from_cache
    assert scene.metadata["reality"]["kind"] == "point cloud" and scene.metadata["reality"]["n_points"] == N_POINTS
    assert set(scene.elements.ifc_class) == {PATCH_CLASS}
    again, report2 = load_model(cloud_files["ply"], cache_dir=tmp_path, patch_area_m2=20.0)
    assert report2.from_cache and again.n_elements == scene.n_elements
    np.testing.assert_array_equal(again.face_element, scene.face_element)
    coarse, report3 = load_model(cloud_files["ply"], cache_dir=tmp_path, patch_area_m2=80.0)
    assert not report3.from_cache and coarse.n_elements < scene.n_elements
    las, las_report = load_model(cloud_files["laz"], cache=False)
    assert las_report.schema == "laz" and las_report.warnings  # georeferenced coordinates are pointed out
    np.testing.assert_allclose(las.bounds()[0], GEO_OFFSET + [-5, -3, 0], atol=0.2)
    with pytest.raises(ModelError, match="surface patches"):
        load_model(cloud_files["ply"], cache=False, elements="faces")


def test_mesh_ply_still_loads_as_a_mesh(tmp_path):
    path = tmp_path / "mesh.ply"
    trimesh.creation.box(BOX).export(path)
    assert not is_point_cloud(path)
    scene, _ = load_model(path, cache=False)
    assert scene.n_elements == 1 and len(scene.faces) == 12
    patches = load_reality(path, patch_area_m2=1000.0, cache=False)
    assert patches.n_elements == 6 and patches.metadata["reality"]["kind"] == "mesh"


def test_poisson_surface_when_open3d_is_installed(box_points):
    pytest.importorskip("open3d")
    spacing = default_spacing(box_points)
    vertices, faces = points_to_mesh(box_points, method="poisson")  # normals estimated and turned outward
    _, d, _ = trimesh.proximity.closest_point(box_mesh(), vertices[::5])
    assert d.mean() <= 0.25 * spacing and np.percentile(d, 99) <= 1.0 * spacing
    recon = trimesh.Trimesh(vertices, faces, process=False)
    centres = recon.triangles_center - box_mesh().centroid
    assert ((recon.face_normals * centres).sum(axis=1) > 0).mean() > 0.95


def test_solid_fills_the_box(box_points):
    spacing = 0.15
    _, hollow = points_to_mesh(box_points, spacing)
    vertices, solid = points_to_mesh(box_points, spacing, solid=True)
    mesh = trimesh.Trimesh(vertices, solid, process=True)
    assert len(solid) < 0.6 * len(hollow)  # one surface instead of two
    # one closed surface 0 to 1 spacing outside each side of the 240 m³ box
    assert mesh.is_watertight and np.prod(BOX) < mesh.volume < np.prod(np.array(BOX) + 2 * spacing)


# --------------------------------------------------------------------------- BIM + reality
R_NORTH = np.array([[1.0, 0.0, 0.0], [0.0, 0.0, 1.0], [0.0, -1.0, 0.0]])  # camera looking +Y, image right +X


def _wall_scene() -> Scene:
    """A 2 × 2 m BIM wall at y = 10, facing a camera at the origin."""
    v = np.array([[-1, 10, -1], [1, 10, -1], [1, 10, 1], [-1, 10, 1]], float)
    f = np.array([[0, 1, 2], [0, 2, 3]])
    return one_element_scene(v, f, "wall", "IfcWall")


def _one_frame_plan() -> Plan:
    return Plan.build(PinholeCamera(320, 240, 300, 300, 160, 120, "small"), R_NORTH[None], np.zeros((1, 3)))


def test_reality_occluder_hides_the_bim_wall(tmp_path):
    path = tmp_path / "scaffold.obj"
    occluder = trimesh.creation.box((4.0, 1.0, 4.0))
    occluder.apply_translation((0, 5, 0))
    occluder.export(path)
    reality = load_reality(path, patch_area_m2=4.0, cache=False)
    bim = replace(_wall_scene(), metadata={"georeference": {"source": "test"}})
    combined = combine(bim, reality)
    assert combined.n_elements == 1 + reality.n_elements
    assert combined.elements.global_id[0] == "wall"
    assert combined.elements.is_target.tolist() == [True] + [False] * reality.n_elements
    assert combined.metadata["georeference"] == {"source": "test"}
    assert combined.metadata["reality"]["source"] == str(path) and combined.metadata["reality"]["role"] == "occluder"

    plan = _one_frame_plan()
    settings = EvaluationSettings(feature_density=0.0)
    alone = evaluate(bim, plan, settings, cache_dir=False)
    # the wall spans ±0.1 rad: 60 × 60 px at f = 300 px
    assert pixel_counts(alone.observations)[0, 0] == pytest.approx(3600, rel=0.05)
    assert alone.metrics.plan.z == 1 and alone.metrics.plan.VC == 1.0

    hidden = evaluate(combined, plan, settings, cache_dir=False)
    counts = pixel_counts(hidden.observations)[0]
    assert counts[0] == 0 and counts[1:].sum() > 0  # the occluder is seen, the wall is not
    assert hidden.metrics.plan.z == 1 and hidden.metrics.plan.VC == 0.0  # occluder patches are not in z

    as_targets = evaluate(combine(bim, reality, reality_role="target"), plan, settings, cache_dir=False)
    assert as_targets.metrics.plan.z == 1 + reality.n_elements


def test_combine_keeps_a_dated_bim_and_checks_frames(tmp_path):
    wall = _wall_scene()
    dated_bim = Scene.from_arrays(wall.vertices, wall.faces, wall.face_element,
                                  wall.elements.with_dates(np.array(["2024-01-01"], "datetime64[s]"),
                                                           np.array(["2024-02-01"], "datetime64[s]")))
    occ = trimesh.creation.box((1, 1, 1))
    reality = Scene.from_arrays(occ.vertices + [0, 5, 0], occ.faces, np.zeros(12), ElementTable.build(["patch 00001"]))
    built = combine(dated_bim, reality).at("2024-03-01")  # undated reality patches exist at every date
    assert built.present.tolist() == [True, True] and built.targets.tolist() == [True, False]
    already = combine(dated_bim.at("2024-03-01"), reality)
    assert already.date == built.date and already.present.tolist() == [True, True] and len(already.faces) == 14
    with pytest.raises(ModelError, match="same frame"):
        combine(wall, Scene.from_arrays(occ.vertices + GEO_OFFSET, occ.faces, np.zeros(12), ElementTable.build(["p"])))
    with pytest.raises(ModelError, match="role"):
        combine(wall, reality, reality_role="context")


# --------------------------------------------------------------------------- bad input
def test_bad_point_clouds(tmp_path, box_points):
    empty = tmp_path / "empty.ply"
    empty.write_bytes(b"")
    with pytest.raises(ModelError, match="empty"):
        read_point_cloud(empty)
    with pytest.raises(ModelError, match="empty"):
        load_model(empty, cache=False)
    no_points = tmp_path / "none.ply"
    no_points.write_text("ply\nformat ascii 1.0\nelement vertex 0\nproperty float x\nproperty float y\nproperty float z\n"
                         "end_header\n")
    with pytest.raises(ModelError, match="has no points"):
        load_model(no_points, cache=False)
    with pytest.raises(ModelError, match="has no points"):
        load_reality(no_points, cache=False)

    las = tmp_path / "nan.las"
    write_las(las, box_points[:100])
    raw = bytearray(las.read_bytes())
    raw[131:139] = struct.pack("<d", float("nan"))  # the header's X scale factor (LAS 1.2 § public header)
    las.write_bytes(bytes(raw))
    with pytest.raises(ModelError, match=r"nan.las: 100 of 100 points have non-finite coordinates"):
        read_point_cloud(las)
    with pytest.raises(ModelError, match="non-finite"):
        load_model(las, cache=False)

    with pytest.raises(ModelError, match="not found"):
        read_point_cloud(tmp_path / "missing.laz")
    with pytest.raises(ModelError, match="not found"):
        load_reality(tmp_path / "missing.las")
    with pytest.raises(ModelError, match="not found"):
        load_model(tmp_path / "missing.las")

    garbage = tmp_path / "garbage.las"
    garbage.write_bytes(b"LASF" + b"\0" * 50)
    with pytest.raises(ModelError, match="cannot be read as LAS/LAZ"):
        load_model(garbage, cache=False)

    with pytest.raises(ModelError, match="too sparse"):
        points_to_mesh(box_points[:500], spacing_m=0.02)  # points ~0.7 m apart, voxels 2 cm
    with pytest.raises(ModelError, match="too sparse"):
        points_to_mesh(box_points[:5])
    with pytest.raises(ModelError, match="voxels"):
        points_to_mesh(np.array([[0, 0, 0], [1000, 1000, 1000.0]] * 10), spacing_m=0.01)
    if importlib.util.find_spec("open3d") is None:
        with pytest.raises(ModelError, match="needs Open3D"):
            points_to_mesh(box_points, method="poisson")


def test_both_sides_of_a_scanned_surface_are_one_element(cloud_files):
    # the 10 × 6 × 4 m box has 248 m² of surface: about 248 / 20 ≈ 12 patches of 20 m², whose voxel shell has a
    # face on each side; without merging the sides there would be about twice as many elements
    from sightplan.model.pointcloud import merge_shell_sides

    scene, _ = load_model(cloud_files["ply"], cache=False, patch_area_m2=20.0)
    assert 8 <= scene.n_elements <= 18
    sides, n_sides = patch_faces(scene.vertices, scene.faces, 20.0)
    assert n_sides >= 1.7 * scene.n_elements
    merged, n = merge_shell_sides(scene.vertices, scene.faces, sides, scene.metadata["reality"]["spacing_m"])
    assert n == scene.n_elements and (merged == scene.face_element).all()
    # each element holds faces facing both ways: one surface seen from either side
    tri = scene.vertices[scene.faces]
    normal = np.cross(tri[:, 1] - tri[:, 0], tri[:, 2] - tri[:, 0])
    centre = tri.mean(axis=1) - np.array([0.0, 0.0, 2.0])  # the box's centre
    outward = np.einsum("ij,ij->i", normal, centre) > 0
    both = [outward[scene.face_element == e].any() and (~outward[scene.face_element == e]).any()
            for e in range(scene.n_elements)]
    assert np.mean(both) > 0.9


def test_laz_points_are_bounded_before_they_are_unpacked(tmp_path, monkeypatch):
    """A LAZ bomb (points that compress to almost nothing) and a header declaring more points than exist are refused
    before any point is decompressed or allocated, by the whole-file and the streaming reader alike."""
    from sightplan.model.pointcloud import PointChunkReader

    flat = np.zeros((200_000, 3)) + [10.0, 20.0, 30.0]  # 200,000 identical 34-byte records: ~6.5 MB from a few kB
    bomb = tmp_path / "bomb.laz"
    write_las(bomb, flat)
    assert bomb.stat().st_size < 100_000
    monkeypatch.setenv("SIGHTPLAN_MAX_UNPACKED_MB", "1")
    for read in (read_point_cloud, PointChunkReader):
        with pytest.raises(ModelError, match=r"bomb.laz \(200,000 points\) unpacks to 6 MB, over the limit of 1 MB"):
            read(bomb)
    monkeypatch.setenv("SIGHTPLAN_MAX_UNPACKED_MB", "8")
    assert len(read_point_cloud(bomb).points) == 200_000  # under the limit it reads

    lying = tmp_path / "lying.las"  # an uncompressed file whose header claims 10⁹ points
    write_las(lying, flat[:100])
    raw = bytearray(lying.read_bytes())
    raw[107:111] = struct.pack("<I", 1_000_000_000)  # legacy number of point records (LAS 1.2 § public header)
    lying.write_bytes(bytes(raw))
    for read in (read_point_cloud, PointChunkReader):
        with pytest.raises(ModelError, match="declares 1,000,000,000 points of 34 bytes, more than the file holds"):
            read(lying)
