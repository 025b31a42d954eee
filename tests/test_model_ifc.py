"""IFC loading: one-wall models built in code (answers known analytically) and real models from ../shared/data."""

from __future__ import annotations

import time
from pathlib import Path

import ifcopenshell
import ifcopenshell.api
import ifcopenshell.api.aggregate
import ifcopenshell.api.context
import ifcopenshell.api.geometry
import ifcopenshell.api.project
import ifcopenshell.api.pset
import ifcopenshell.api.root
import ifcopenshell.api.spatial
import ifcopenshell.api.type
import ifcopenshell.api.unit
import ifcopenshell.guid
import numpy as np
import pytest

from sightplan.errors import ModelError
from sightplan.model import load_model, sample_model_path, summarize
from sightplan.model.disciplines import discipline_of
from sightplan.model.ifc import EXCLUDED_CLASSES, load_ifc

SHARED = Path(__file__).resolve().parents[1].parent / "shared" / "data"
UNIT_SCALE = {"m": 1.0, "mm": 0.001, "inch": 0.0254}
WALL_ORIGIN = np.array([10.0, 20.0, 0.0])  # metres
WALL_SIZE = np.array([4.0, 0.2, 3.0])  # length, thickness, height in metres


@pytest.fixture
def shared_data() -> Path:
    if not SHARED.is_dir():
        pytest.skip(f"shared data not found at {SHARED}")
    return SHARED


def _shared_file(root: Path, rel: str) -> Path:
    path = root / rel
    if not path.is_file():
        pytest.skip(f"{rel} not in shared data")
    return path


def _box(f, context, size, origin, product) -> None:
    """A size=(x, y, z) metre box at ``origin`` (metres) as the product's Body."""
    rep = ifcopenshell.api.geometry.add_wall_representation(f, context=context, length=size[0], height=size[2], thickness=size[1])
    ifcopenshell.api.geometry.assign_representation(f, product=product, representation=rep)
    matrix = np.eye(4)
    matrix[:3, 3] = origin
    ifcopenshell.api.geometry.edit_object_placement(f, product=product, matrix=matrix, is_si=True)


def _new_file(version: str) -> ifcopenshell.file:
    """An empty file; IFC2X3 needs an owner history, hence a user and an application."""
    f = ifcopenshell.api.project.create_file(version=version)
    if version == "IFC2X3":
        org = f.createIfcOrganization(Name="sightplan tests")
        f.createIfcPersonAndOrganization(f.createIfcPerson(FamilyName="Tester"), org)
        f.createIfcApplication(org, "1", "sightplan tests", "sightplan")
    return f


