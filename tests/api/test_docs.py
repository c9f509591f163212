"""Every command of the docs runs as written (issue 30 item 1).

Each page's console blocks (README.md and every ``docs/**/*.md``, found at collection time, so
a new page is run without a change here) run in order in one bash shell, in a fresh folder,
with ``rcb`` of this virtual environment first on PATH and a fresh SQLite database (the
checkout's ``examples/`` and ``tests/data/`` are linked into it, as a command run from a
checkout sees them): each
command must exit 0 and print the lines its block shows (``tests/docs_console.py``). A server
a page starts (``rcb serve ... &``) gets a free port in place of the 8000 it writes, as does
a machine's (``--port 5001``), and the page's process group is killed at the end; a page that
does not end in ``PAGE_SECONDS`` fails with the command it was waiting in and what its
background servers printed. A page may declare ``<!-- docs-test: serve -->``
on a line of its own: the test then starts ``rcb serve`` on ``./rcb.db`` (port 8000 in the
page) before its commands.

README's opening block (a fresh virtual environment with the demo; one with the whole test
suite) is a ``bash`` block, not a console block: it is not run here, because the second
command would run this test again and both install from the registry. What is checked is
that it is there, unchanged, and that its test command is the one ``.ci/run`` runs; its
``rcb demo`` runs in README's first console block.
"""

from __future__ import annotations

import json
import os
import re
import signal
import socket
import subprocess
import sys
import time
import tomllib
from pathlib import Path

import pytest

from conftest import invoke
from docs_console import PORT, Command, commands, hung, script, written_ports
from live import free_port

ROOT = Path(__file__).parents[2]
README = ROOT / "README.md"
PAGES = [README, *sorted((ROOT / "docs").rglob("*.md"))]
RUNNABLE = [p for p in PAGES if commands(p, ROOT)]
INSTALL = (
    "python3 -m venv .venv && .venv/bin/pip install -q -e . && .venv/bin/rcb demo",
    'python3 -m venv .venv && .venv/bin/pip install -q -e ".[test]" && .venv/bin/python -m pytest',
)
SERVE = re.compile(r"^<!-- docs-test: serve -->$", re.MULTILINE)
#: A ``toml`` block of a page: its text.
TOML_BLOCK = re.compile(r"^```toml\n(.*?)^```", re.S | re.M)
#: Each whole plan file a page shows (a ``toml`` block with a name and operations), by page.
PLAN_BLOCKS = [
    (page.relative_to(ROOT).as_posix(), text)
    for page in PAGES
    for text in TOML_BLOCK.findall(page.read_text(encoding="utf-8"))
    if {"name", "operations"} <= set(tomllib.loads(text))
]
#: A hang guard on a page's whole run, server start included: try-a-machine takes 23 s on a quiet
#: host and passed 150 s once with both cores oversubscribed (issue 30 point 8: no failure
#: that is only the host's speed).
PAGE_SECONDS = 600


def _environment(folder: Path) -> dict[str, str]:
    env = {k: v for k, v in os.environ.items() if not k.startswith("RCB_")}
    env["PATH"] = f"{Path(sys.executable).parent}{os.pathsep}{env.get('PATH', '')}"
    env["COLUMNS"] = "80"  # tables as in a pipe or a log
    env["HOME"] = str(folder)
    return env


def _wait_for(port: int, seconds: float) -> None:
    deadline = time.monotonic() + seconds
    while time.monotonic() < deadline:
        with socket.socket() as s:
            if s.connect_ex(("127.0.0.1", port)) == 0:
                return
        time.sleep(0.2)
    raise AssertionError(f"rcb serve did not listen on 127.0.0.1:{port} in {seconds} s")


