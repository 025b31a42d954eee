"""Defaults end to end, as a user runs them: every flown template with its defaults around every model of
``../shared/data``, the bundled sample and the basement-and-terrain fixture, through ``sightplan plan`` → ``sightplan
check`` → ``sightplan export --format wpl`` without ``--force``; and ``sightplan optimize`` with and without a budget.

A model without a georeference gets one with ``--origin`` at export, as its user would give it. ``make test`` runs
the sample and the basement-and-terrain fixture; the 18 cases over the models of ``../shared/data`` (0.2 s to 20 s
each, 83 s together on two cores) would take ``make test`` past its 12 minutes, so ``make bench`` runs them (marker
``bench``)."""

from __future__ import annotations

from pathlib import Path

import pytest

from conftest import shared_file
from site_fixture import write_basement_house
from test_cli import run_cli

MODELS = {"sample": None}
LARGE = {
    "duplex_electrical": ("ifc", "Ifc2s3_Duplex_Electrical.ifc"),
    "ifcopenhouse": ("ifc", "IfcOpenHouse_IFC4.ifc"),
    "construction_task": ("ifc", "construction_scheduling_task.ifc"),
    "xella": ("schependomlaan", "XELLA-Begane grond.ifc"),
    "multicom": ("schependomlaan", "MULTICOM-Prefab.ifc"),
    "bernts": ("schependomlaan", "BERNTS-Staalconstructie.ifc"),
}
TEMPLATES = ["facade", "orbit", "lawnmower"]


def _model(name: str, tmp: Path) -> str:
    if name == "sample":
        return "sample"
    if name == "basement_house":
        return str(write_basement_house(tmp / "house.ifc"))
    return str(shared_file(*{**MODELS, **LARGE}[name]))


@pytest.mark.parametrize("template", TEMPLATES)
@pytest.mark.parametrize("model", [*MODELS, "basement_house",
                                   *(pytest.param(m, marks=pytest.mark.bench) for m in LARGE)])
def test_template_defaults_plan_check_and_export(tmp_path, model, template):
    m = _model(model, tmp_path)
    made = run_cli("plan", template, m, "-o", "plan.json", cwd=tmp_path)
    assert made.returncode == 0, made.stdout + made.stderr
    assert "no violations" in made.stdout and "ground:" in made.stdout
    checked = run_cli("check", "plan.json", m, "--safety-distance", "10", cwd=tmp_path)
    assert checked.returncode == 0, checked.stdout
    origin = [] if model in ("sample", "duplex_electrical", "basement_house") else ["--origin", "51.84,5.87"]
    out = run_cli("export", "plan.json", "--format", "wpl", "--model", m, "-o", "m.waypoints", *origin, cwd=tmp_path)
    assert out.returncode == 0, out.stdout + out.stderr
    assert "--force" not in out.stdout + out.stderr
    assert list(tmp_path.glob("m*.waypoints"))


# in make bench, both: the optimiser's plans are checked by check_plan in make test (test_optimize.py: its legs cut
# where too near, the Duplex's single-view mission kept apart), and the templates' defaults run here in make test
@pytest.mark.bench
@pytest.mark.parametrize("budget", [[], ["--budget-frames", "12"]])
def test_optimised_plan_passes_its_checks_and_exports(tmp_path, budget):
    m = _model("basement_house", tmp_path)
    made = run_cli("optimize", m, "--scale", "0.1", *budget, "-o", "opt.json", cwd=tmp_path)
    assert made.returncode == 0, made.stdout + made.stderr
    checked = run_cli("check", "opt.json", m, "--safety-distance", "10", cwd=tmp_path)
    assert checked.returncode == 0, checked.stdout
    out = run_cli("export", "opt.json", "--format", "wpl", "--model", m, "-o", "o.waypoints", cwd=tmp_path)
    assert out.returncode == 0, out.stdout + out.stderr