def make_ifc(path: Path, *, version: str = "IFC4", unit: str = "m", load_bearing: bool = False) -> Path:
    """A storey with a 4 × 0.2 × 3 m wall at (10, 20, 0), plus one product of each special kind.

    Also: a 1 m furniture box (occluder), a beam with an Axis only (skipped), a stair
    without geometry aggregating a flight (container + element), an IfcSpace and an
    IfcVirtualElement with boxes (excluded), an IfcAnnotation (excluded).
    """
    api = ifcopenshell.api
    f = _new_file(version)
    project = api.root.create_entity(f, ifc_class="IfcProject", name="P")
    if unit == "m":
        length = api.unit.add_si_unit(f, unit_type="LENGTHUNIT")
    elif unit == "mm":
        length = api.unit.add_si_unit(f, unit_type="LENGTHUNIT", prefix="MILLI")
    else:
        length = api.unit.add_conversion_based_unit(f, name=unit)
    api.unit.assign_unit(f, units=[length])
    model = api.context.add_context(f, context_type="Model")
    body = api.context.add_context(f, context_type="Model", context_identifier="Body", target_view="MODEL_VIEW", parent=model)
    axis = api.context.add_context(f, context_type="Model", context_identifier="Axis", target_view="GRAPH_VIEW", parent=model)
    site = api.root.create_entity(f, ifc_class="IfcSite", name="Site")
    building = api.root.create_entity(f, ifc_class="IfcBuilding", name="B")
    storey = api.root.create_entity(f, ifc_class="IfcBuildingStorey", name="Level 0")
    api.aggregate.assign_object(f, products=[site], relating_object=project)
    api.aggregate.assign_object(f, products=[building], relating_object=site)
    api.aggregate.assign_object(f, products=[storey], relating_object=building)

    wall = api.root.create_entity(f, ifc_class="IfcWall", name="Wall 1")
    _box(f, body, WALL_SIZE, WALL_ORIGIN, wall)
    if load_bearing:
        pset = api.pset.add_pset(f, product=wall, name="Pset_WallCommon")
        api.pset.edit_pset(f, pset=pset, properties={"LoadBearing": True})
    chair = api.root.create_entity(f, ifc_class="IfcFurnishingElement", name="Chair")
    _box(f, body, (1.0, 1.0, 1.0), (0.0, 0.0, 0.0), chair)
    beam = api.root.create_entity(f, ifc_class="IfcBeam", name="Axis-only beam")
    rep = api.geometry.add_axis_representation(f, context=axis, axis=[(0.0, 0.0, 0.0), (5.0, 0.0, 0.0)])
    api.geometry.assign_representation(f, product=beam, representation=rep)
    stair = api.root.create_entity(f, ifc_class="IfcStair", name="Stair")
    flight = api.root.create_entity(f, ifc_class="IfcStairFlight", name="Flight")
    _box(f, body, (2.0, 1.0, 0.5), (20.0, 0.0, 0.0), flight)
    api.aggregate.assign_object(f, products=[flight], relating_object=stair)
    space = api.root.create_entity(f, ifc_class="IfcSpace", name="Room")
    _box(f, body, (5.0, 5.0, 3.0), (0.0, 0.0, 0.0), space)
    api.aggregate.assign_object(f, products=[space], relating_object=storey)
    virtual = api.root.create_entity(f, ifc_class="IfcVirtualElement", name="Boundary")
    _box(f, body, (1.0, 1.0, 1.0), (-5.0, 0.0, 0.0), virtual)
    api.root.create_entity(f, ifc_class="IfcAnnotation", name="Note")
    api.spatial.assign_container(f, products=[wall, chair, beam, stair, virtual], relating_structure=storey)
    f.write(str(path))
    return path


def _element_mesh(scene, global_id: str) -> tuple[np.ndarray, np.ndarray]:
    idx = list(scene.elements.global_id).index(global_id)
    tri = scene.vertices[scene.faces[scene.face_element == idx]]
    return tri, scene.face_areas()[scene.face_element == idx]


def _volume(tri: np.ndarray) -> float:
    """Enclosed volume of a closed triangle set (divergence theorem), independent of the loader."""
    return float(abs(np.einsum("ij,ij->i", tri[:, 0], np.cross(tri[:, 1], tri[:, 2])).sum()) / 6.0)


# --------------------------------------------------------------------- built in code
@pytest.mark.parametrize("version", ["IFC4", "IFC2X3"])
@pytest.mark.parametrize("unit", ["m", "mm", "inch"])
def test_wall_in_metres_whatever_the_unit(tmp_path, version, unit):
    path = make_ifc(tmp_path / f"wall_{unit}.ifc", version=version, unit=unit)
    raw = ifcopenshell.open(str(path))
    depth = [s.Depth for s in raw.by_type("IfcExtrudedAreaSolid")][0]  # the file really stores file units
    assert depth == pytest.approx(WALL_SIZE[2] / UNIT_SCALE[unit])

    scene, report = load_ifc(path)
    wall_id = raw.by_type("IfcWall")[0].GlobalId
    tri, areas = _element_mesh(scene, wall_id)
    assert report.schema == version
    assert report.unit_scale == pytest.approx(UNIT_SCALE[unit])
    np.testing.assert_allclose(tri.reshape(-1, 3).min(0), WALL_ORIGIN, atol=1e-6)
    np.testing.assert_allclose(tri.reshape(-1, 3).max(0), WALL_ORIGIN + WALL_SIZE, atol=1e-6)
    assert areas.sum() == pytest.approx(2 * (4 * 3 + 4 * 0.2 + 3 * 0.2), rel=1e-6)  # 26.8 m²
    assert _volume(tri) == pytest.approx(4 * 0.2 * 3, rel=1e-6)  # 2.4 m³


