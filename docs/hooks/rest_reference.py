"""The REST reference page, written at build time from the FastAPI app's OpenAPI document.

``on_files`` adds ``reference/rest.md`` to the site: one section per operation (method, path,
summary, roles, parameters, request body, answers) and the schemas, all read from
``create_app(url).openapi()``. The app is built on a throw-away SQLite URL and never connects
(building the document reads no table), so the build is offline and needs no server; the
served document is linked as ``/api/v1/openapi.json`` for generators.
"""

from __future__ import annotations

import json
import tempfile
from pathlib import Path
from typing import Any

from mkdocs.structure.files import File, Files

PAGE = "reference/rest.md"
METHODS = ("get", "post", "put", "patch", "delete")


def _document() -> dict[str, Any]:
    from api.rest.app import create_app

    with tempfile.TemporaryDirectory() as folder:
        app = create_app(f"sqlite:///{Path(folder) / 'openapi.db'}")
        document: dict[str, Any] = app.openapi()
    return document


def _type(schema: dict[str, Any]) -> str:
    if "$ref" in schema:
        name = schema["$ref"].rsplit("/", 1)[-1]
        return f"[{name}](#schema-{name.lower()})"
    if "anyOf" in schema:
        return " or ".join(_type(s) for s in schema["anyOf"])
    if schema.get("type") == "array":
        return f"array of {_type(schema.get('items', {}))}"
    if "enum" in schema:
        return " \\| ".join(f"`{v}`" for v in schema["enum"])
    return str(schema.get("type", "any"))


def _cell(text: str) -> str:
    return " ".join(text.split()).replace("|", "\\|")


def _operation(path: str, method: str, op: dict[str, Any]) -> list[str]:
    lines = [f"### `{method.upper()} {path}`", ""]
    if op.get("summary"):
        lines += [f"**{op['summary']}**", ""]
    if op.get("description"):
        lines += [op["description"].strip(), ""]
    lines += [f"operationId: `{op.get('operationId', '')}`", ""]
    params = op.get("parameters", [])
    if params:
        lines += [
            "| parameter | in | type | required | description |",
            "| --- | --- | --- | --- | --- |",
        ]
        for p in params:
            desc = _cell(p.get("description", "") or p.get("schema", {}).get("description", ""))
            lines.append(
                f"| `{p['name']}` | {p['in']} | {_type(p.get('schema', {}))} | "
                f"{'yes' if p.get('required') else 'no'} | {desc} |"
            )
        lines.append("")
    body = op.get("requestBody")
    if body:
        for media, content in body.get("content", {}).items():
            lines += [f"Body (`{media}`): {_type(content.get('schema', {}))}", ""]
    lines += ["| status | description | body |", "| --- | --- | --- |"]
    for status, answer in op.get("responses", {}).items():
        content = answer.get("content", {})
        kinds = ", ".join(f"`{m}` {_type(c.get('schema', {}))}" for m, c in content.items())
        lines.append(f"| {status} | {_cell(answer.get('description', ''))} | {kinds} |")
    return [*lines, ""]


def _schema(name: str, schema: dict[str, Any]) -> list[str]:
    lines = [f"### {name} {{#schema-{name.lower()}}}", ""]
    if schema.get("description"):
        lines += [_cell(schema["description"]), ""]
    props = schema.get("properties", {})
    if props:
        required = set(schema.get("required", []))
        lines += ["| field | type | required | description |", "| --- | --- | --- | --- |"]
        for field, sub in props.items():
            desc = _cell(sub.get("description", "") or sub.get("title", ""))
            lines.append(
                f"| `{field}` | {_type(sub)} | {'yes' if field in required else 'no'} | {desc} |"
            )
    elif "enum" in schema:
        lines.append(f"One of {_type(schema)}.")
    else:
        lines.append(f"`{_cell(json.dumps(schema, ensure_ascii=False))}`")
    return [*lines, ""]


def render(document: dict[str, Any]) -> str:
    """The page's Markdown for an OpenAPI document."""
    info = document["info"]
    lines = [
        "# REST reference",
        "",
        f"*{info['title']}*, API version {info['version']}, OpenAPI {document['openapi']}. "
        "This page is generated at build time from the app's OpenAPI document "
        "(`docs/hooks/rest_reference.py`); a running `rcb serve` serves the same document "
        "at `/api/v1/openapi.json` for client generators. How to use the routes: "
        "[REST service](../guide/rest-service.md).",
        "",
        "## Operations",
        "",
    ]
    for path, item in document["paths"].items():
        for method in METHODS:
            if method in item:
                lines += _operation(path, method, item[method])
    lines += ["## Schemas", ""]
    for name, schema in document.get("components", {}).get("schemas", {}).items():
        lines += _schema(name, schema)
    return "\n".join(lines)


def on_files(files: Files, config: Any) -> Files:
    """Add the generated page to the site's files."""
    files.append(File.generated(config, PAGE, content=render(_document())))
    return files
