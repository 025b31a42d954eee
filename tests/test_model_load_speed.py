"""Loading a Revit-like furnished model (benchmarks/revit_like.py, tiny): shared furniture geometry
placed per occurrence, the triangle guard, progress from the first moment. No timing assertions."""

from __future__ import annotations

import importlib.util
import sys
from pathlib import Path

import ifcopenshell
import ifcopenshell.geom
import numpy as np
import pytest

from sightplan.model import load_model, summarize
from sightplan.model.ifc import load_ifc

BENCHMARKS = Path(__file__).resolve().parents[1] / "benchmarks"


def _revit_like():
    spec = importlib.util.spec_from_file_location("revit_like", BENCHMARKS / "revit_like.py")
    module = importlib.util.module_from_spec(spec)
    sys.modules.setdefault("revit_like", module)
    spec.loader.exec_module(module)
    return module


@pytest.fixture(scope="module")
def tiny(tmp_path_factory) -> tuple[Path, dict]:
    generator = _revit_like()
    path = tmp_path_factory.mktemp("revit-like") / "tiny.ifc"
    info = generator.write_revit_like_ifc(path, **generator.TINY)
    return path, info


@pytest.fixture(scope="module")
def loaded(tiny):
    return load_ifc(tiny[0])


def _bounds(scene, index: int) -> tuple[np.ndarray, np.ndarray]:
    v = scene.vertices[scene.faces[scene.face_element == index].ravel()]
    return v.min(axis=0), v.max(axis=0)


def test_tiny_model_is_small_and_revit_shaped(tiny):
    path, info = tiny
    f = ifcopenshell.open(str(path))
    assert f.schema == "IFC2X3" and info["bytes"] < 2**20
    furniture = f.by_type("IfcFurnishingElement")
    assert len(furniture) == info["by_class"]["IfcFurnishingElement"] > 50
    # every occurrence is a mapped item of its type's one representation map
    maps = {p.Representation.Representations[0].Items[0].MappingSource.id() for p in furniture}
    assert len(maps) == info["furniture_types"] == len(f.by_type("IfcFurnitureType"))
    assert len(f.by_type("IfcRelVoidsElement")) == len(f.by_type("IfcRelFillsElement")) == len(f.by_type("IfcOpeningElement"))
    assert f.by_type("IfcBooleanClippingResult") and f.by_type("IfcCircleProfileDef") and f.by_type("IfcFacetedBrep")


def test_every_occurrence_is_an_element_with_its_own_placement(tiny, loaded):
    path, info = tiny
    scene, report = loaded
    assert report.n_elements == info["elements"] and not report.skipped and not report.fallbacks
    assert sorted(report.excluded) == ["IfcOpeningElement", "IfcSpace"]
    s = summarize(scene, report)
    assert {k: v["elements"] for k, v in s["by_class"].items()} == info["by_class"]
    assert s["elements_without_triangles"] == 0 and report.peak_rss_mb > 0
    names = list(scene.elements.name)
    plants = [i for i, n in enumerate(names) if n.startswith("Plant:1.01.")]
    assert len(plants) == 2  # two occurrences of one type in the first room, 8 m and 6 m apart
    (lo_a, hi_a), (lo_b, hi_b) = (_bounds(scene, i) for i in plants)
    assert hi_a - lo_a == pytest.approx(hi_b - lo_b, rel=0.03)
    assert (lo_b + hi_b) / 2 - (lo_a + hi_a) / 2 == pytest.approx([8.0, 6.0, 0.0], abs=0.1)
    assert lo_a[2] == pytest.approx(0.0, abs=1e-6) and hi_a[2] == pytest.approx(1.6, abs=1e-3)
    chairs = [i for i, n in enumerate(names) if n.startswith("Chair:")]
    n_tri = np.bincount(scene.face_element, minlength=len(names))
    assert len(set(n_tri[chairs].tolist())) == 1  # one triangulation, placed per occurrence


