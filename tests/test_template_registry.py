"""Each template is declared once (its parameter dataclass): the command line's options, the web API's request
schema and the page's form (``GET /api/templates``) all come from that declaration, and a bound declared there is
enforced the same way everywhere."""

from __future__ import annotations

import dataclasses
import math

import pytest

from sightplan.errors import PlanError
from sightplan.plan.templates.base import ParamInfo, cli_name, info_of, label_of, unit_of
from sightplan.plan.templates.registry import TEMPLATE_NAMES, TEMPLATES, WALKED, build_template

pytest.importorskip("fastapi")

from fastapi.testclient import TestClient  # noqa: E402
from typer.testing import CliRunner  # noqa: E402

from sightplan.cli.main import app as cli_app  # noqa: E402
from sightplan.cli.plan_cmd import TEMPLATE_OPTIONS  # noqa: E402
from sightplan.web.app import create_app  # noqa: E402
from sightplan.web.config import ServerConfig  # noqa: E402


def declared():
    """(template, field name, declaration, default) of every parameter of every template."""
    return [(t.name, f.name, info_of(f), f.default) for t in TEMPLATES.values() for f in dataclasses.fields(t.params)]


def too_low(info):
    """A value just past the declaration's lower bound, or None when it has none."""
    if info.ge is not None:
        return info.ge - 0.5 if info.kind == "number" else [info.ge - 0.5]
    if info.gt is not None:
        return info.gt if info.kind == "number" else [info.gt]
    return None


@pytest.fixture(scope="module")
def client(tmp_path_factory):
    with TestClient(create_app(ServerConfig(data_dir=tmp_path_factory.mktemp("reg") / "d"))) as c:
        assert c.post("/api/projects", json={"name": "bounds"}).json()["id"] == 1
        yield c


def test_every_template_module_is_found_once_with_unit_suffixed_fields():
    assert TEMPLATE_NAMES == ("facade", "orbit", "lawnmower", "bridge", "route")
    assert WALKED == {"route"}
    for _, name, info, _ in declared():
        if info.kind in ("number", "numbers") and name not in ("overlap", "side_overlap"):  # overlaps are ratios
            assert unit_of(name), f"{name} carries no unit"
        assert info.help and not info.help.endswith(".")


def test_names_without_their_unit_make_the_labels_and_the_options():
    plain, named = ParamInfo("h"), ParamInfo("h", cli="point", label="Axis")
    assert [cli_name(n, plain) for n in ("gsd_m_px", "oblique_pitch_deg", "deck_z_m", "side_overlap")] == [
        "gsd", "oblique-pitch", "deck-z", "side-overlap"]
    assert [label_of(n, plain) for n in ("gsd_m_px", "oblique_pitch_deg", "deck_z_m")] == ["Gsd", "Oblique pitch",
                                                                                          "Deck z"]
    assert (cli_name("axis", named), label_of("axis", named)) == ("point", "Axis")


def test_the_command_line_options_are_the_declared_parameters():
    result = CliRunner().invoke(cli_app, ["plan", "--help"], env={"COLUMNS": "400"})
    assert result.exit_code == 0, result.output
    options = {o.cli: o for o in TEMPLATE_OPTIONS}
    for template, name, info, _ in declared():
        cli = info.cli or name.removesuffix("_m_px").removesuffix("_deg").removesuffix("_m").replace("_", "-")
        assert f"--{cli}" in result.output
        assert (template, name) in [m[:2] for m in options[cli].members]
    # --step is an orbit's degrees and a route's metres: both named in its help with their units
    step = options["step"].help()
    assert "orbit: degrees between frames (default: by overlap) (°; ≥ 0.01, ≤ 180)" in step
    assert "route: metres between frames (m; > 0, ≤ 100000)" in step


@pytest.mark.parametrize("case", [c for c in declared() if too_low(c[2]) is not None], ids=lambda c: f"{c[0]}.{c[1]}")
def test_a_declared_bound_is_refused_by_the_library_the_command_line_and_the_api(case, client):
    template, name, info, _ = case
    bad = too_low(info)
    with pytest.raises(PlanError, match=name):
        TEMPLATES[template].make({name: bad})
    cli = info.cli or name.removesuffix("_m_px").removesuffix("_deg").removesuffix("_m").replace("_", "-")
    args = ["plan", template, "no-such-model.ifc", f"--{cli}", str(bad if info.kind == "number" else bad[0])]
    result = CliRunner().invoke(cli_app, args)  # refused before the (missing) model is read
    assert result.exit_code == 2 and f"--{cli}" in result.output and "no-such-model" not in result.output, result.output
    r = client.post("/api/projects/1/plans", json={"model_id": 1, "template": template, name: bad})
    assert r.status_code == 422 and name in r.text