def test_element_rules(tmp_path):
    path = make_ifc(tmp_path / "rules.ifc")
    scene, report = load_ifc(path)
    classes = set(scene.elements.ifc_class)
    assert classes == {"IfcWall", "IfcFurnishingElement", "IfcStairFlight"}
    assert not classes & set(EXCLUDED_CLASSES)
    assert report.excluded == {"IfcAnnotation": 1, "IfcSpace": 1, "IfcVirtualElement": 1}
    assert report.containers == {"IfcBuilding": 1, "IfcBuildingStorey": 1, "IfcSite": 1, "IfcStair": 1}
    [beam] = report.skipped
    assert (beam.ifc_class, beam.name) == ("IfcBeam", "Axis-only beam")
    assert beam.reason == "no Body representation (only Axis)"
    assert report.n_elements + len(report.skipped) + sum(report.excluded.values()) + sum(report.containers.values()) == (
        report.n_products
    )
    row = dict(zip(scene.elements.ifc_class, range(scene.n_elements)))
    assert not scene.elements.is_target[row["IfcFurnishingElement"]]  # furniture occludes only
    assert scene.elements.is_target[row["IfcWall"]] and scene.elements.is_target[row["IfcStairFlight"]]
    assert scene.elements.storey[row["IfcStairFlight"]] == "Level 0"  # found through the stair aggregate
    assert scene.elements.discipline[row["IfcWall"]] == "A"  # not load-bearing
    assert report.n_targets == 2 and report.n_triangles == 3 * 12

    scene_all, _ = load_ifc(path, include_occluders_as_targets=True)
    assert scene_all.elements.is_target.all()
    assert scene_all.content_hash != scene.content_hash  # options are part of the hash


def test_load_bearing_wall_is_structural_and_disciplines(tmp_path):
    scene, _ = load_ifc(make_ifc(tmp_path / "lb.ifc", load_bearing=True))
    assert scene.elements.discipline[list(scene.elements.ifc_class).index("IfcWall")] == "S"

    api = ifcopenshell.api
    f = _new_file("IFC2X3")
    light = api.root.create_entity(f, ifc_class="IfcFlowTerminal")
    api.type.assign_type(f, related_objects=[light], relating_type=api.root.create_entity(f, ifc_class="IfcLightFixtureType"))
    toilet = api.root.create_entity(f, ifc_class="IfcFlowTerminal")
    api.type.assign_type(
        f, related_objects=[toilet], relating_type=api.root.create_entity(f, ifc_class="IfcSanitaryTerminalType")
    )
    untyped = api.root.create_entity(f, ifc_class="IfcFlowSegment")
    column = api.root.create_entity(f, ifc_class="IfcColumn")
    proxy = api.root.create_entity(f, ifc_class="IfcBuildingElementProxy")
    got = [discipline_of(e, "IFC2X3") for e in (light, toilet, untyped, column, proxy)]
    assert got == ["E", "P", "M", "S", ""]
    g = api.project.create_file(version="IFC4")
    got4 = [
        discipline_of(g.create_entity(c, GlobalId=ifcopenshell.guid.new()), "IFC4")
        for c in ("IfcDuctSegment", "IfcCableSegment", "IfcPipeSegment", "IfcWindow")
    ]
    assert got4 == ["M", "E", "P", "A"]


