"""Imports flow api → db → supervisor → models (DESIGN.md, "Layers")."""

from __future__ import annotations

import ast

import pytest

from conftest import ROOT

FORBIDDEN = {
    "models": {"supervisor", "db", "api", "cvxpy", "sqlalchemy", "fastapi", "typer", "rich"},
    "supervisor": {"db", "api", "sqlalchemy", "fastapi", "typer", "rich"},
    "db": {"api", "fastapi", "typer"},
}


def _imports(path):
    tree = ast.parse(path.read_text(encoding="utf-8"))
    for node in ast.walk(tree):
        if isinstance(node, ast.Import):
            yield from (alias.name.split(".")[0] for alias in node.names)
        elif isinstance(node, ast.ImportFrom) and node.module and node.level == 0:
            yield node.module.split(".")[0]


@pytest.mark.parametrize("package", sorted(FORBIDDEN))
def test_imports_flow_one_way(package):
    files = sorted((ROOT / package).rglob("*.py"))
    assert files, f"no sources found under {package}/"
    bad = {
        f"{f.relative_to(ROOT)} imports {name}"
        for f in files
        for name in _imports(f)
        if name in FORBIDDEN[package]
    }
    assert not bad