def test_local_tessellation_matches_the_kernels_world_coordinates(tiny, loaded):
    """Shared geometry is tessellated once and placed in numpy: the same as the kernel's world output."""
    path, _ = tiny
    scene, _ = loaded
    f = ifcopenshell.open(str(path))
    settings = ifcopenshell.geom.settings()
    settings.set("use-world-coords", True)
    ids = list(scene.elements.global_id)
    picks = [f.by_type(c)[k] for c in ("IfcWallStandardCase", "IfcDoor", "IfcWindow", "IfcFurnishingElement")
             for k in (0, -1)]
    for product in picks:
        shape = ifcopenshell.geom.create_shape(settings, product)
        v = np.frombuffer(shape.geometry.verts_buffer, dtype=np.float64).reshape(-1, 3)
        lo, hi = _bounds(scene, ids.index(product.GlobalId))
        np.testing.assert_allclose(lo, v.min(axis=0), atol=1e-9)
        np.testing.assert_allclose(hi, v.max(axis=0), atol=1e-9)
        assert (scene.face_element == ids.index(product.GlobalId)).sum() == len(shape.geometry.faces) // 3


def test_a_product_over_the_triangle_guard_falls_back_to_its_box(tiny, loaded):
    path, _ = tiny
    full, _ = loaded
    names = list(full.elements.name)
    n_tri = np.bincount(full.face_element, minlength=len(names))
    sofa = names.index(next(n for n in names if n.startswith("Sofa:")))
    limit = int(n_tri[sofa]) - 1  # the sofa (and anything as detailed) is over it
    over = {names[i] for i in np.flatnonzero(n_tri > limit)}
    scene, report = load_ifc(path, max_triangles=limit)
    assert list(scene.elements.global_id) == list(full.elements.global_id)
    assert {fb.name for fb in report.fallbacks} == over
    assert all("bounding box" in fb.reason and f"> {limit:,}" in fb.reason for fb in report.fallbacks)
    boxed = np.bincount(scene.face_element, minlength=len(names))
    assert boxed[sofa] == 12 and all(boxed[names.index(n)] == 12 for n in over)
    lo, hi = _bounds(scene, sofa)
    lo_full, hi_full = _bounds(full, sofa)  # the box holds the sofa (in the sofa's own axes, so a little larger)
    assert np.all(lo <= lo_full + 1e-9) and np.all(hi >= hi_full - 1e-9) and np.all(hi - lo < (hi_full - lo_full) * 1.2)
    assert summarize(scene, report)["fallbacks"][0]["reason"] == report.fallbacks[0].reason

    skipped_scene, skipped_report = load_ifc(path, max_triangles=limit, oversize="skip")
    assert skipped_report.n_elements == len(names) - len(over)
    assert {s.name for s in skipped_report.skipped} == over == {fb.name for fb in skipped_report.fallbacks}
    assert sofa not in set(skipped_scene.elements.name)
    with pytest.raises(ValueError, match="oversize"):
        load_ifc(path, oversize="ignore")


def test_fallbacks_survive_the_cache(tiny, tmp_path):
    path, _ = tiny
    first = load_model(path, cache=True, cache_dir=tmp_path, max_triangles=1000)[1]
    second = load_model(path, cache=True, cache_dir=tmp_path, max_triangles=1000)[1]
    assert second.from_cache and second.fallbacks == first.fallbacks and first.fallbacks
    assert second.peak_rss_mb == first.peak_rss_mb > 0
    assert not load_model(path, cache=True, cache_dir=tmp_path)[1].from_cache  # another guard, another scene


def test_progress_starts_at_once_is_monotone_and_reaches_one(tiny):
    path, _ = tiny
    shares: list[float] = []
    states = []
    load_ifc(path, progress=shares.append, status=states.append)
    assert shares[0] == 0.0 and shares == sorted(shares) and shares[-1] == 1.0 and len(shares) > 3
    phases = [s.phase for s in states]
    assert phases[0] == "reading" and phases[-1] == "done"
    order = ["reading", "tessellating", "assembling", "done"]
    assert [p for i, p in enumerate(phases) if i == 0 or phases[i - 1] != p] == order
    tess = [s for s in states if s.phase == "tessellating"]
    assert tess[-1].done == tess[-1].total > 50 and all(0 <= s.done <= s.total for s in tess)
    assert [s.done for s in tess] == sorted(s.done for s in tess)
    # each product's note names the one finished last, and says so: the kernel tells no one what it works on now
    notes = [s.message for s in tess[1:-1]]
    assert notes and all(m.startswith("after Ifc") and m.endswith("'") for m in notes), notes[:3]
    assert all(s.eta_s is None or s.eta_s >= 0 for s in states) and [s.elapsed_s for s in states] == sorted(
        s.elapsed_s for s in states)


