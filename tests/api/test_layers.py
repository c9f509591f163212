"""Imports flow api → db → supervisor → models (DESIGN.md, "Layers"), with no import cycle.

The module graph is read with ``ast`` from every file of every package, counting every import:
at the top, inside functions and under ``TYPE_CHECKING`` alike. The same files are held small:
no module over 400 lines, no function over 60 (the long ones of today listed, a ratchet).
"""

from __future__ import annotations

import ast

import pytest

from conftest import ROOT

FORBIDDEN = {
    "models": {"supervisor", "db", "api", "cvxpy", "sqlalchemy", "fastapi", "typer", "rich"},
    "supervisor": {"db", "api", "sqlalchemy", "fastapi", "typer", "rich"},
    "db": {"api", "fastapi", "typer"},
}
PACKAGES = ("models", "supervisor", "db", "api")


def _module_name(path):
    parts = list(path.relative_to(ROOT).with_suffix("").parts)
    if parts[-1] == "__init__":
        parts.pop()
    return ".".join(parts)


def _modules():
    """Every module of the project's packages: dotted name -> path."""
    return {
        _module_name(path): path
        for package in PACKAGES
        for path in sorted((ROOT / package).rglob("*.py"))
    }


MODULES = _modules()
SUBPACKAGES = sorted(
    _module_name(path) for package in PACKAGES for path in (ROOT / package).rglob("__init__.py")
)


def _imports(name, path):
    """Every module ``name`` imports (dotted), anywhere in the file, relative ones resolved."""
    is_package = path.name == "__init__.py"
    tree = ast.parse(path.read_text(encoding="utf-8"))
    for node in ast.walk(tree):
        if isinstance(node, ast.Import):
            yield from (alias.name for alias in node.names)
        elif isinstance(node, ast.ImportFrom):
            if node.level:
                base = name.split(".")
                base = base[: len(base) - node.level + (1 if is_package else 0)]
                module = ".".join([*base, node.module] if node.module else base)
            else:
                module = node.module or ""
            yield module
            for alias in node.names:  # ``from package import module``
                yield f"{module}.{alias.name}"


def _graph():
    """Module -> the project modules it imports."""
    return {
        name: sorted({m for m in _imports(name, path) if m in MODULES and m != name})
        for name, path in MODULES.items()
    }


def _cycles(graph):
    """The strongly connected components with more than one module (Tarjan's algorithm)."""
    index, low, on_stack, stack, found = {}, {}, set(), [], []

    def visit(v):
        index[v] = low[v] = len(index)
        stack.append(v)
        on_stack.add(v)
        for w in graph[v]:
            if w not in index:
                visit(w)
                low[v] = min(low[v], low[w])
            elif w in on_stack:
                low[v] = min(low[v], index[w])
        if low[v] == index[v]:
            component = []
            while True:
                w = stack.pop()
                on_stack.discard(w)
                component.append(w)
                if w == v:
                    break
            if len(component) > 1:
                found.append(sorted(component))

    for v in sorted(graph):
        if v not in index:
            visit(v)
    return found


def test_every_subpackage_is_covered():
    assert {"supervisor.optimize", "supervisor.rcb", "supervisor.virtual", "api.rest"} <= set(
        SUBPACKAGES
    )
    # every folder of sources is a package (setuptools finds it), so each file is checked below
    folders = {p.parent for package in PACKAGES for p in (ROOT / package).rglob("*.py")}
    assert {_module_name(f / "__init__.py") for f in folders} <= set(SUBPACKAGES)
    assert len(MODULES) == sum(len(list((ROOT / p).rglob("*.py"))) for p in PACKAGES)


@pytest.mark.parametrize("module", sorted(m for m in MODULES if m.split(".")[0] in FORBIDDEN))
def test_imports_flow_one_way(module):
    package = module.split(".")[0]
    names = {m.split(".")[0] for m in _imports(module, MODULES[module])}
    assert not names & FORBIDDEN[package], f"{module} imports {sorted(names & FORBIDDEN[package])}"


