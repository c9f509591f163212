"""Tables keyed by quantity or parameter name, as models a client generator turns into types.

A setpoint (``{depth_mm: 2.1, ...}``), its predictions (``{force_N: {value, band}, ...}``) and a
part's measurements (``{force_N: {value, uncertainty}, ...}``) travel as JSON objects whose
keys are names of the registries (:data:`models.kinematics.PARAMETERS`,
:data:`models.quantities.QUANTITIES`). Declared as free maps, a generated client types them as
``dict[str, Any]`` and leaves the names to the reader of the docs; here each is a model with one
optional property per registered name, built from the registry (a new quantity is a new
property, never restated here).

On the wire nothing changes: a name without a value is absent, never ``null``. The JSON Schema
says so (the property is optional and not nullable); an answer omits the names without a
value (:meth:`Keyed._omit_absent`); a request that sends ``null`` for one is refused (422).
"""

from __future__ import annotations

from collections.abc import Callable, Iterable
from typing import Any

from pydantic import (
    BaseModel,
    ConfigDict,
    Field,
    SerializerFunctionWrapHandler,
    create_model,
    model_serializer,
)


def _not_nullable(schema: dict[str, Any]) -> None:
    """Every property optional, not nullable and without a default (absent: no value)."""
    for prop in schema.get("properties", {}).values():
        prop.pop("default", None)
        branches = prop.pop("anyOf", None)
        if branches is not None:  # "X | None": keep X
            kept = [b for b in branches if b != {"type": "null"}]
            prop.update(kept[0] if len(kept) == 1 else {"anyOf": kept})


def _closed(schema: dict[str, Any]) -> None:
    """:func:`_not_nullable`, and no other property (the readers refuse other names)."""
    _not_nullable(schema)
    schema["additionalProperties"] = False


class Keyed(BaseModel):
    """A table of values by registered name; names without a value are left out of answers."""

    model_config = ConfigDict(json_schema_extra=_not_nullable)

    @model_serializer(mode="wrap")
    def _omit_absent(self, handler: SerializerFunctionWrapHandler):  # type: ignore[no-untyped-def]
        # no return annotation: pydantic then documents the answer with the model's own
        # schema (an annotation would replace it, "-> Any" by an empty one)
        data = handler(self)
        if isinstance(data, dict):
            return {k: v for k, v in data.items() if v is not None or k not in self.model_fields}
        return data


class KeyedOut(Keyed):
    """An answer's table: nothing beyond the registered names."""

    model_config = ConfigDict(extra="forbid", json_schema_extra=_closed)


class KeyedIn(Keyed):
    """A request's table: other names pass to the domain reader, which refuses them by name.

    The reader's message lists the names it knows (``unknown quantity; known: ...``); the
    schema declares no other property.
    """

    model_config = ConfigDict(extra="allow", json_schema_extra=_closed)


def keyed_model(
    name: str,
    doc: str,
    names: Iterable[str],
    value: Any,
    describe: Callable[[str], str],
    base: type[Keyed] = KeyedOut,
) -> type[Keyed]:
    """A :class:`Keyed` model ``name`` with an optional ``value`` property per name.

    ``value``: the type of each entry; ``describe``: the description of a name's entry.
    """
    fields: dict[str, Any] = {n: (value, Field(None, description=describe(n))) for n in names}
    model: type[Keyed] = create_model(name, __base__=base, __doc__=doc, **fields)
    model.__module__ = __name__
    return model
