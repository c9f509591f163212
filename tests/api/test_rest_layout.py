"""The REST service's layout: one router per resource, one reader of the environment, no cycle."""

from __future__ import annotations

import ast
from pathlib import Path

import pytest
from fastapi.routing import APIRoute
from fastapi.testclient import TestClient

from api.rest.app import create_app
from api.rest.routes import health, parts, plans, review, tools
from api.rest.schemas.plans import MachineIn
from api.settings import DATABASE_URL_VAR, Settings, database_url
from db.engine import DEFAULT_URL
from models.quantities import DERIVED_QUANTITIES

from conftest import ROOT
from migrated import migrated

#: The operations of the contract: method, path and operation id (named on each route, short
#: and stable: a generated client's method names; issue 30).
OPERATIONS = {
    ("get", "/api/v1/health", "getHealth"),
    ("get", "/api/v1/ready", "getReady"),
    ("post", "/api/v1/plans", "createPlan"),
    ("get", "/api/v1/plans", "listPlans"),
    ("post", "/api/v1/plans/{plan_id}/replan", "replanPlan"),
    ("get", "/api/v1/plans/{plan_id}", "getPlan"),
    ("get", "/api/v1/plans/{plan_id}/setpoints", "getSetpoints"),
    ("post", "/api/v1/plans/{plan_id}/parts", "reportPart"),
    ("get", "/api/v1/plans/{plan_id}/parts", "listParts"),
    ("get", "/api/v1/plans/{plan_id}/parts/{part_id}", "getPart"),
    ("get", "/api/v1/plans/{plan_id}/history", "getHistory"),
    ("get", "/api/v1/plans/{plan_id}/models", "getModels"),
    ("get", "/api/v1/plans/{plan_id}/models/versions", "listModelVersions"),
    ("get", "/api/v1/tools", "listTools"),
    ("get", "/api/v1/tools/{name}", "getTool"),
    ("get", "/api/v1/tools/{name}/fleet", "getToolFleet"),
    ("get", "/api/v1/tools/{name}/fleet/imported", "getToolFleetImported"),
    ("get", "/api/v1/tools/{name}/fleet/law", "getToolFleetLaw"),
    ("post", "/api/v1/tools", "addTool"),
}


@pytest.fixture(scope="module")
def app(tmp_path_factory):
    url = f"sqlite:///{tmp_path_factory.mktemp('layout') / 'rcb.db'}"
    migrated(url)
    return create_app(url)


def test_the_operations_are_the_contracts(app):
    document = app.openapi()
    found = {
        (method, path, operation["operationId"])
        for path, item in document["paths"].items()
        for method, operation in item.items()
    }
    assert found == OPERATIONS


def test_every_router_is_mounted_with_its_full_path(app):
    mounted = {route.endpoint for route in app.routes if isinstance(route, APIRoute)}
    for resource in (health, parts, plans, review, tools):
        routes = [r for r in resource.router.routes if isinstance(r, APIRoute)]
        assert routes and len(routes) == len(resource.router.routes)
        assert all(r.path.startswith("/api/v1/") for r in routes)
        assert {r.endpoint for r in routes} <= mounted


def test_a_405_names_every_method_of_the_path(app):
    answer = TestClient(app).delete("/api/v1/plans")
    assert answer.status_code == 405
    assert answer.headers["Allow"] == "GET, HEAD, POST"  # HEAD: api.rest.head_method


def test_the_machine_limits_are_the_derived_quantities():
    limits = {name for name in MachineIn.model_fields if name.startswith("max_")}
    assert limits == {f"max_{quantity}" for quantity in DERIVED_QUANTITIES}


def test_the_database_url_comes_from_the_argument_then_the_environment():
    assert database_url("sqlite:///a.db", {DATABASE_URL_VAR: "sqlite:///b.db"}) == "sqlite:///a.db"
    assert database_url(None, {DATABASE_URL_VAR: "sqlite:///b.db"}) == "sqlite:///b.db"
    assert database_url(None, {DATABASE_URL_VAR: ""}) == DEFAULT_URL
    assert Settings.from_env({}).database_url == DEFAULT_URL


def _module_imports(path: Path) -> set[str]:
    tree = ast.parse(path.read_text(encoding="utf-8"))
    names: set[str] = set()
    for node in ast.walk(tree):  # every import, TYPE_CHECKING ones included
        if isinstance(node, ast.Import):
            names |= {alias.name for alias in node.names}
        elif isinstance(node, ast.ImportFrom) and node.module and node.level == 0:
            names.add(node.module)
            names |= {f"{node.module}.{alias.name}" for alias in node.names}
    return names


def test_api_modules_import_no_cycle():
    modules = {
        ".".join(p.relative_to(ROOT).with_suffix("").parts).removesuffix(".__init__"): p
        for p in (ROOT / "api").rglob("*.py")
    }
    graph = {
        name: {m for m in _module_imports(path) if m in modules and m != name}
        for name, path in modules.items()
    }
    done: set[str] = set()

    def visit(name: str, trail: tuple[str, ...]) -> None:
        assert name not in trail, " -> ".join((*trail, name))
        if name in done:
            return
        for child in graph[name]:
            visit(child, (*trail, name))
        done.add(name)

    for name in sorted(graph):
        visit(name, ())
