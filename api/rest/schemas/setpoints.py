"""Setpoints as the MES reads them: per operation the cutting parameters and predictions."""

from __future__ import annotations

from typing import TYPE_CHECKING, Annotated, Literal

from pydantic import Field

from api.rest.schemas.common import Band, Out
from api.rest.schemas.quantities import keyed_table
from db.fleet_names import MAX_NAMED
from models.kinematics import PARAMETERS, PROCESSES
from models.quantities import QUANTITIES
from supervisor.inputs.objectives import Objective

#: Every cutting parameter, in the processes' order (turning's, then milling's new ones).
ALL_PARAMETERS = list(dict.fromkeys(p for process in PROCESSES for p in PARAMETERS[process]))


#: The unit each parameter name ends with (DESIGN.md, "Contracts"), longest first.
_UNITS = (("_mm_rev", "mm/rev"), ("_m_min", "m/min"), ("_mm", "mm"))


def _parameter(name: str) -> str:
    """``feed [mm/rev] (turning)``: the name's words, its unit, the processes that have it."""
    processes = ", ".join(p for p in PROCESSES if name in PARAMETERS[p])
    suffix, unit = next((s, u) for s, u in _UNITS if name.endswith(s))
    return f"{name.removesuffix(suffix).replace('_', ' ')} [{unit}] ({processes})"


def _quantity(name: str) -> str:
    q = QUANTITIES[name]
    return f"{q.description} [{q.unit}]; a limit on it is a {q.sense}imum"


_SETPOINT_DOC = (
    "The cutting parameters of an operation, each in the unit its name ends with; those of "
    "its process only (turning: depth_mm, feed_mm_rev, speed_m_min; milling: axial_depth_mm, "
    "radial_depth_mm, feed_per_tooth_mm, speed_m_min)."
)
_PREDICTED_DOC = (
    "Per quantity predicted at the setpoint (those the tool models, and those derived from "
    "them and the parameters), its value and band, in the unit its name ends with."
)

if TYPE_CHECKING:  # to mypy, maps of names; at run time typed tables built from the registries
    Setpoint = dict[str, float]
    Predicted = dict[str, Band]
else:
    #: A setpoint: a property per cutting parameter (models.kinematics.PARAMETERS).
    Setpoint = keyed_table("Setpoint", _SETPOINT_DOC, ALL_PARAMETERS, float, _parameter)
    #: Predictions: a property per quantity (models.quantities.QUANTITIES).
    Predicted = keyed_table("Predicted", _PREDICTED_DOC, list(QUANTITIES), Band, _quantity)


class ConstantLoadOut(Out):
    """Constant-load control of a milling setpoint (Tai et al.): what the inner loop holds."""

    reference_current_A: float = Field(description="spindle current the feed override holds")
    feed_rate_upper_mm_min: float = Field(description="never above the programmed feed rate")
    feed_rate_lower_mm_min: float = Field(description="change the tool when the feed reaches it")
    programmed_feed_rate_mm_min: float
    upper_governed_by: Literal["current", "setpoint"]
    tool_change_by_feed: bool
    wear_interval_mm: tuple[float, float]


class PassGroupOut(Out):
    """The passes of one kind of an operation cut in whole passes, all at one setpoint."""

    kind: Literal["roughing", "finishing"]
    count: int = Field(description="passes of this kind")
    depth_mm: float = Field(description="depth of each (milling: axial depth)")
    setpoint: Setpoint
    predicted: Predicted
    mrr_cm3_min: float
    time_min: float = Field(description="of all passes of this kind")
    binding: list[str]
    robust_by: Literal["band", "cone"] = "band"


class PassesOut(Out):
    """An operation's stock_mm cut in whole passes: roughing first, then the finish if any."""

    stock_mm: float
    count: int = Field(description="passes in all")
    groups: list[PassGroupOut]


class OperationSetpoint(Out):
    """One operation's setpoint as in ``rcb optimize --json``."""

    name: str
    tool: str
    process: str
    setpoint: Setpoint
    predicted: Predicted
    mrr_cm3_min: float
    time_min: float
    binding: list[str]
    objective: Objective = "mrr"
    cost_per_kg: float | None = Field(
        None, description="Borangiu's productivity cost J, when the operation has cost data"
    )
    constant_load: ConstantLoadOut | None = None
    robust_by: Literal["band", "cone"] = Field(
        "band",
        description="what keeps the setpoint safe: the bands, or (strategy learn) the learned "
        "model's cone; with cone, predicted shows the learned value and the cone's half-width",
    )
    passes: PassesOut | None = Field(
        None,
        description="an operation with stock_mm: the passes, their depths and setpoints; "
        "setpoint is then the roughing passes', mrr_cm3_min the volume over time_min",
    )


