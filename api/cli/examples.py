"""``rcb examples``: the example files installed with the package, listed or copied out to edit.

The files are package data (``api/cli/example_files/*.toml``, links to the repository's
``examples/``: one copy), found with :mod:`importlib.resources`, so ``rcb demo`` and
``rcb examples`` work from any directory and from an installed wheel.
"""

from __future__ import annotations

from collections.abc import Iterator
from contextlib import contextmanager
from importlib import resources
from importlib.resources.abc import Traversable
from pathlib import Path
from typing import Annotated

import typer
from rich.console import Console
from rich.text import Text

from api.cli.common import JsonOption, emit, errors, say, write_atomically
from api.cli.tables import new_table
from models.errors import InputError

#: The package and folder the example files are installed in.
_PACKAGE, _FOLDER = "api.cli", "example_files"

examples_app = typer.Typer(
    help="Example plans and files shipped with rcb: list them, copy one out to edit.",
    invoke_without_command=True,
)
_out = Console()


def _files() -> dict[str, Traversable]:
    """Every example file by name (its stem), sorted by name."""
    folder = resources.files(_PACKAGE).joinpath(_FOLDER)
    found = (f for f in folder.iterdir() if f.name.endswith(".toml"))
    return {f.name.removesuffix(".toml"): f for f in sorted(found, key=lambda f: f.name)}


def names() -> list[str]:
    """The names of the example files (``ivester_demo_part`` ...)."""
    return list(_files())


def _find(name: str, field: str = "NAME") -> Traversable:
    files = _files()
    found = files.get(name.removesuffix(".toml"))
    if found is None:
        raise InputError(field, name, f"no such example; known: {', '.join(files)}")
    return found


@contextmanager
def example_path(name: str) -> Iterator[Path]:
    """The example ``name`` as a file path while the context lasts (a copy if zipped)."""
    with resources.as_file(_find(name)) as path:
        yield path


#: What each example is and the command that runs it (others: their first comment line).
_SUMMARIES = {
    "ivester_demo_part": (
        "Ivester & Heigel's six-operation turning part (Tables 4-5)",
        "rcb demo",
    ),
    "milling_demo_part": (
        "a slot and a side finish; spindle current as the force sensor",
        "rcb demo --milling",
    ),
    "tai_constant_load_part": (
        "constant-load milling of Tai, Tsai & Li (feed override)",
        "rcb optimize FILE",
    ),
    "borangiu_domain": (
        "Borangiu's (feed rate, spindle speed) domain of one pass",
        "rcb milling domain FILE",
    ),
    "turning_passes_part": (
        "stock in whole passes: an OD with a finishing pass, a face",
        "rcb optimize FILE",
    ),
    "milling_passes_part": (
        "the milling demo's 6 mm slot in whole axial passes",
        "rcb demo --plan FILE",
    ),
    "virtual_lathe_part": (
        "the demo part with its spindle-load calibration: a machine to collect from",
        "rcb virtual serve --protocol mtconnect --plan FILE",
    ),
    "cam_relief_part": (
        "a relief from a depth map: flat roughing, ball finishing",
        "rcb cam depthmap IMAGE --pixel-mm P --z-range-mm LO:HI --tool flat:10 "
        "--plan FILE --operation rough --out OUT.nc",
    ),
}


def summary(name: str) -> tuple[str, str]:
    """What the example ``name`` is, and the command that runs it (``FILE``: its path)."""
    if name in _SUMMARIES:
        return _SUMMARIES[name]
    first = _find(name).read_text(encoding="utf-8").partition("\n")[0]
    return first.lstrip("#").strip(), "rcb optimize FILE"


@examples_app.callback()
def examples(ctx: typer.Context, as_json: JsonOption = False) -> None:
    """List the example files (name, what it is); rcb examples copy NAME copies one out."""
    if ctx.invoked_subcommand is not None:
        return
    listed = [
        {"name": n, "file": f"{n}.toml", "summary": summary(n)[0], "run": summary(n)[1]}
        for n in names()
    ]
    if as_json:
        emit({"examples": listed})
        return
    table = new_table(title="examples: rcb examples copy NAME [DEST]", title_justify="left")
    table.add_column("name", overflow="fold")
    table.add_column("what it is; how to run it", overflow="fold")
    for entry in listed:
        table.add_row(entry["name"], Text.assemble(entry["summary"], "\n", (entry["run"], "dim")))
    _out.print(table)


@examples_app.command("copy")
def copy(
    name: Annotated[str, typer.Argument(metavar="NAME", help="An example's name (rcb examples).")],
    dest: Annotated[
        Path | None,
        typer.Argument(metavar="[DEST]", help="File or directory (default: ./NAME.toml)."),
    ] = None,
    force: Annotated[bool, typer.Option("--force", help="Overwrite an existing file.")] = False,
) -> None:
    """Copy an example file out to edit (never over an existing file without --force)."""
    with errors():
        source = _find(name)
        target = dest if dest is not None else Path(source.name)
        if target.is_dir():
            target = target / source.name
        if not target.parent.is_dir():
            raise InputError("DEST", str(target), "the directory does not exist")
        if target.exists() and not force:
            raise InputError("DEST", str(target), "exists already (--force overwrites it)")
        write_atomically(target, source.read_bytes(), "DEST")
    say(f"rcb: wrote {target}")