def test_bad_files_raise_model_error(tmp_path):
    with pytest.raises(ModelError, match="not found"):
        load_ifc(tmp_path / "missing.ifc")
    text = tmp_path / "notes.ifc"
    text.write_text("just some text, not a model\n")
    with pytest.raises(ModelError, match="not an IFC file"):
        load_ifc(text)
    truncated = tmp_path / "truncated.ifc"
    truncated.write_bytes(sample_model_path().read_bytes()[:500_000])
    with pytest.raises(ModelError, match="truncated"):
        load_ifc(truncated)
    empty = tmp_path / "empty.ifc"
    empty.write_bytes(b"")
    with pytest.raises(ModelError, match="empty"):
        load_ifc(empty)

    f = ifcopenshell.api.project.create_file(version="IFC4")
    ifcopenshell.api.root.create_entity(f, ifc_class="IfcProject", name="P")
    ifcopenshell.api.root.create_entity(f, ifc_class="IfcWall", name="no geometry")
    f.write(str(tmp_path / "nogeom.ifc"))
    with pytest.raises(ModelError, match="no elements with geometry"):
        load_ifc(tmp_path / "nogeom.ifc")
    with pytest.raises(ModelError, match="supported:.*\\.ifc"):
        load_model(text.with_suffix(".dwg").write_text("x") and text.with_suffix(".dwg"), cache=False)


def test_ifczip(tmp_path):
    import zipfile

    path = make_ifc(tmp_path / "wall.ifc", unit="mm")
    with zipfile.ZipFile(tmp_path / "wall.ifczip", "w") as z:
        z.write(path, "wall.ifc")
    scene, report = load_model(tmp_path / "wall.ifczip", cache=False)
    assert report.n_elements == 3
    np.testing.assert_allclose(scene.bounds(), [[0, 0, 0], [22.0, 20.2, 3.0]], atol=1e-6)  # chair at 0, flight to x=22, wall


# --------------------------------------------------------------------- real models
def test_duplex_every_product_accounted_for():
    t0 = time.perf_counter()
    scene, report = load_model("sample", cache=False)
    elapsed = time.perf_counter() - t0
    f = ifcopenshell.open(str(sample_model_path()))
    assert report.schema == "IFC2X3" and report.unit_scale == 1.0
    assert report.n_products == len(f.by_type("IfcProduct")) == 295
    accounted = report.n_elements + len(report.skipped) + sum(report.excluded.values()) + sum(report.containers.values())
    assert accounted == report.n_products
    assert report.excluded == {"IfcOpeningElement": len(f.by_type("IfcOpeningElement")), "IfcSpace": len(f.by_type("IfcSpace"))}
    assert len(set(scene.elements.global_id)) == scene.n_elements == report.n_elements
    furniture = np.array([c == "IfcFurnishingElement" for c in scene.elements.ifc_class])
    assert furniture.sum() == len(f.by_type("IfcFurnishingElement"))
    assert not scene.elements.is_target[furniture].any() and scene.elements.is_target[~furniture].all()
    assert np.bincount(scene.face_element, minlength=scene.n_elements).min() > 0  # every element has triangles
    assert set(scene.elements.storey) <= {s.Name for s in f.by_type("IfcBuildingStorey")}
    assert set(scene.elements.discipline) == {"S", "A"}
    size = np.diff(scene.bounds(), axis=0)[0]
    assert 8 < size[0] < 10 and 20 < size[1] < 30 and 6 < size[2] < 10  # a two-family house, in metres
    assert scene.metadata["georeference"] is None
    info = summarize(scene, report)
    assert info["elements"] == report.n_elements and info["occluders"] == furniture.sum()
    assert sum(v["elements"] for v in info["by_storey"].values()) == report.n_elements
    import json

    json.dumps(info)
    print(f"duplex: {elapsed:.2f} s, {report.n_elements} elements, {report.n_triangles} triangles")


