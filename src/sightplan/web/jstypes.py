"""The page's types, generated from the API's OpenAPI document: one JSDoc ``@typedef`` per request and response
model, written to ``static/api-types.js``, which the page's modules name in their ``@param``/``@returns`` comments.

Regenerate after changing a schema (a test fails until the file matches)::

    python -m sightplan.web.jstypes
"""

from __future__ import annotations

import re
import sys
import tempfile
from pathlib import Path
from typing import Any

TYPES_JS = Path(__file__).parent / "static" / "api-types.js"

HEADER = """\
// The request and response types of sightplan's REST API, generated from its OpenAPI document by
// `python -m sightplan.web.jstypes`; do not edit by hand. Modules name them in JSDoc comments, e.g.
//   /** @param {import('./api-types.js').PlanOut} plan */
"""


def _name(ref: str) -> str:
    return re.sub(r"\W", "_", ref.rsplit("/", 1)[-1])


def js_type(schema: dict[str, Any]) -> str:
    """The JSDoc type of a JSON schema."""
    if "$ref" in schema:
        return _name(schema["$ref"])
    if "const" in schema:
        return _literal(schema["const"])
    if "enum" in schema:
        return "|".join(_literal(v) for v in schema["enum"])
    for key in ("anyOf", "oneOf"):
        if key in schema:
            parts = list(dict.fromkeys(js_type(s) for s in schema[key]))
            return "(" + "|".join(parts) + ")" if len(parts) > 1 else parts[0]
    kind = schema.get("type")
    if kind == "array":
        inner = js_type(schema.get("items", {}))
        return f"Array<{inner}>"
    if kind == "object" or "properties" in schema or "additionalProperties" in schema:
        extra = schema.get("additionalProperties")
        value = js_type(extra) if isinstance(extra, dict) and extra else "*"
        return f"Object<string, {value}>"
    return {"string": "string", "integer": "number", "number": "number", "boolean": "boolean",
            "null": "null"}.get(kind, "*")


def _literal(v: Any) -> str:
    return f"'{v}'" if isinstance(v, str) else str(v).lower() if isinstance(v, bool) else str(v)


def _comment(text: str) -> str:
    return " ".join(str(text).split()).replace("*/", "*\\/")


def typedefs(openapi: dict[str, Any]) -> str:
    """The ``api-types.js`` text for an OpenAPI document: its component schemas in name order."""
    out = [HEADER]
    for name, schema in sorted(openapi.get("components", {}).get("schemas", {}).items()):
        lines = ["/**"]
        if schema.get("description"):
            lines.append(f" * {_comment(schema['description'])}")
        props = schema.get("properties")
        if props is None:
            lines.append(f" * @typedef {{{js_type(schema)}}} {_name(name)}")
        else:
            lines.append(f" * @typedef {{object}} {_name(name)}")
            required = set(schema.get("required", []))
            for prop, sub in props.items():
                key = prop if prop in required else f"[{prop}]"
                about = sub.get("description") or sub.get("title", "")
                lines.append(f" * @property {{{js_type(sub)}}} {key}" + (f" {_comment(about)}" if about else ""))
        lines.append(" */")
        out.append("\n".join(lines))
    out.append("export {};\n")
    return "\n\n".join(out)


def current_openapi() -> dict[str, Any]:
    """The OpenAPI document of a server in team mode (every route), made in a throw-away data folder."""
    from .app import create_app
    from .config import ServerConfig

    with tempfile.TemporaryDirectory() as tmp:
        return create_app(ServerConfig(data_dir=Path(tmp) / "d", team=True)).openapi()


def main() -> int:
    text = typedefs(current_openapi())
    if TYPES_JS.exists() and TYPES_JS.read_text(encoding="utf-8") == text:
        print(f"{TYPES_JS} is up to date")
        return 0
    TYPES_JS.write_text(text, encoding="utf-8")
    print(f"wrote {TYPES_JS}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