@pytest.mark.parametrize("package", PACKAGES)
def test_no_import_cycle(package):
    cycles = [c for c in _cycles(_graph()) if any(m.split(".")[0] == package for m in c)]
    assert not cycles, "import cycles: " + "; ".join(" <-> ".join(c) for c in cycles)


def test_the_cycle_finder_finds_a_cycle():
    graph = {"a": ["b"], "b": ["c"], "c": ["a"], "d": ["a"]}
    assert _cycles(graph) == [["a", "b", "c"]]


def _folder_pairs(graph, package="supervisor"):
    """Pairs of ``package``'s folders that import each other: {(a, b): (a's importer, b's)}."""
    edges = {}
    for module, imported in graph.items():
        parts = module.split(".")
        if parts[0] != package or len(parts) < 3:
            continue
        for other in imported:
            theirs = other.split(".")
            if theirs[0] == package and len(theirs) >= 3 and theirs[1] != parts[1]:
                edges.setdefault((parts[1], theirs[1]), module)
    return {(a, b): (edges[(a, b)], edges[(b, a)]) for a, b in edges if a < b and (b, a) in edges}


#: The two-way folder imports inside supervisor/ allowed: none since issue 31 item 5 (the
#: test stays a ratchet: a pair listed here must still exist).
TWO_WAY_TODAY: set[tuple[str, str]] = set()


def test_no_new_two_way_import_between_supervisor_folders():
    pairs = _folder_pairs(_graph())
    new = {p: how for p, how in pairs.items() if p not in TWO_WAY_TODAY}
    assert not new, "folders that import each other: " + "; ".join(
        f"{a} <-> {b} ({ma} / {mb})" for (a, b), (ma, mb) in sorted(new.items())
    )
    undone = TWO_WAY_TODAY - set(pairs)
    assert not undone, f"no longer two-way, take them out of TWO_WAY_TODAY: {sorted(undone)}"


def test_the_folder_pair_finder_finds_a_pair():
    graph = {
        "supervisor.a.x": ["supervisor.b.y"],
        "supervisor.b.y": ["supervisor.c.z"],
        "supervisor.c.z": ["supervisor.a.w", "models.q"],
        "supervisor.a.w": [],
    }
    assert _folder_pairs(graph) == {}
    graph["supervisor.b.y"].append("supervisor.a.w")
    assert _folder_pairs(graph) == {("a", "b"): ("supervisor.a.x", "supervisor.b.y")}


#: The largest module outside tests/ (issue 16: files small and single-purpose).
MAX_LINES = 400


def test_no_module_is_over_400_lines():
    files = [*MODULES.values(), *sorted((ROOT / "benchmarks" / "api_load").rglob("*.py"))]
    long = {
        str(path.relative_to(ROOT)): n
        for path in files
        if (n := len(path.read_text(encoding="utf-8").splitlines())) > MAX_LINES
    }
    assert not long


@pytest.mark.parametrize("package", SUBPACKAGES)
def test_every_package_says_what_it_holds(package):
    init = ROOT / package.replace(".", "/") / "__init__.py"
    doc = ast.get_docstring(ast.parse(init.read_text(encoding="utf-8")))
    assert doc and "arrive" not in doc, f"{init.relative_to(ROOT)}: docstring {doc!r}"


@pytest.mark.parametrize("module", sorted(m for m in MODULES if m.startswith("api.services")))
def test_use_cases_do_not_import_their_interfaces(module):
    # The REST service, the CLI and the report call the use cases, never the other way round.
    interfaces = ("api.rest", "api.cli", "api.report")
    bad = {m for m in _imports(module, MODULES[module]) if m.startswith(interfaces)}
    assert not bad


#: The longest production function, from its ``def`` line (decorators excluded) to its last
#: line, nested functions counted within their parent (issue 31 item 7).
MAX_FUNCTION_LINES = 60
#: The production functions longer than that today, as "path::qualname" (a nested function
#: as ``parent.child``, a method as ``Class.method``) with their length when listed. A ratchet:
#: no function may join, and one that is no longer long must leave.
LONG_TODAY: frozenset[str] = frozenset()  # none since issue 31 item 7 (2026-11-29)