def test_an_option_the_template_does_not_take_is_refused_by_name():
    result = CliRunner().invoke(cli_app, ["plan", "facade", "sample", "--radius", "20"])
    assert result.exit_code == 2 and "takes no --radius" in result.output and "--footprint" in result.output
    with pytest.raises(PlanError, match="takes no radius_m"):
        TEMPLATES["facade"].make({"radius_m": (20.0,)})


def test_the_api_schema_is_a_union_on_template_generated_from_the_declarations(client):
    schemas = client.get("/openapi.json").json()["components"]["schemas"]
    for t in TEMPLATES.values():
        props = schemas[f"{t.name.capitalize()}PlanIn"]["properties"]
        assert props["template"]["const"] == t.name
        for name, info, default in t.fields():
            if not info.web:
                assert name not in props
                continue
            p = props[name]
            leaf = p.get("items", p) if info.kind == "numbers" else p
            if info.kind == "number":
                leaf = next((a for a in p.get("anyOf", [p]) if a.get("type") == "number"), p)
            for bound, key in (("ge", "minimum"), ("gt", "exclusiveMinimum"), ("le", "maximum"),
                               ("lt", "exclusiveMaximum")):
                if getattr(info, bound) is not None:
                    assert leaf[key] == getattr(info, bound), (t.name, name, key)
            if info.kind == "choice":
                assert set(p["enum"]) == set(info.choices) and p["default"] == default
    # the flight settings every template shares carry their unit
    base = schemas["FacadePlanIn"]["properties"]
    assert {"safety_distance_m", "vlos_radius_m", "altitude_limit_m", "min_height_m"} <= set(base)


def test_the_form_description_is_the_declarations(client):
    listed = client.get("/api/templates").json()
    assert [t["name"] for t in listed] == list(TEMPLATE_NAMES)
    for t in listed:
        decl = [(n, info, d) for n, info, d in TEMPLATES[t["name"]].fields() if info.web]
        assert [f["name"] for f in t["fields"]] == [n for n, _, _ in decl]
        for f, (_, info, default) in zip(t["fields"], decl, strict=True):
            assert f["kind"] == info.kind and f["help"] == info.help and f["choices"] == list(info.choices)
            assert f["default"] == (None if default == () else default)
            assert (f["ge"], f["gt"], f["le"], f["lt"]) == (info.ge, info.gt, info.le, info.lt)
            assert f["pair"] == info.pair
        assert t["safety_distance_m"] == (0.3 if t["walked"] else 10.0)
    # an orbit's radii and heights are paired ring by ring: the form shows them as rows
    orbit = {f["name"]: f["pair"] for f in next(t for t in listed if t["name"] == "orbit")["fields"]}
    assert orbit["radius_m"] == orbit["height_m"] == "ring"


def test_parameters_given_as_a_dict_build_the_same_plan_as_the_dataclass():
    from sightplan.camera.catalogue import get_camera
    from sightplan.model.load import load_model, sample_model_path

    scene = load_model(sample_model_path())[0]
    cam = get_camera("p4p")
    a = build_template("orbit", scene, cam, {"radius_m": [30], "height_m": [10], "step_deg": 30}, 10.0, 2.0)
    b = build_template("orbit", scene, cam, TEMPLATES["orbit"].params(radius_m=(30.0,), height_m=(10.0,), step_deg=30),
                       10.0, 2.0)
    assert len(a) == len(b) == 12  # 360° / 30°
    assert all(math.isclose(x, y) for x, y in zip(a.C_world.ravel(), b.C_world.ravel(), strict=True))


def test_a_new_template_with_a_one_value_radius_shares_the_repeated_option(monkeypatch):
    """A template added beside the orbit, whose radius is one number, shares --radius: one value for it, several for
    the orbit."""
    from dataclasses import dataclass

    from sightplan.cli import plan_cmd
    from sightplan.plan.templates.base import Params, Template, param

    @dataclass(frozen=True)
    class SpiralParams(Params):
        radius_m: float | None = param(None, "radius of the spiral", gt=0)

    spiral = Template("spiral", "a descending spiral", SpiralParams, lambda *a: None, order=5)
    monkeypatch.setattr(plan_cmd, "TEMPLATES", {**TEMPLATES, "spiral": spiral})
    radius = next(o for o in plan_cmd.template_options() if o.cli == "radius")
    assert radius.kind == "numbers" and [m[0] for m in radius.members] == ["orbit", "spiral"]
    assert radius.value("spiral", [30.0]) == ("radius_m", 30.0)
    assert radius.value("orbit", [30.0, 40.0]) == ("radius_m", (30.0, 40.0))
    with pytest.raises(PlanError, match="--radius takes one value for the spiral template"):
        radius.value("spiral", [30.0, 40.0])
    assert "spiral: radius of the spiral (m; > 0)" in radius.help()