def _run(page: Path, cmds: list[Command], folder: Path) -> tuple[int | None, Path]:
    """Run the page's script in ``folder``: its exit status (None: not done in PAGE_SECONDS)."""
    outputs = folder / ".docs-test"
    outputs.mkdir()
    (folder / "examples").symlink_to(ROOT / "examples")
    (folder / "tests").mkdir()
    (folder / "tests" / "data").symlink_to(ROOT / "tests" / "data")
    ports = {written: free_port() for written in written_ports(cmds)}
    port = ports[PORT]
    env = _environment(folder)
    (outputs / "run.sh").write_text(script(cmds, ports, outputs), encoding="utf-8")
    serve = None
    if SERVE.search(page.read_text(encoding="utf-8")):
        serve = subprocess.Popen(
            [
                str(Path(sys.executable).parent / "rcb"),
                "serve",
                "--db",
                "sqlite:///./rcb.db",
                "--port",
                str(port),
            ],
            cwd=folder,
            env=env,
            stdout=subprocess.DEVNULL,
            stderr=subprocess.DEVNULL,
            start_new_session=True,
        )
        _wait_for(port, 60)
    shell = subprocess.Popen(
        ["bash", str(outputs / "run.sh")], cwd=folder, env=env, start_new_session=True
    )
    code: int | None = None
    try:
        code = shell.wait(timeout=PAGE_SECONDS)
    except subprocess.TimeoutExpired:
        pass  # the group is killed below; the test says what was running
    finally:
        for process in (shell, serve):
            if process is not None:
                try:
                    os.killpg(process.pid, signal.SIGTERM)
                except ProcessLookupError:
                    pass
                process.wait(timeout=30)
    return code, outputs


@pytest.mark.parametrize("page", RUNNABLE, ids=lambda p: p.relative_to(ROOT).as_posix())
def test_every_command_of_the_page_runs_and_prints_what_it_shows(page, tmp_path):
    cmds = commands(page, ROOT)
    code, outputs = _run(page, cmds, tmp_path)
    if code is None:
        pytest.fail(hung(cmds, outputs, PAGE_SECONDS))
    failed = outputs / "failed"
    if code != 0 or failed.exists():
        index, status = failed.read_text().split() if failed.exists() else ("?", str(code))
        cmd = cmds[int(index)] if index.isdigit() else None
        out = (outputs / f"{index}.out").read_text(errors="replace") if cmd else ""
        where = f"{cmd.page}:{cmd.line}: $ {cmd.text}" if cmd else "the page's script"
        pytest.fail(f"{where}\nexit {status}\n{out[-3000:]}")
    for index, cmd in enumerate(cmds):
        file = outputs / f"{index}.out"
        out = file.read_text(errors="replace") if file.exists() else ""
        missing = cmd.expects_in(out)
        assert not missing, f"{cmd.page}:{cmd.line}: $ {cmd.text}\nmissing {missing}\n{out[-3000:]}"


def test_the_plan_file_guide_shows_a_plan_file_that_runs():
    assert "docs/guide/plan-files.md" in [page for page, _ in PLAN_BLOCKS]


@pytest.mark.parametrize(("page", "text"), PLAN_BLOCKS, ids=[p for p, _ in PLAN_BLOCKS])
def test_every_plan_file_of_the_docs_is_optimized(runner, tmp_path, page, text):
    """Before: plan-files.md's limited roughness_um with no roughness model for its tool."""
    plan = tmp_path / "snippet.toml"
    plan.write_text(text, encoding="utf-8")
    done = invoke(runner, "optimize", str(plan), "--json")
    assert done.exit_code == 0, f"{page}: {done.stderr}"
    name = tomllib.loads(text)["name"]
    assert json.loads(done.stdout)["plan"] == name


def test_readme_opens_with_the_two_install_commands_ci_runs():
    text = README.read_text(encoding="utf-8")
    opening = f"# rcb-supervisor\n\n```bash\n{INSTALL[0]}\n{INSTALL[1]}\n```\n"
    assert text.startswith(opening)
    ci = (ROOT / ".ci" / "run").read_text(encoding="utf-8")
    assert INSTALL[1] in ci.splitlines()


def test_readme_is_at_most_10_kB_and_links_into_the_docs():
    text = README.read_text(encoding="utf-8")
    assert len(text.encode("utf-8")) <= 10_000
    for link in re.findall(r"\]\((docs/[^)#]+)", text):
        assert (ROOT / link).is_file(), link


def test_readmes_machine_commands_are_run_by_the_machine_page():
    """README's serve, collect, watch block is skipped there: the page runs the same lines."""
    block = re.search(r"## Try a machine.*?```console\n(.*?)```", README.read_text(), re.S)
    assert block is not None
    lines = [line[2:] for line in block.group(1).splitlines() if line.startswith("$ ")]
    page = [c.text for c in commands(ROOT / "docs" / "try-a-machine.md", ROOT)]
    assert len(lines) == 3 and all(line in page for line in lines), (lines, page)


