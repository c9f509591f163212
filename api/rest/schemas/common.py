"""What the schemas share: checked numbers and text, the strategy names, the closed models.

Issue 17: every input is strict (no ``true`` or ``"5"`` taken for a number), finite and within
:data:`models.bounds.LARGEST`, and every text is bounded and storable; identifiers (serials,
names) carry no control characters. Issue 29: every bound comes from :mod:`models.bounds`, which
the CLI's readers apply too.
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import Annotated, Any, Literal

from fastapi import Query
from pydantic import AfterValidator, BaseModel, ConfigDict, Field, WithJsonSchema

from models.bounds import (
    LARGEST,
    LARGEST_WHOLE,
    MAX_IDENTITY,
    MAX_TEXT,
    SMALLEST_POSITIVE,
)
from models.fields import identity, storable
from supervisor.rcb.strategies import REGISTRY, STRATEGY_NAMES

#: What the docs say of each strategy: its name and summary from the registry.
STRATEGY_DOC = "RCB strategy: " + "; ".join(f"{s.name}: {s.summary}" for s in REGISTRY.values())


def _registered(name: str) -> str:
    if name not in REGISTRY:
        raise ValueError(f"unknown strategy; expected one of: {', '.join(STRATEGY_NAMES)}")
    return name


#: A name of :data:`supervisor.rcb.strategies.REGISTRY`: the OpenAPI enum and the check both come
#: from the registry (never restated here).
Strategy = Annotated[
    str,
    AfterValidator(_registered),
    WithJsonSchema({"type": "string", "enum": list(STRATEGY_NAMES), "description": STRATEGY_DOC}),
]


_FINITE = {"strict": True, "allow_inf_nan": False}
#: A number: strict (JSON ``true`` or ``"5"`` is refused, an integer is taken), finite, and at
#: most :data:`models.bounds.LARGEST` in magnitude.
Number = Annotated[float, Field(ge=-LARGEST, le=LARGEST, **_FINITE)]
#: A :data:`Number` > 0 (at least :data:`models.bounds.SMALLEST_POSITIVE`).
Positive = Annotated[float, Field(ge=SMALLEST_POSITIVE, le=LARGEST, **_FINITE)]
#: A :data:`Number` >= 0.
NonNegative = Annotated[float, Field(ge=0, le=LARGEST, **_FINITE)]
#: A whole number >= 1 (strict: no ``true``, ``"5"`` or ``5.0``) that an integer column holds.
Count = Annotated[int, Field(strict=True, ge=1, le=LARGEST_WHOLE)]

#: A string with something in it (the domain readers refuse blank text) that can be stored.
Text = Annotated[str, Field(pattern=r"\S", max_length=MAX_TEXT), AfterValidator(storable)]


def _identifier(value: str) -> str:
    """A serial or a name as it is compared and stored (:func:`models.fields.identity`)."""
    return identity(value)


#: A serial or a name: text of at most :data:`models.bounds.MAX_IDENTITY` characters, no
#: control, format or other invisible characters; stored NFKC without surrounding white space.
Name = Annotated[
    str,
    Field(pattern=r"\S", max_length=MAX_IDENTITY),
    AfterValidator(storable),
    AfterValidator(_identifier),
]
#: A path or query value without NUL (PostgreSQL refuses it in a query).
NO_NUL = r"^[^\x00]*$"

#: The ``cursor`` of a list keyed by id (plans, a tool's fleet).
IdCursor = Annotated[
    str | None,
    Query(pattern=r"^[0-9]{1,10}$", description="`next_cursor` of the previous page"),
]
#: The ``cursor`` of a plan's parts or setpoint versions: an id (a version), or ``n`` and one
#: when it pages back from the newest (:mod:`api.services.read.common`: a cursor says which
#: order it continues).
PartCursor = Annotated[
    str | None,
    Query(
        pattern=r"^n?[0-9]{1,10}$",
        description="`next_cursor` of the previous page, of the same `order`",
    ),
]
#: The ``order`` of a list that pages either way through time (setpoint versions, parts).
PageOrder = Literal["oldest", "newest"]


def keys_schema(names: list[str]) -> dict[str, Any]:
    """JSON Schema of a table whose keys the domain reader checks.

    Documented, not validated here: the reader's error, naming the field and the known keys, is
    what the client sees.
    """
    return {"propertyNames": {"enum": names}}


class Out(BaseModel):
    """A response body: nothing beyond its declared fields."""

    model_config = ConfigDict(extra="forbid")


class Band(Out):
    """A prediction and its band ± ΔY."""

    value: float
    band: float


def field_path(loc: Sequence[str | int]) -> str:
    """``("body", "operations", 0, "name")`` → ``operations[0].name``."""
    parts = list(loc)
    if parts and parts[0] in ("body", "query", "path", "header"):
        parts = parts[1:]
    out = ""
    for part in parts:
        out += f"[{part}]" if isinstance(part, int) else (f".{part}" if out else str(part))
    return out or "body"