class LeftOutPlans(Out):
    """A tool's plans the fleet left out, among its machines' newest, by their first reason."""

    taken_out: int = Field(description="taken out by an engineer (the plan or its machine)")
    halted: int = Field(description="halted")
    changed: int = Field(
        description="its process changed beyond what an engineer accepted (rcb fleet include)"
    )


class PriorProvenance(Out):
    """Where a quantity's fleet prior came from."""

    quantity: str
    plans: list[str] | None = Field(
        description=f"the stored plans whose readings it holds, the first {MAX_NAMED} by name "
        "(null to a key scoped to plans: other plans' names are not shown to it); "
        "GET /tools/{name}/fleet lists every plan, a page at a time"
    )
    plans_total: int = Field(description="how many plans it holds the readings of")
    machines: list[str] | None = Field(
        description=f"the machines they ran on, the first {MAX_NAMED} by name (null to a key "
        "scoped to plans)"
    )
    machines_total: int = Field(description="how many machines they ran on")
    between_machine_spread: float = Field(
        description="the learned spread of ln K between machines [-] (0.041: 4.1 %)"
    )
    operation_spread: float | None = Field(
        None,
        description="the learned spread of an operation's ln K about its machine's [-] "
        "(null: a prior made before it was learned, at the default 0.02)",
    )
    readings: int
    band_checked_at_sd: float | None = Field(
        None,
        description="where the fleet's machines differ by more than the catalogue's band, "
        "or a plan of the tool halted (band_checked_because says which): the band's "
        "optimum runs only where it holds at this many standard deviations of the fleet "
        "prior, else the prior's (slower) setpoint does (null: checked at its mean)",
    )
    band_checked_because: list[Literal["spread", "halted"]] | None = Field(
        None,
        description="why the band's optimum is checked at band_checked_at_sd: 'spread', the "
        "machines' spread of ln K passes the band; 'halted', a plan of the tool halted "
        "(left_out.halted counts them); empty where it is not (null: a prior stored before "
        "the reason was kept)",
    )
    widened_by_part: str | None = Field(
        None,
        description="the serial of the part whose readings showed this machine outside the "
        "fleet's spread: its ln K was then let go to the catalogue's band, the exponents kept "
        "(null: the fleet prior holds)",
    )
    left_out: LeftOutPlans | None = Field(
        None,
        description="the tool's plans the fleet left out of this prior, among each machine's "
        "newest with it: GET /tools/{name}/fleet says which and why (null: a prior made "
        "before they were counted)",
    )
    text: str = Field(description="the provenance as one line")


class NoiseProvenance(Out):
    """Where a measuring chain's noise prior came from (supervisor.fleet.noise)."""

    quantity: str
    machines: list[str] | None = Field(
        description="the machines whose chains' readings it holds, the first "
        f"{MAX_NAMED} by name (null to a key scoped to plans)"
    )
    machines_total: int = Field(description="how many machines' chains it holds")
    readings: int
    noise_scale: float = Field(
        description="the fleet's chains' noise as a multiple of the reported u [-]"
    )
    between_chain_spread: float = Field(
        description="the learned spread of the noise variance's ln between chains [-]"
    )
    let_go_by_part: str | None = Field(
        None,
        description="the serial of the part whose readings showed this machine's chain "
        "noisier than the fleet's: its noise was then learned from the default (null: the "
        "fleet's noise prior holds)",
    )
    text: str = Field(description="the provenance as one line")


#: Where each chain's noise prior came from.
NoiseProvenances = Annotated[
    list[NoiseProvenance],
    Field(
        description="per measured quantity, where its chain's noise prior came from (empty: "
        "the default's, a chain 2.11 x noisier than it claims until its readings show "
        "otherwise)"
    ),
]


#: What ``learn`` started from.
PriorSource = Annotated[
    Literal["fleet", "catalogue"],
    Field(
        description="what learn started from: what the stored plans learned with the plan's "
        "tools (fleet), or the tools' catalogue models"
    ),
]
#: Per operation, where each quantity's fleet prior came from.
Provenances = Annotated[
    dict[str, list[PriorProvenance]],
    Field(
        description="per operation, where each quantity's fleet prior came from (empty: the "
        "catalogue's)"
    ),
]


class Setpoints(Out):
    """The setpoints in force."""

    plan_id: int
    setpoint_version: int
    prior: PriorSource
    provenance: Provenances
    noise_provenance: NoiseProvenances
    operations: list[OperationSetpoint]
