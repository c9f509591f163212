"""Tables keyed by quantity or parameter name, as types a client generator can use.

A setpoint (``{depth_mm: 2.1, ...}``), its predictions (``{force_N: {value, band}, ...}``) and a
part's measurements (``{force_N: {value, uncertainty}, ...}``) travel as JSON objects whose
keys are names of the registries (:data:`models.kinematics.PARAMETERS`,
:data:`models.quantities.QUANTITIES`). Declared as free maps, a generated client types them as
``dict[str, Any]`` and leaves the names to the reader of the docs; here each is a table with one
optional key per registered name, built from the registry (a new quantity is a new property,
never restated here).

On the wire nothing changes: a name without a value is absent, never ``null``. Each table is a
``TypedDict`` of optional keys: pydantic validates and writes it as it came (no ``null`` added
for a missing name, no Python call per answer) and documents it as an object whose properties
are optional and not nullable; a request that sends ``null`` for one is refused (422).
"""

from __future__ import annotations

from collections.abc import Callable, Iterable
from typing import Annotated, Any, Literal

from pydantic import ConfigDict, Field, with_config
from typing_extensions import TypedDict  # pydantic reads typing's only from Python 3.12


def _closed(schema: dict[str, Any]) -> None:
    """No property but the registered names (the readers refuse others, naming them)."""
    schema["additionalProperties"] = False


def keyed_table(
    name: str,
    doc: str,
    names: Iterable[str],
    value: Any,
    describe: Callable[[str], str],
    extra: Literal["forbid", "allow"] = "forbid",
) -> Any:
    """A ``TypedDict`` ``name``: an optional ``value`` entry per name, none other.

    ``describe``: the description of a name's entry. ``extra="allow"`` (a request's table):
    another name is validated as a ``value`` too and passes to the domain, which refuses it
    naming what the operation's tool can measure
    (:func:`supervisor.rcb.report_readings.check_quantity`); the schema still declares no
    other property.
    """
    fields = {n: Annotated[value, Field(description=describe(n))] for n in names}
    more: dict[str, Any] = {"extra_items": value} if extra == "allow" else {}
    table: Any = TypedDict(name, fields, total=False, **more)  # type: ignore[misc]
    table.__doc__ = doc
    table.__module__ = __name__
    config = ConfigDict(json_schema_extra=_closed)
    if extra == "forbid":
        config["extra"] = "forbid"
    return with_config(config)(table)
