"""The optimiser against the best template of the grid, and the one tolerance of the targets' bounds: views placed on
the 45° bound serve, and two plans 6·10⁻¹² m apart score the same."""

from __future__ import annotations

import re
from dataclasses import replace

import numpy as np
import pytest

from optimize_support import box_building
from sightplan.camera.models import PinholeCamera
from sightplan.engines.registry import available_engines
from sightplan.evaluate import EvaluationSettings, evaluate
from sightplan.model.scene import ElementTable, Scene
from sightplan.optimize import Scored, Targets, best_of, score_plan, template_grid
from sightplan.plan.checks.feasibility import FlightSettings
from sightplan.plan.types import Plan

pytestmark = pytest.mark.skipif(not available_engines(), reason="no visibility engine")


def look_at(C: np.ndarray, target: np.ndarray) -> np.ndarray:
    z = (target - C) / np.linalg.norm(target - C)
    x = np.cross(z, [0.0, 0.0, 1.0])
    x /= np.linalg.norm(x)
    return np.column_stack([x, np.cross(z, x), z])


def panels() -> Scene:
    """Eight wall panels in a row at y = 0, 5 m wide and 10 m high, facing south."""
    vertices, faces = [], []
    for k in range(8):
        x0 = -20.0 + 5 * k
        vertices += [(x0, 0, 0), (x0 + 5, 0, 0), (x0 + 5, 0, 10), (x0, 0, 10)]
        faces += [[4 * k, 4 * k + 2, 4 * k + 1], [4 * k, 4 * k + 3, 4 * k + 2]]
    return Scene.from_arrays(np.array(vertices, float), np.array(faces), np.repeat(np.arange(8), 2),
                             ElementTable.build([f"P{k}" for k in range(8)]))


def test_views_on_the_45_degree_bound_serve_and_plans_6e_12_m_apart_score_the_same():
    """A row of views 8 m south of the panels, each aimed 45° east of north: every view meets the panels at 45°,
    which the evaluation gives as 45 plus or minus a rounding. The same row 6·10⁻¹² m away (aimed again) is the same
    plan; both meet every panel that three views see."""
    scene = panels()
    cam = PinholeCamera(64, 48, 48.0, 48.0, 32.0, 24.0, "small")
    C = np.column_stack([np.linspace(-30.0, 10.0, 21), np.full(21, -8.0), np.full(21, 5.0)])

    def row(C: np.ndarray) -> Plan:
        return Plan.build(cam, np.array([look_at(c, c + np.array([8.0, 8.0, 0.0])) for c in C]), C)

    et = Targets(k=3, max_ssd_m_px=1.0, omega_px=25).resolve(scene, 1.0)
    a = score_plan(scene, row(C), et, scale=1.0, cache_dir=False)
    b = score_plan(scene, row(C + 6e-12), et, scale=1.0, cache_dir=False)
    assert a.met.tolist() == b.met.tolist() and int(a.met.sum()) == 8


def test_the_best_template_passes_the_checks_then_meets_most_then_flies_least():
    def row(label, ok, met, minutes):
        report = type("Report", (), {"ok": ok, "total_time_s": minutes * 60})()
        score = type("Score", (), {"met": np.arange(10) < met})()
        return Scored(label, None, report, score)  # type: ignore[arg-type]

    rows = [row("fails the checks", False, 9, 1.0), row("meets 5", True, 5, 2.0), row("meets 7, slow", True, 7, 9.0),
            row("meets 7, quick", True, 7, 4.0)]
    assert best_of(rows).label == "meets 7, quick"
    assert best_of(rows[:1]).label == "fails the checks" and best_of([]) is None


def test_the_grid_is_the_benchmarks():
    labels = [label for label, _, _ in template_grid(box_building(), FlightSettings(safety_distance_m=10.0))]
    assert labels == [f"{name} {o}%" for o in (60, 70, 80)
                      for name in ("facade box", "facade outline", "orbit", "lawnmower")]


@pytest.mark.bench  # make bench; the comparison's pieces are tested here in make test
def test_the_command_line_sets_the_optimiser_beside_the_best_template(tmp_path):
    """On an 8 m cube (k = 2): every template of the grid is planned, checked and scored; the best passes the checks;
    the optimiser like for like meets every target the template meets, and at its minutes meets at least as many."""
    import trimesh
    from typer.testing import CliRunner

    from sightplan.cli.main import app

    mesh = trimesh.creation.box((8, 8, 8))
    mesh.apply_translation((4, 4, 4))
    mesh.export(tmp_path / "box.obj")
    r = CliRunner().invoke(app, ["optimize", str(tmp_path / "box.obj"), "--k", "2", "--scale", "0.05",
                                 "-o", str(tmp_path / "plan.json")], env={"COLUMNS": "260"})  # reruns read the cache
    assert r.exit_code == 0, r.output
    text = r.output
    assert "the template grid" in text and "against the best template" in text
    for label in ("facade box 60%", "facade outline 70%", "orbit 80%", "lawnmower 70%"):
        assert label in text
    best = next(line for line in text.splitlines() if "(best)" in line)
    assert " ok " in best
    like = next(line for line in text.splitlines() if "optimised, the template's targets" in line)
    assert "all its targets met" in like and "frames −" in like
    equal = next(line for line in text.splitlines() if "optimised at the template's minutes" in line)
    assert re.search(r"\+\d+ targets met", equal)  # at least as many as the template


def test_the_tolerance_is_a_hair_not_a_slack():
    """Three head-on views of one panel: at an SSD bound equal to their coarsest SSD the panel is met; a millionth
    below it, not."""
    scene = panels()
    cam = PinholeCamera(64, 48, 48.0, 48.0, 32.0, 24.0, "small")
    C = np.array([[-17.5, -8.0, 5.0], [-17.5, -9.0, 5.0], [-17.5, -10.0, 5.0]])
    plan = Plan.build(cam, np.array([look_at(c, np.array([-17.5, 0.0, 5.0])) for c in C]), C)
    loose = Targets(k=3, max_ssd_m_px=1.0, omega_px=25).resolve(scene, 1.0)
    assert bool(score_plan(scene, plan, loose, scale=1.0, cache_dir=False).met[0])
    obs = evaluate(scene, plan, EvaluationSettings(scale=1.0), cache_dir=False).observations
    worst = float(obs.ssd[obs.element == 0].max())
    on = replace(loose, max_ssd_m_px=np.full(8, worst))
    over = replace(loose, max_ssd_m_px=np.full(8, worst * (1 - 1e-6)))
    assert bool(score_plan(scene, plan, on, scale=1.0, cache_dir=False).met[0])
    assert not bool(score_plan(scene, plan, over, scale=1.0, cache_dir=False).met[0])
