"""The RCB settings reference page, written at build time from their one declaration.

``on_files`` adds ``reference/rcb-settings.md``: a row per setting of
:data:`supervisor.rcb.settings.SETTINGS` (name, what it takes, default, doc), in the order a
plan file's ``[rcb]`` table, ``rcb replan --rcb NAME=VALUE`` and the REST schemas take them.
Nothing of it is written by hand.
"""

from __future__ import annotations

from typing import Any

from mkdocs.structure.files import File, Files

PAGE = "reference/rcb-settings.md"


def _takes(setting: Any) -> str:
    if setting.kind == "choice":
        return "one of " + ", ".join(f"`{c}`" for c in setting.choices)
    if setting.kind == "floors":
        return f"a table QUANTITY = number ≥ {setting.low:g}"
    return f"a number in {setting.interval}"


def _default(setting: Any) -> str:
    value = setting.default_value()
    if value is None:
        return "the strategy's"
    return "none" if value == {} else f"`{value}`"


def render() -> str:
    """The page's Markdown, from the declaration as it is installed."""
    from supervisor.rcb.settings import SETTINGS

    lines = [
        "# RCB settings",
        "",
        "Every RCB setting of a plan, generated at build time from `supervisor.rcb.settings` "
        "(`docs/hooks/rcb_settings.py`). A plan file gives them in an `[rcb]` table, "
        "`rcb plans create` and `rcb replan` take `--rcb NAME=VALUE` (a floor: "
        "`--rcb floors.force_N=50`), `POST /plans` a query parameter each (`floor=QUANTITY=VALUE`) "
        "or the body's `rcb` object, `POST /plans/{id}/replan` an `rcb` object. An unknown name or "
        "a value out of range is refused, naming the field and the value.",
        "",
        "```toml",
        "[rcb]",
        'strategy = "bayes"',
        "alpha = 0.3",
        "floors = { force_N = 50 }",
        "```",
        "",
        "| setting | takes | default | what it is |",
        "| --- | --- | --- | --- |",
    ]
    for name, setting in SETTINGS.items():
        lines.append(f"| `{name}` | {_takes(setting)} | {_default(setting)} | {setting.doc} |")
    return "\n".join(lines) + "\n"


def on_files(files: Files, config: Any) -> Files:
    """Add the generated page to the site's files."""
    files.append(File.generated(config, PAGE, content=render()))
    return files
