"""The page's types are generated from the API's OpenAPI document and checked in: regenerating gives the same file."""

from __future__ import annotations

import pytest

pytest.importorskip("fastapi")

from sightplan.web.jstypes import TYPES_JS, current_openapi, js_type, typedefs  # noqa: E402


def test_the_checked_in_types_are_the_generated_ones():
    assert TYPES_JS.read_text(encoding="utf-8") == typedefs(current_openapi()), \
        "the API changed: run `python -m sightplan.web.jstypes` and commit static/api-types.js"


def test_json_schema_types_map_to_jsdoc():
    assert js_type({"anyOf": [{"type": "number"}, {"type": "null"}]}) == "(number|null)"
    assert js_type({"type": "array", "items": {"$ref": "#/components/schemas/PlanOut"}}) == "Array<PlanOut>"
    assert js_type({"enum": ["box", "outline"]}) == "'box'|'outline'"
    assert js_type({"type": "object", "additionalProperties": {"type": "string"}}) == "Object<string, string>"
    assert js_type({"const": "orbit"}) == "'orbit'"


def test_every_template_request_is_typed_for_the_page():
    text = TYPES_JS.read_text(encoding="utf-8")
    for name in ("FacadePlanIn", "OrbitPlanIn", "LawnmowerPlanIn", "BridgePlanIn", "RoutePlanIn", "TemplateOut",
                 "FeedbackOut", "ElementDetailOut", "PlanFileOut"):
        assert f"@typedef {{object}} {name}" in text
    assert "@property {'orbit'} template" in text and "@property {(number|null)} [step_deg]" in text
    assert "@property {number} [overlap]" in text  # a default, so never null
