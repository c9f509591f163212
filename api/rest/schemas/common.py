"""What the schemas share: text that can be stored, the strategy names, the closed models."""

from __future__ import annotations

from typing import Annotated, Any

from pydantic import AfterValidator, BaseModel, ConfigDict, Field, WithJsonSchema

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


def _storable(value: str) -> str:
    """Refuse what no database column can hold: NUL, unpaired surrogates (JSON allows both)."""
    if "\x00" in value:
        raise ValueError("must not contain NUL characters")
    try:
        value.encode("utf-8")
    except UnicodeEncodeError:
        raise ValueError("must be valid Unicode (an unpaired surrogate)") from None
    return value


#: A string with something in it (the domain readers refuse blank text) that can be stored.
Text = Annotated[str, Field(pattern=r"\S"), AfterValidator(_storable)]
#: A path or query value without NUL (PostgreSQL refuses it in a query).
NO_NUL = r"^[^\x00]*$"


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