def test_readme_runs_the_demo_and_the_first_commands():
    texts = [c.text for c in commands(README, ROOT)]
    assert texts and texts[0].startswith("rcb demo")


def test_the_new_users_flow_is_run_in_order():
    """Demo; a plan stored by name; ten parts over curl; the report; collect (when written)."""
    engineer = [c.text for c in commands(ROOT / "docs/getting-started/process-engineer.md", ROOT)]
    mes = [c.text for c in commands(ROOT / "docs/getting-started/mes-integrator.md", ROOT)]
    first = [i for i, t in enumerate(engineer) if t.startswith("rcb demo")]
    create = [i for i, t in enumerate(engineer) if t.startswith("rcb plans create")]
    show = [i for i, t in enumerate(engineer) if t.startswith("rcb plans show")]
    assert first and create and show and first[0] < create[0] < show[0]
    parts = [i for i, t in enumerate(mes) if "curl" in t and "/parts" in t]
    loop = [i for i in parts if "seq -w 2 10" in mes[i]]
    report = [i for i, t in enumerate(mes) if t.startswith("rcb report")]
    assert len(parts) == 2 and loop and report and parts[-1] < report[0]
    machine = ROOT / "docs" / "try-a-machine.md"
    if machine.exists():  # written in parallel (issue 30 item 3)
        texts = " ".join(c.text for c in commands(machine, ROOT))
        assert "rcb virtual serve" in texts and "rcb collect" in texts


PAGE = """# A page

```console
$ echo one \\
    two
one two
$ printf 'a long line\\n'
a long...
```

<!-- docs-test: skip it would reach a machine -->
```console
$ false
```

```text
$ not a console block
```
"""


def test_a_page_is_read_as_its_commands_their_output_and_its_skips(tmp_path):
    page = tmp_path / "page.md"
    page.write_text(PAGE, encoding="utf-8")
    found = commands(page, tmp_path)
    assert [(c.line, c.text, c.expected) for c in found] == [
        (4, "echo one \\\n    two", ("one two",)),
        (7, "printf 'a long line\\n'", ("a long...",)),
    ]
    assert found[0].expects_in("one two\n") == []
    assert found[0].expects_in("one\n") == ["one two"]
    assert found[1].expects_in("  a long line\n") == []
    assert found[1].expects_in("not a long line\n") == ["a long..."]


def test_the_script_stops_at_the_first_failing_command_and_names_it(tmp_path):
    page = tmp_path / "page.md"
    page.write_text("```console\n$ X=1\n$ test $X = 2\n$ echo never > ran\n```\n", "utf-8")
    outputs = tmp_path / "out"
    outputs.mkdir()
    run = outputs / "run.sh"
    run.write_text(script(commands(page, tmp_path), {PORT: 1234}, outputs), encoding="utf-8")
    code = subprocess.run(["bash", str(run)], cwd=tmp_path, timeout=30).returncode
    assert code == 1
    assert (outputs / "failed").read_text().split() == ["1", "1"]
    assert not (tmp_path / "ran").exists()


def test_each_port_the_docs_write_becomes_a_free_port(tmp_path):
    """Before: only 8000 was; three fleet pages at once met on 5001 and two hung 600 s."""
    page = tmp_path / "page.md"
    page.write_text(
        "```console\n$ rcb serve --port 8000 &\n$ curl http://127.0.0.1:8000/api/v1/health\n"
        "$ rcb virtual serve --port 5001 --service-url http://127.0.0.1:8000/api/v1 &\n"
        "$ curl http://127.0.0.1:5001/lathe/current http://127.0.0.1:50012/x\n```\n",
        "utf-8",
    )
    cmds = commands(page, tmp_path)
    assert written_ports(cmds) == [8000, 5001]
    text = script(cmds, {8000: 40123, 5001: 40124}, tmp_path)
    serve = next(line for line in text.splitlines() if line.startswith("rcb serve"))
    assert serve.startswith("rcb serve --port 40123 > ") and serve.endswith(" 2>&1 &")
    assert "http://127.0.0.1:40123/api/v1/health" in text and "8000" not in text
    assert "rcb virtual serve --port 40124 --service-url http://127.0.0.1:40123/api/v1 >" in text
    assert "http://127.0.0.1:40124/lathe/current http://127.0.0.1:50012/x" in text


