"""The CLI reference page, written at build time from the ``rcb`` Typer app.

``on_files`` adds ``reference/cli.md``: for every command and sub-command, in the order
``rcb --help`` lists them, its usage line, its help text and a table of its arguments and
options, each as typer's own ``get_help_record`` gives it to ``--help`` (usage with type,
help with default), read from ``typer.main.get_command(app)``. Nothing of it is
written by hand, so it cannot drift from the app. (mkdocs-click was tried first: typer now
vendors click as ``typer._click``, and mkdocs-click's ``isinstance(param, click.Option)``
finds no option of a Typer command, so its tables came out empty.)
"""

from __future__ import annotations

from typing import Any

from mkdocs.structure.files import File, Files

PAGE = "reference/cli.md"


def _cell(text: str) -> str:
    return " ".join(str(text).split()).replace("|", "\\|")


def _params(command: Any, ctx: Any) -> list[str]:
    """A row per argument and option: its usage and help as ``--help`` prints them."""
    rows = []
    for param in command.get_params(ctx):
        if getattr(param, "hidden", False):
            continue
        record = param.get_help_record(ctx)
        if record is None or record[0].startswith("--help"):
            continue
        usage, help_text = record
        # a pipe inside a code span does not split a Markdown table's row: not escaped there
        rows.append(f"| `{' '.join(usage.split())}` | {_cell(help_text)} |")
    if not rows:
        return []
    return ["| argument or option | description |", "| --- | --- |", *rows, ""]


def _command(command: Any, path: list[str], parent: Any) -> list[str]:
    ctx = command.context_class(command, info_name=path[-1], parent=parent)
    name = " ".join(path)
    level = "#" * min(len(path) + 1, 4)
    lines = [f"{level} `{name}`", ""]
    usage = " ".join(command.collect_usage_pieces(ctx))
    lines += ["```text", f"{name} {usage}".rstrip(), "```", ""]
    if command.help:
        lines += [command.help.strip().replace("\b\n", ""), ""]
    lines += _params(command, ctx)
    if hasattr(command, "list_commands"):
        for sub in command.list_commands(ctx):
            child = command.get_command(ctx, sub)
            if child is not None and not getattr(child, "hidden", False):
                lines += _command(child, [*path, sub], ctx)
    return lines


def render() -> str:
    """The page's Markdown, from the app as it is installed."""
    import typer

    from api.cli.main import app

    root = typer.main.get_command(app)
    head = [
        "# CLI reference",
        "",
        "Every command of `rcb`, generated at build time from the Typer app "
        "(`docs/hooks/cli_reference.py`): the same text as `rcb COMMAND --help`. "
        "What the commands are for, with examples: [Commands](../guide/commands.md).",
        "",
    ]
    return "\n".join(head + _command(root, ["rcb"], None))


def on_files(files: Files, config: Any) -> Files:
    """Add the generated page to the site's files."""
    files.append(File.generated(config, PAGE, content=render()))
    return files