def _function_lengths(source, prefix=""):
    """Every function of ``source`` (module text): {qualname: lines from ``def`` to its end}."""
    lengths = {}

    def visit(node, scope):
        for child in ast.iter_child_nodes(node):
            if isinstance(child, ast.FunctionDef | ast.AsyncFunctionDef):
                name = f"{scope}{child.name}"
                lengths[f"{prefix}{name}"] = child.end_lineno - child.lineno + 1
                visit(child, f"{name}.")
            elif isinstance(child, ast.ClassDef):
                visit(child, f"{scope}{child.name}.")
            else:
                visit(child, scope)

    visit(ast.parse(source), "")
    return lengths


def _long_functions(paths, root=ROOT):
    """The functions of ``paths`` over :data:`MAX_FUNCTION_LINES`: {"path::qualname": lines}."""
    found = {}
    for path in paths:
        prefix = f"{path.relative_to(root).as_posix()}::"
        lengths = _function_lengths(path.read_text(encoding="utf-8"), prefix)
        found |= {name: n for name, n in lengths.items() if n > MAX_FUNCTION_LINES}
    return found


def test_no_new_long_function():
    # alembic/ (the migrations) is no package of PACKAGES, so it is not read
    long = _long_functions(MODULES.values())
    new = {name: n for name, n in long.items() if name not in LONG_TODAY}
    assert not new, f"functions over {MAX_FUNCTION_LINES} lines: " + "; ".join(
        f"{name} ({n})" for name, n in sorted(new.items())
    )
    undone = LONG_TODAY - set(long)
    assert not undone, f"no longer long (or gone), take them out of LONG_TODAY: {sorted(undone)}"


def test_the_long_function_finder_flags_61_lines_and_passes_60(tmp_path):
    def module(lines):
        # a decorator (not counted), the def line, then the body: ``lines`` lines in all
        body = "".join(f"    x{i} = {i}\n" for i in range(lines - 2))
        return f"@staticmethod\ndef f():\n{body}    return 0\n"

    (tmp_path / "ok.py").write_text(module(60), encoding="utf-8")
    (tmp_path / "long.py").write_text(module(61), encoding="utf-8")
    found = _long_functions(sorted(tmp_path.glob("*.py")), root=tmp_path)
    assert found == {"long.py::f": 61}
    nested = (
        "class C:\n    def m(self):\n        def g():\n            return 1\n        return g\n"
    )
    assert _function_lengths(nested) == {"C.m": 4, "C.m.g": 2}


def _long_files(paths, root=ROOT):
    """The files of ``paths`` over :data:`MAX_LINES` lines, counted as
    :func:`test_no_module_is_over_400_lines` counts them: {"path": lines}."""
    return {
        path.relative_to(root).as_posix(): n
        for path in paths
        if (n := len(path.read_text(encoding="utf-8").splitlines())) > MAX_LINES
    }


def test_no_test_file_is_over_400_lines():
    # issue 31 item 7: the tests are held small too, conftest.py and the helper modules
    # included; a long one is split by topic, its shared helpers in a module without test_
    long = _long_files(sorted((ROOT / "tests").rglob("*.py")))
    assert not long, f"test files over {MAX_LINES} lines: " + "; ".join(
        f"{name} ({n})" for name, n in sorted(long.items())
    )


def test_the_long_file_finder_flags_401_lines_and_passes_400(tmp_path):
    (tmp_path / "ok.py").write_text("x = 0\n" * 400, encoding="utf-8")
    (tmp_path / "long.py").write_text("x = 0\n" * 401, encoding="utf-8")
    (tmp_path / "sub").mkdir()
    (tmp_path / "sub" / "long.py").write_text("x = 0\n" * 400 + "y = 1", encoding="utf-8")
    found = _long_files(sorted(tmp_path.rglob("*.py")), root=tmp_path)
    assert found == {"long.py": 401, "sub/long.py": 401}
