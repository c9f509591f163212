"""The options of ``rcb fit`` (:mod:`api.cli.fit`), each an ``Annotated`` type with its help."""

from __future__ import annotations

from pathlib import Path
from typing import Annotated

import typer

DataArgument = Annotated[
    Path, typer.Argument(metavar="DATA.csv", help="Test data: a CSV file with a header line.")
]
ResponseOption = Annotated[
    str,
    typer.Option(
        "--response",
        help="Column of the measured quantity Y (with --life-to-wear: of the time).",
    ),
]
VarOption = Annotated[
    list[str] | None,
    typer.Option(
        "--var",
        help="NAME=COLUMN: a model variable (a parameter or context of --process) and its "
        "column, or COLUMN/NUMBER for the column divided by a number, e.g. "
        "feed_per_tooth_mm=feed/6 (repeatable).",
    ),
]
FixOption = Annotated[
    list[str] | None,
    typer.Option("--fix", help="NAME=EXPONENT: an exponent not to fit (repeatable)."),
]
BandOption = Annotated[
    str,
    typer.Option(
        "--band", help="range: ΔK holds every point (Ivester & Heigel); 2s: ΔK = K(e^(k·s)−1)."
    ),
]
KOption = Annotated[
    float | None,
    typer.Option("--k", help="Coverage factor of --band 2s (default 2, NIST TN 1297)."),
]
WhereOption = Annotated[
    list[str] | None,
    typer.Option(
        "--where",
        help="COLUMN=TEXT: keep the rows whose cell is this text (repeatable; all must hold).",
    ),
]
QuantityOption = Annotated[
    str | None,
    typer.Option("--quantity", help="What Y is: force_N, roughness_um, tool_life_mm3 ..."),
]
ProcessOption = Annotated[
    str, typer.Option("--process", help="turning or milling: which variable names exist.")
]
ToolNameOption = Annotated[
    str | None, typer.Option("--tool-name", help="Name of the tool --write-tool writes.")
]
WriteToolOption = Annotated[
    Path | None,
    typer.Option("--write-tool", help="Write the model here as a plan-file tool (TOML)."),
]
LifeToWearOption = Annotated[
    float | None,
    typer.Option(
        "--life-to-wear",
        metavar="VB_MM",
        help="Fit tool life: per tool (--series) the --response time at which its flank "
        "wear (--wear) first reaches VB_MM [mm], e.g. 0.3 (ISO 3685).",
    ),
]
WearOption = Annotated[
    str | None,
    typer.Option("--wear", help="Column of the flank wear [mm] (default VB)."),
]
SeriesOption = Annotated[
    str | None,
    typer.Option("--series", help="Column naming each tool's rows (default case)."),
]
