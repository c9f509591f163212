"""Tools and their baseline power-law models, as added and as read."""

from __future__ import annotations

from typing import Annotated, Any

from fastapi import Query
from pydantic import BaseModel, ConfigDict, Field

from api.rest.schemas.common import Name, NonNegative, Out, Positive, Text, allowed, keys_schema
from models.bounds import LARGEST_EXPONENT
from models.kinematics import CONTEXT, PARAMETERS, PROCESSES, Process
from models.quantities import MODEL_QUANTITIES

#: An exponent of a power law or its standard error: within ±:data:`models.bounds.LARGEST_EXPONENT`.
Exponent = Annotated[
    float,
    Field(strict=True, allow_inf_nan=False, ge=-LARGEST_EXPONENT, le=LARGEST_EXPONENT),
]


class ModelIn(BaseModel):
    """A power-law model ``Y = K·Π x_i^e_i`` with band ±ΔK."""

    model_config = ConfigDict(extra="forbid", allow_inf_nan=False)
    K: Positive
    dK: NonNegative = 0.0
    exponents: dict[str, Exponent] = Field(
        default_factory=dict,
        description="per variable of the tool's process: its parameters and context",
        json_schema_extra=keys_schema(
            sorted({v for p in PROCESSES for v in PARAMETERS[p] + CONTEXT[p]})
        ),
    )
    source: Text | None = Field(None, description="default: the tool's source")
    reference: Text | None = Field(None, description="where in the source (table, equation)")
    exponent_stderr: dict[str, Exponent] | None = Field(
        None,
        description="standard errors of fitted exponents (rcb fit); learn's prior spread",
    )


def _exponents_of_process(schema: dict[str, Any]) -> None:
    """A model's exponents may only name the variables of the tool's own process."""
    schema["allOf"] = [
        {
            "if": {"properties": {"process": {"const": p}}},
            "then": {
                "properties": {
                    "models": {
                        "additionalProperties": {
                            "properties": {
                                "exponents": keys_schema(list(PARAMETERS[p] + CONTEXT[p]))
                            }
                        }
                    }
                }
            },
        }
        for p in PROCESSES
    ]


class ToolIn(BaseModel):
    """A tool with its models, as in a plan file's ``[[tools]]``."""

    model_config = ConfigDict(
        extra="forbid", allow_inf_nan=False, json_schema_extra=_exponents_of_process
    )
    name: Name
    process: Process
    description: Text | None = None
    material: Text | None = None
    source: Text | None = Field(None, description="where the models come from (default: REST API)")
    models: dict[str, ModelIn] = Field(
        min_length=1, json_schema_extra=keys_schema(list(MODEL_QUANTITIES))
    )


class ModelOut(Out):
    """A baseline model with provenance."""

    K: float
    dK: float
    exponents: dict[str, float]
    source: str
    reference: str


class ToolOut(Out):
    """A tool with its baseline models and provenance."""

    name: str
    process: str
    description: str
    material: str
    source: str
    models: dict[str, ModelOut]
    refused: str | None = Field(
        None,
        description="a stored value this version's check refuses (stored under an earlier "
        "one): which, and the way out; the plans that use the tool are refused until then "
        "(null: none)",
    )


class ToolList(Out):
    """A page of the catalogue and the stored tools, by name.

    Pass ``next_cursor`` as ``cursor`` for the next page; null: no more.
    """

    tools: list[ToolOut]
    next_cursor: str | None


class FleetMember(Out):
    """A stored plan using the tool: in the fleet (new plans' priors) or why not."""

    plan_id: int
    plan: str
    machine: str
    operations: list[str] = Field(description="the plan's operations using the tool")
    readings: int = Field(description="readings its learned models of the tool rest on")
    in_fleet: bool
    out: str = Field(description="why not in the fleet (empty when it is)")
    let_go: list[str] = Field(
        description="'OPERATION QUANTITY' whose fleet prior this plan's machine let go"
    )


class ImportedFleetMachine(Out):
    """A machine whose models of the tool this database imported: in the fleet or not."""

    machine: str = Field(description="as the fleet names it: NAME@ORIGIN (rcb fleet exclude)")
    models: int = Field(description="its learned models of the tool")
    readings: int = Field(description="readings they rest on")
    in_fleet: bool
    out: str = Field(description="why not in the fleet (empty when it is)")


class ImportedFleetList(Out):
    """A page of the machines of a tool's imported models, by name: in the fleet or not.

    Pass ``next_cursor`` as ``cursor`` for the next page; null: no more.
    """

    tool: str
    machines: list[ImportedFleetMachine] = Field(description="none for a key scoped to plans")
    next_cursor: str | None


class FleetList(Out):
    """A page of the stored plans using a tool, by id: which make new plans' fleet priors.

    Pass ``next_cursor`` as ``cursor`` for the next page; null: no more.
    """

    tool: str
    plans: list[FleetMember]
    imported: int = Field(
        description="learned models imported from other databases (their machines: "
        "GET /tools/{name}/fleet/imported)"
    )
    imported_in_fleet: int = Field(
        description="of imported, the models of machines not taken out of the fleet"
    )
    next_cursor: str | None


class LawParameter(Out):
    """One parameter of a tool's law after K: the fleet's belief and the catalogue prior's."""

    name: str = Field(
        description="an exponent's input (feed_mm_rev), or edge_rise: the rise "
        "of ln Y over an edge's life"
    )
    fleet: float
    fleet_sd: float = Field(description="a new machine's standard deviation of it")
    catalogue: float
    catalogue_sd: float


class QuantityLaw(Out):
    """What the fleet learned of one quantity's law (supervisor.fleet.law)."""

    quantity: str
    K: float = Field(description="the fleet's K (every input at 1 in its unit)")
    catalogue_K: float
    parameters: list[LawParameter]
    reference: dict[str, float] = Field(
        description="the inputs, in their units, where the machines' readings pin the law best"
    )
    law_sd: float = Field(description="sd of the fleet law's ln Y at reference [-]")
    new_machine_sd: float = Field(
        description="sd of ln Y at reference for a new machine's operation: the law, the "
        "between-machine and the between-operation spreads [-]"
    )
    catalogue_sd: float = Field(description="sd of the catalogue prior's ln Y at reference [-]")
    between_machine_spread: float = Field(description="learned spread of ln K between machines")
    operation_spread: float = Field(description="learned spread of an operation's ln K")
    plans: int
    machines: int
    readings: int
    text: str = Field(description="the provenance as one line, as a new plan's prior shows it")


class FleetLawOut(Out):
    """What the fleet learned of a tool's law, per measured quantity, beside the catalogue.

    From the plans in the fleet (GET /tools/{name}/fleet), at a new plan's default settings;
    counts only, no plan's or machine's name. Empty: new plans start from the catalogue.
    """

    tool: str
    quantities: list[QuantityLaw]


#: The ``cursor`` of a list keyed by text (tools, model versions): an opaque token.
TextCursor = Annotated[
    str | None,
    Query(
        pattern=allowed(
            r"^[A-Za-z0-9_-]{1,1200}$",
            "must be the previous page's next_cursor: 1 to 1200 letters, digits, _ or -",
        ),
        description="`next_cursor` of the previous page (opaque)",
    ),
]
