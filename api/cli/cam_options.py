"""The options of ``rcb cam depthmap`` (:mod:`api.cli.cam`), each an ``Annotated`` type."""

from __future__ import annotations

from pathlib import Path
from typing import Annotated

import typer

ImageArgument = Annotated[
    Path, typer.Argument(metavar="IMAGE", help="8/16-bit greyscale PNG or TIFF.")
]
PixelOption = Annotated[float, typer.Option("--pixel-mm", help="Pixel size [mm].")]
ZRangeOption = Annotated[
    str, typer.Option("--z-range-mm", metavar="LO:HI", help="Heights of black and white [mm].")
]
ToolOption = Annotated[str, typer.Option("--tool", help="Roughing cutter: flat:D.")]
PlanOption = Annotated[Path, typer.Option("--plan", metavar="PLAN.toml", help="The plan file.")]
OperationOption = Annotated[str, typer.Option("--operation", help="The plan's roughing operation.")]
OutOption = Annotated[Path, typer.Option("--out", metavar="program.nc", help="Program to write.")]
FinishOption = Annotated[
    str | None, typer.Option("--finish", help="Finishing cutter: ball:D, bull:D:R or flat:D.")
]
FinishOperationOption = Annotated[
    str | None,
    typer.Option("--finish-operation", help="The plan's finishing operation [default: finish]."),
]
StepoverOption = Annotated[float, typer.Option("--stepover-mm", help="Finishing stepover [mm].")]
FinishDirectionOption = Annotated[
    str, typer.Option("--finish-direction", help="x, y or an angle in degrees (Bresenham).")
]
NegativeOption = Annotated[
    bool, typer.Option("--negative", help="Complement the grey levels (a mould).")
]
StockTopOption = Annotated[
    float | None, typer.Option("--stock-top-mm", help="Top of the stock [default: HI].")
]
AllowanceOption = Annotated[
    float, typer.Option("--allowance-mm", help="Stock left by roughing [mm].")
]
FormToleranceOption = Annotated[
    float | None,
    typer.Option(
        "--form-tolerance-mm",
        help="Stair left between levels [mm] [default: the allowance with --finish, else 0.04].",
    ),
]
MaxArcRadiusOption = Annotated[
    float, typer.Option("--max-arc-radius-mm", help="Largest G2/G3 radius [mm].")
]
PreviewOption = Annotated[
    Path | None, typer.Option("--preview", metavar="preview.png", help="Draw the paths.")
]
VerifyOption = Annotated[bool, typer.Option("--verify", help="Simulate the program.")]
