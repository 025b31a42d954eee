"""Progress series: the same plan at several dates of a 4D model."""

from __future__ import annotations

import numpy as np
import pytest
import trimesh

from sightplan.camera.models import PinholeCamera
from sightplan.errors import ScheduleError
from sightplan.evaluate import EvaluationSettings
from sightplan.geometry.poses import R_from_gimbal
from sightplan.model.scene import ElementTable, Scene
from sightplan.plan.types import Plan
from sightplan.series import evaluate_series, schedule_days


def two_walls() -> Scene:
    """Wall B (4 × 3 m, 0.2 m thick) at y = 20 finished on 1 Feb 2025; wall A, wider (8 × 5 m), at y = 10 in
    front of it, finished on 1 Mar 2025. A camera at the origin looking north sees B until A stands."""
    parts, fe = [], []
    for k, (size, centre) in enumerate((((8.0, 0.2, 5.0), (0.0, 10.0, 1.5)), ((4.0, 0.2, 3.0), (0.0, 20.0, 1.5)))):
        m = trimesh.creation.box(size, trimesh.transformations.translation_matrix(centre))
        parts.append(m)
        fe.append(np.full(len(m.faces), k))
    mesh = trimesh.util.concatenate(parts)
    el = ElementTable.build(["A", "B"], finish=["2025-03-01", "2025-02-01"])
    return Scene.from_arrays(mesh.vertices, mesh.faces, np.concatenate(fe), el)


def plan() -> Plan:
    cam = PinholeCamera(400, 300, 300.0, 300.0, 200.0, 150.0, name="test")
    return Plan.build(cam, R_from_gimbal([0.0], [0.0]), np.array([[0.0, 0.0, 1.5]]))


def test_series_builds_up_and_reuses_unchanged_states(tmp_path):
    scene = two_walls()
    settings = EvaluationSettings(engine="embree", feature_density=0.0)
    days = ["2025-01-15", "2025-02-15", "2025-02-20", "2025-03-15", "2026-01-01"]
    series = evaluate_series(scene, plan(), days, settings, cache_dir=False)
    rows = {r["date"]: r for r in series.rows()}
    assert rows["2025-01-15"]["built"] == 0 and rows["2025-01-15"]["VC"] is None  # nothing stands yet
    assert rows["2025-02-15"]["built"] == 1 and rows["2025-02-15"]["VC"] == pytest.approx(100.0)  # B seen
    assert rows["2025-02-20"]["same_as"] == "2025-02-15"  # nothing changed: not cast again
    # A stands and hides B: one of the two elements seen. Before A was built it hid nothing.
    assert rows["2025-03-15"]["built"] == 2 and rows["2025-03-15"]["VC"] == pytest.approx(50.0)
    ev = {p.date: p.evaluation for p in series.points}
    pixels_b_alone = ev["2025-02-15"].observations.count[ev["2025-02-15"].observations.element == 1].sum()
    assert pixels_b_alone > 0
    assert not (ev["2025-03-15"].observations.element == 1).any()
    assert series.warnings == ("2025-03-15, 2026-01-01 after the schedule's last date 2025-03-01: everything scheduled stands",)
    png = series.plot(tmp_path / "series.png")
    assert png.stat().st_size > 10_000
    text = series.write_csv(tmp_path / "series.csv").read_text()
    assert text.splitlines()[0].startswith("date,built,VC,")


def test_schedule_days_and_bad_dates():
    scene = two_walls()
    assert schedule_days(scene) == ["2025-02-01", "2025-03-01"]
    with pytest.raises(ScheduleError, match="no element stands"):
        evaluate_series(scene, plan(), ["2024-01-01"], EvaluationSettings(feature_density=0.0), cache_dir=False)
    with pytest.raises(ScheduleError):
        evaluate_series(scene, plan(), ["2025-13-01"], cache_dir=False)
    undated = Scene.from_arrays(scene.vertices, scene.faces, scene.face_element, ElementTable.build(["A", "B"]))
    with pytest.raises(ScheduleError, match="link a schedule"):
        schedule_days(undated)
