"""Request bodies a domain reader checks alone, documented by the schema of their structure.

A plan is read by one reader whichever way it comes (TOML, JSON, the stored body:
:func:`supervisor.inputs.plan.plan_from_mapping`, issue 31), so ``POST /plans`` takes the JSON
object as it is and hands it to the reader (``POST /tools`` to the tool reader,
:func:`models.tool.tool_from_mapping`, a replan's changes to
:func:`supervisor.rcb.replan.replan`); FastAPI would document it as "any object". Its
OpenAPI document names the structure instead: :class:`api.rest.schemas.plans.PlanIn`, the
schema a client generates its types from (``tests/api/test_rest_schema.py`` fuzzes the service
with it: every body it refuses, the reader refuses too).
"""

from __future__ import annotations

import functools
from typing import Any

from fastapi import FastAPI
from pydantic import BaseModel

from api.rest.schemas.plans import PlanIn
from api.rest.schemas.replan import ReplanIn
from api.rest.schemas.tools import ToolIn

#: Each operation whose body the reader checks, and the model that documents its body.
DOCUMENTED_BY: dict[str, type[BaseModel]] = {
    "createPlan": PlanIn,
    "addTool": ToolIn,
    "replanPlan": ReplanIn,
}
_REF = "#/components/schemas/{model}"


def install(app: FastAPI) -> None:
    """Document each body of :data:`DOCUMENTED_BY` by its model's schema (as a model body is)."""
    generate = app.openapi

    def openapi() -> dict[str, Any]:
        document = generate()
        schemas = document.setdefault("components", {}).setdefault("schemas", {})
        for item in document.get("paths", {}).values():
            for operation in item.values():
                model = DOCUMENTED_BY.get(operation.get("operationId", ""))
                if model is None:
                    continue
                body = operation["requestBody"]["content"]["application/json"]
                body["schema"] = {"$ref": _REF.format(model=model.__name__)}
                for name, definition in _schemas(model).items():
                    schemas.setdefault(name, definition)
        document["components"]["schemas"] = dict(sorted(schemas.items()))
        return document

    app.openapi = openapi  # type: ignore[method-assign]


@functools.cache  # the document is asked for at every GET of openapi.json
def _schemas(model: type[BaseModel]) -> dict[str, Any]:
    """The component schemas of ``model`` as FastAPI writes a body of that model's.

    From a scratch app with one route taking it, so they are FastAPI's, byte for byte.
    """
    scratch = FastAPI()
    scratch.post("/", operation_id="scratch")(_taking(model))
    found: dict[str, Any] = scratch.openapi()["components"]["schemas"]
    names = {model.__name__, *model.model_json_schema().get("$defs", {})}
    return {name: found[name] for name in names}


def _taking(model: type[BaseModel]) -> Any:
    def take(body: Any) -> None:
        """A route taking ``model`` as its body."""

    take.__annotations__ = {"body": model, "return": None}  # read by FastAPI at run time
    return take
