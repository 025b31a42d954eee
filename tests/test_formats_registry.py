"""The format registry: every module of sightplan/formats that declares a FORMAT is found, without a list to edit;
names and written suffixes are unique, detection is unambiguous, the option types are the registry's, and every
format written that sightplan also reads gives its plan back through its own reader."""

from __future__ import annotations

import ast
import textwrap
from pathlib import Path
from typing import get_args

import numpy as np
import pytest

from geoid_support import require_geoid
from sightplan.export import EXTENSIONS, export_plan
from sightplan.formats import registry
from sightplan.formats.base import FlightFormat
from sightplan.geometry.poses import gimbal_from_R
from sightplan.plan.load import PlanFormat, detect_format, load_plan
from test_exports import GEOREFS, TAKEOFF, angle_diff, facade_plan

FOLDER = Path(registry.__file__).parent


def declares_format(path: Path) -> bool:
    return any(isinstance(node, ast.Assign) and any(isinstance(t, ast.Name) and t.id == "FORMAT" for t in node.targets)
               for node in ast.parse(path.read_text()).body)


def test_every_module_that_declares_a_format_is_found():
    declared = sorted(p.stem for p in FOLDER.glob("*.py") if declares_format(p))
    assert declared == sorted(registry.FORMATS)  # one module per format, named after it
    assert {"sightplan", "opensfm", "csv", "colmap", "qgc", "wpl", "wpml", "litchi", "kml", "geojson"} <= set(declared)
    for name, spec in registry.FORMATS.items():
        assert spec.name == name and spec.label
        assert spec.read is not None or spec.write is not None, name


def test_a_new_module_is_found_without_editing_a_list(tmp_path, monkeypatch):
    package = tmp_path / "more_formats"
    package.mkdir()
    (package / "__init__.py").write_text("")
    (package / "helpers.py").write_text("X = 1\n")  # no FORMAT: not a format
    (package / "dxf.py").write_text(textwrap.dedent("""
        from sightplan.formats.base import FlightFormat
        FORMAT = FlightFormat(name="dxf", label="DXF", suffix=".dxf", write=lambda flight, path, target: [path])
    """))
    monkeypatch.syspath_prepend(str(tmp_path))
    assert list(registry.discover(package, "more_formats")) == ["dxf"]
    (package / "dxf2.py").write_text("from more_formats.dxf import FORMAT\n")
    with pytest.raises(RuntimeError, match="dxf"):
        registry.discover(package, "more_formats")


def test_names_and_written_suffixes_are_unique_and_detection_is_unambiguous():
    writers = registry.WRITERS
    assert len({f.suffix for f in writers}) == len(writers) and all(f.suffix.startswith(".") for f in writers)
    claims: dict[str, list[FlightFormat]] = {}
    for f in registry.READERS:
        for suffix in f.suffixes:
            claims.setdefault(suffix, []).append(f)
    for suffix, formats in claims.items():
        if len(formats) > 1:  # told apart by content: at most one takes what no sniff recognises
            assert sum(f.sniff is None for f in formats) <= 1, suffix
            assert all(f.what for f in formats if f.sniff is not None), suffix
    assert sum(f.folder for f in registry.READERS) <= 1


def test_the_option_types_are_the_registrys():
    assert get_args(registry.ExportFormat) == registry.EXPORT_FORMATS == tuple(f.name for f in registry.WRITERS)
    listed = ("qgc", "wpl", "wpml", "litchi", "kml", "geojson")  # the CLI's order, kept by the records' ``order``
    assert tuple(n for n in registry.EXPORT_FORMATS if n in listed) == listed
    assert tuple(n for n in registry.PLAN_FORMATS if n in listed) == ("qgc", "wpl", "wpml", "litchi")
    assert registry.PLAN_FORMATS[:4] == ("sightplan", "opensfm", "csv", "colmap")
    assert get_args(PlanFormat) == registry.PLAN_FORMATS == tuple(f.name for f in registry.READERS)
    assert EXTENSIONS == {f.name: f.suffix for f in registry.WRITERS}
    assert registry.export_choices().startswith("qgc (QGroundControl .plan), wpl (")


READ_AND_WRITTEN = [f.name for f in registry.WRITERS if f.read is not None]


def test_the_formats_read_and_written():
    assert {"qgc", "wpl", "wpml", "litchi"} <= set(READ_AND_WRITTEN)


@pytest.mark.parametrize("fmt", READ_AND_WRITTEN)
def test_every_format_written_reads_back_through_its_own_reader(tmp_path, fmt):
    require_geoid()  # DJI's take-off reference height is ellipsoidal
    georef, _ = GEOREFS["topocentric"]
    plan = facade_plan()
    paths = export_plan(plan, fmt, tmp_path / f"facade{registry.FORMATS[fmt].suffix}", georef, TAKEOFF)
    assert len(paths) == 2  # a file per mission
    assert [detect_format(p) for p in paths] == [fmt, fmt]
    back = [load_plan(p, georef=georef, camera="m3e") for p in paths]
    assert [b.parameters["source"]["format"] for b in back] == [fmt, fmt]
    np.testing.assert_allclose(np.vstack([b.C_world for b in back]), plan.C_world, atol=0.1)
    h0, p0, _ = gimbal_from_R(plan.R_world_camera)
    h1, p1, _ = (np.concatenate(v) for v in zip(*(gimbal_from_R(b.R_world_camera) for b in back)))
    assert max(angle_diff(a, b) for a, b in zip(h0, h1)) < 0.01
    np.testing.assert_allclose(p1, p0, atol=0.01)