def _mirrored_furniture_ifc(path: Path) -> None:
    """One box-shaped furniture type placed twice through its representation map: as it is, and mirrored
    (a mapping operator with a left-handed axis, as exports write mirrored family instances)."""
    f = ifcopenshell.file(schema="IFC4")
    pt = f.createIfcCartesianPoint
    d = f.createIfcDirection
    origin = f.createIfcAxis2Placement3D(pt((0.0, 0.0, 0.0)), None, None)
    context = f.createIfcGeometricRepresentationContext(None, "Model", 3, 1e-5, origin, None)
    body = f.createIfcGeometricRepresentationSubContext("Body", "Model", None, None, None, None, context, None,
                                                        "MODEL_VIEW", None)
    units = f.createIfcUnitAssignment([f.createIfcSIUnit(None, "LENGTHUNIT", None, "METRE")])
    project = f.createIfcProject(ifcopenshell.guid.new(), None, "p", None, None, None, None, [context], units)
    # an L-shaped block off its own origin, so a mirror really moves and turns it
    profile = f.createIfcArbitraryClosedProfileDef("AREA", None, f.createIfcPolyline(
        [pt(c) for c in ((0.5, 0.0), (2.0, 0.0), (2.0, 0.5), (1.0, 0.5), (1.0, 1.5), (0.5, 1.5), (0.5, 0.0))]))
    solid = f.createIfcExtrudedAreaSolid(profile, origin, d((0.0, 0.0, 1.0)), 0.8)
    rep_map = f.createIfcRepresentationMap(origin, f.createIfcShapeRepresentation(body, "Body", "SweptSolid", [solid]))
    ops = [f.createIfcCartesianTransformationOperator3D(None, None, pt((0.0, 0.0, 0.0)), None, None),
           f.createIfcCartesianTransformationOperator3D(d((-1.0, 0.0, 0.0)), d((0.0, 1.0, 0.0)), pt((0.0, 0.0, 0.0)),
                                                         None, d((0.0, 0.0, 1.0)))]
    site = f.createIfcSite(ifcopenshell.guid.new(), None, "site", None, None,
                           f.createIfcLocalPlacement(None, origin), None, None, "ELEMENT")
    f.createIfcRelAggregates(ifcopenshell.guid.new(), None, None, None, project, [site])
    items = []
    for i, op in enumerate(ops):
        placement = f.createIfcLocalPlacement(None, f.createIfcAxis2Placement3D(pt((5.0 * i, 0.0, 0.0)), None, None))
        shape = f.createIfcProductDefinitionShape(None, None, [f.createIfcShapeRepresentation(
            body, "Body", "MappedRepresentation", [f.createIfcMappedItem(rep_map, op)])])
        items.append(f.createIfcFurniture(ifcopenshell.guid.new(), None, f"chair {i}", None, None, placement, shape,
                                          None, None))
    f.createIfcRelContainedInSpatialStructure(ifcopenshell.guid.new(), None, None, None, items, site)
    f.write(str(path))


def test_a_mirrored_occurrence_keeps_its_faces_outward(tmp_path):
    path = tmp_path / "mirrored.ifc"
    _mirrored_furniture_ifc(path)
    scene, _ = load_ifc(path)
    assert scene.n_elements == 2
    normals = scene.face_normals()
    for e in range(2):
        sel = scene.face_element == e
        v = scene.vertices[scene.faces[sel]]  # (m, 3, 3)
        # a closed solid wound outward has a positive signed volume (divergence theorem)
        volume = np.einsum("ij,ij->i", v[:, 0], np.cross(v[:, 1], v[:, 2])).sum() / 6.0
        assert volume == pytest.approx(0.8 * (1.5 * 0.5 + 0.5 * 1.0), rel=1e-6)
        assert np.isfinite(normals[sel]).all()
    lo0, hi0 = _bounds(scene, 0)
    lo1, hi1 = _bounds(scene, 1)
    np.testing.assert_allclose([lo0[0], hi0[0]], [0.5, 2.0], atol=1e-9)
    np.testing.assert_allclose([lo1[0], hi1[0]], [5.0 - 2.0, 5.0 - 0.5], atol=1e-9)  # mirrored in x, then placed