def test_a_machine_on_its_default_port_gets_a_free_one_too(tmp_path):
    """Before: try-a-machine.md's lathes kept 5000 and 4840, where two suites at once meet."""
    page = tmp_path / "page.md"
    page.write_text(
        "```console\n$ rcb virtual serve --protocol mtconnect --plan p.toml &\n"
        "$ curl http://127.0.0.1:5000/lathe/current\n"
        "$ rcb virtual serve --protocol opcua --plan p.toml --parts 3 &\n"
        "$ rcb virtual serve --protocol opcua --port 4841 &\n```\n",
        "utf-8",
    )
    cmds = commands(page, tmp_path)
    assert written_ports(cmds) == [8000, 5000, 4840, 4841]
    text = script(cmds, {8000: 1, 5000: 40125, 4840: 40126, 4841: 40127}, tmp_path)
    assert "rcb virtual serve --port 40125 --protocol mtconnect --plan p.toml >" in text
    assert "curl http://127.0.0.1:40125/lathe/current" in text
    assert "rcb virtual serve --port 40126 --protocol opcua --plan p.toml --parts 3 >" in text
    assert "rcb virtual serve --protocol opcua --port 40127 >" in text


def _hook(name: str):
    import importlib.util

    spec = importlib.util.spec_from_file_location(name, ROOT / "docs" / "hooks" / f"{name}.py")
    assert spec is not None and spec.loader is not None
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


def test_the_rest_reference_has_every_operation_and_schema_of_the_openapi_document():
    hook = _hook("rest_reference")
    document = hook._document()
    page = hook.render(document)
    for path, item in document["paths"].items():
        for method in item:
            assert f"### `{method.upper()} {path}`" in page
    for name in document["components"]["schemas"]:
        assert f"### {name} {{#schema-{name.lower()}}}" in page
    assert "`POST /api/v1/plans/{plan_id}/parts`" in page and "[PartCreated]" in page


def test_the_cli_reference_has_every_command_with_its_options():
    import typer

    from api.cli.main import app

    page = _hook("cli_reference").render()
    root = typer.main.get_command(app)
    for name in root.list_commands(None):
        assert f"## `rcb {name}`" in page
    create = page[page.index("### `rcb plans create`") :]
    create = create[: create.index("\n### ")]
    assert "`--strategy <learn|ivester|bayes>`" in create and "[default: learn]" in create
    assert "| `--depth-mm <float>` | Turning depth [mm]. |" in page  # a unit, not Rich markup


def test_a_page_that_declares_a_server_gets_one_on_the_port_it_writes(tmp_path):
    page = tmp_path / "page.md"
    page.write_text(
        "<!-- docs-test: serve -->\n\n```console\n"
        "$ curl -s --retry 30 --retry-connrefused --retry-delay 1 "
        "http://127.0.0.1:8000/api/v1/health\n"
        '{"status":"ok"}\n```\n',
        "utf-8",
    )
    folder = tmp_path / "run"
    folder.mkdir()
    cmds = commands(page, tmp_path)
    code, outputs = _run(page, cmds, folder)
    assert code == 0 and not (outputs / "failed").exists()
    assert cmds[0].expects_in((outputs / "0.out").read_text()) == []
    assert (folder / "rcb.db").exists()  # the test's server made the page's database


def test_a_page_that_hangs_is_reported_with_what_ran_and_what_died(tmp_path):
    """The fleet page once hung 600 s in a CI run and the failure said nothing more."""
    page = tmp_path / "page.md"
    page.write_text(
        "```console\n$ sh -c 'echo no such port >&2; exit 3' &\n$ echo waiting\n"
        "$ until [ -f never.toml ]; do sleep 0.2; done\n```\n",
        "utf-8",
    )
    outputs = tmp_path / "out"
    outputs.mkdir()
    cmds = commands(page, tmp_path)
    (outputs / "run.sh").write_text(script(cmds, {PORT: 1234}, outputs), encoding="utf-8")
    shell = subprocess.Popen(["bash", str(outputs / "run.sh")], cwd=tmp_path)
    with pytest.raises(subprocess.TimeoutExpired):
        shell.wait(timeout=3)
    shell.kill()
    shell.wait()
    report = hung(cmds, outputs, 3)
    assert report.startswith("the page did not end in 3 s; running: page.md:4: $ until [ -f")
    assert "--- 2: $ sh -c 'echo no such port >&2; exit 3' &\nno such port" in report
    assert "$ echo waiting" not in report