def test_inches_file_comes_out_in_metres(shared_data):
    path = _shared_file(shared_data, "ifc/construction_scheduling_task.ifc")
    scene, report = load_ifc(path)
    assert report.unit_scale == pytest.approx(0.0254)
    # Wall #1: footprint polyline x from -3 to 195 in (198 in), 6 in thick, extruded 120 in.
    tri, _ = _element_mesh(scene, "26tmERtwL8G8UQn5BoglEh")
    size = np.sort(np.ptp(tri.reshape(-1, 3), axis=0))
    np.testing.assert_allclose(size, np.sort([198 * 0.0254, 6 * 0.0254, 120 * 0.0254]), atol=1e-6)


def test_schependomlaan_steel(shared_data):
    path = _shared_file(shared_data, "schependomlaan/BERNTS-Staalconstructie.ifc")
    t0 = time.perf_counter()
    scene, report = load_ifc(path)
    elapsed = time.perf_counter() - t0
    classes = list(scene.elements.ifc_class)
    assert classes.count("IfcBeam") == 742 and classes.count("IfcColumn") == 56  # the data README's counts
    assert report.unit_scale == 0.001 and set(scene.elements.discipline) == {"S"}
    assert report.containers.get("IfcElementAssembly", 0) > 0  # assemblies are represented by their parts
    assert report.n_elements + len(report.skipped) + sum(report.excluded.values()) + sum(report.containers.values()) == (
        report.n_products
    )
    size = np.diff(scene.bounds(), axis=0)[0]
    assert (size > 5).all() and (size < 100).all()  # a house-sized frame in metres, not millimetres
    print(f"steel: {elapsed:.2f} s, {report.n_elements} elements, {report.n_triangles} triangles")


def test_map_conversion_is_carried(tmp_path):
    import ifcopenshell.api.georeference

    path = make_ifc(tmp_path / "geo.ifc", unit="mm")
    f = ifcopenshell.open(str(path))
    ifcopenshell.api.georeference.add_georeferencing(f)
    ifcopenshell.api.georeference.edit_georeferencing(
        f,
        projected_crs={"Name": "EPSG:28992"},
        coordinate_operation={"Eastings": 187000000.0, "Northings": 425000000.0, "OrthogonalHeight": 12000.0, "Scale": 1.0},
    )
    f.write(str(path))
    scene, _ = load_ifc(path)
    geo = scene.metadata["georeference"]
    assert geo["target_crs"] == "EPSG:28992" and geo["source"] == "IfcMapConversion"
    # no MapUnit on the CRS: eastings are in the project unit (mm) and come out in metres
    assert (geo["eastings_m"], geo["northings_m"], geo["orthogonal_height_m"]) == pytest.approx((187000.0, 425000.0, 12.0))


def test_failed_geometry_is_reported(tmp_path):
    path = make_ifc(tmp_path / "bad_geom.ifc")
    f = ifcopenshell.open(str(path))
    wall = f.by_type("IfcWall")[0]
    solid = f.by_type("IfcExtrudedAreaSolid")[0]
    assert wall.Representation.Representations[0].Items[0] == solid
    solid.SweptArea = f.createIfcRectangleProfileDef("AREA", None, None, 0.0, 0.0)  # a profile of zero area
    f.write(str(path))
    scene, report = load_ifc(path)
    assert wall.GlobalId not in set(scene.elements.global_id)
    [failed] = [s for s in report.skipped if s.global_id == wall.GlobalId]
    assert failed.reason == "geometry failed or empty"


def test_tessellation_reports_progress(tmp_path):
    from sightplan.model.load import load_model

    seen: list[float] = []
    load_model("sample", cache=False, progress=seen.append)
    assert len(seen) > 10 and seen == sorted(seen) and seen[0] < 0.2 and seen[-1] == pytest.approx(1.0, abs=0.02)
