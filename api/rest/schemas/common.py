"""What the schemas share: checked numbers and text, the strategy names, the closed models.

Issue 17: every input is strict (no ``true`` or ``"5"`` taken for a number), finite and within
:data:`models.bounds.LARGEST`, and every text is bounded and storable; identifiers (serials,
names) carry no control characters. Issue 29: every bound comes from :mod:`models.bounds`, which
the CLI's readers apply too.
"""

from __future__ import annotations

import types
from collections.abc import Mapping, Sequence
from typing import Annotated, Any, Literal, Union, get_args, get_origin, get_type_hints

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
from models.misspelt import unknown_field
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

#: Each ``pattern`` of a schema and what it allows, in words: a value it refuses is answered
#: with these (``cursor = 'abc': must be ...``), never the regular expression. A pattern not
#: here fails a test (every pattern of the OpenAPI document is), never shows its regex.
PATTERN_WORDS: dict[str, str] = {}


def allowed(pattern: str, words: str) -> str:
    """``pattern``, declared with what it allows in words (:data:`PATTERN_WORDS`)."""
    PATTERN_WORDS[pattern] = words
    return pattern


#: A string with something in it (the domain readers refuse blank text) that can be stored.
_VISIBLE = allowed(r"\S", "must not be blank: some visible character")
Text = Annotated[str, Field(pattern=_VISIBLE, max_length=MAX_TEXT), AfterValidator(storable)]


def _identifier(value: str) -> str:
    """A serial or a name as it is compared and stored (:func:`models.fields.identity`)."""
    return identity(value)


#: A serial or a name: text of at most :data:`models.bounds.MAX_IDENTITY` characters, no
#: control, format or other invisible characters; stored NFKC without surrounding white space.
Name = Annotated[
    str,
    Field(pattern=_VISIBLE, max_length=MAX_IDENTITY),
    AfterValidator(storable),
    AfterValidator(_identifier),
]
#: A path or query value without NUL (PostgreSQL refuses it in a query).
NO_NUL = allowed(r"^[^\x00]*$", "must not contain NUL characters")

#: The ``cursor`` of a list keyed by id (plans, a tool's fleet).
IdCursor = Annotated[
    str | None,
    Query(
        pattern=allowed(
            r"^[0-9]{1,10}$", "must be the previous page's next_cursor: 1 to 10 digits"
        ),
        description="`next_cursor` of the previous page",
    ),
]
#: The ``cursor`` of a plan's parts or setpoint versions, or of a tool's fleet: an id (a
#: version), or ``n`` and one when it pages back from the newest
#: (:mod:`api.services.read.common`: a cursor says which order it continues).
PartCursor = Annotated[
    str | None,
    Query(
        pattern=allowed(
            r"^n?[0-9]{1,10}$",
            "must be the previous page's next_cursor: 1 to 10 digits, after an n when it pages "
            "from the newest",
        ),
        description="`next_cursor` of the previous page, of the same `order`",
    ),
]
#: The ``order`` of a list that pages either way through time (setpoint versions, parts, a
#: tool's fleet).
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


#: pydantic's error type -> what the value must be, in the product's words (``str.format`` of
#: the error's ``ctx``); the words of ``rcb``'s options (:mod:`api.cli.usage_words`) and of the
#: domain readers (``required field missing``, ``unknown field; expected one of: ...``).
_MUST = {
    "missing": "required field missing",
    "string_type": "must be text (a JSON string)",
    # JSON's "\ud800" escape alone, which no UTF-8 holds (pydantic: "unable to parse raw data")
    "string_unicode": "is not valid Unicode text: a lone surrogate (a \\ud800-\\udfff escape "
    "without its pair)",
    "int_type": "must be a whole number",
    "int_parsing": "must be a whole number",
    "int_from_float": "must be a whole number",
    "float_type": "must be a number",
    "float_parsing": "must be a number",
    "finite_number": "must be a finite number",
    "bool_type": "must be true or false",
    "bool_parsing": "must be true or false",
    "dict_type": "must be an object of named fields",
    "model_type": "must be an object of named fields",
    "model_attributes_type": "must be an object of named fields",
    "list_type": "must be a list",
    "greater_than_equal": "must be at least {ge}",
    "greater_than": "must be greater than {gt}",
    "less_than_equal": "must be at most {le}",
    "less_than": "must be less than {lt}",
    "enum": "must be one of {expected}",
    "literal_error": "must be one of {expected}",
    "string_too_long": "must be at most {max_length} characters",
    "string_too_short": "must be at least {min_length} characters",
    "too_long": "must have at most {max_length} items",
    "too_short": "must have at least {min_length} item(s)",
    "extra_forbidden": "unknown field",
}


def plain_message(error: Mapping[str, Any], model: Any = None) -> str:
    """One of pydantic's errors as the service words it: what the value must be.

    Never pydantic's sentence ("Input should be ...", "Value error, ...") nor a pattern's
    regular expression (:data:`PATTERN_WORDS`). ``model``: the body's model, whose fields an
    unknown field's message lists.
    """
    kind, ctx = str(error.get("type", "")), dict(error.get("ctx") or {})
    if kind == "value_error" and "error" in ctx:
        return str(ctx["error"])
    if kind == "string_pattern_mismatch":
        # a pattern not declared: a test fails (tests/api/test_problem_wording.py); never a 500
        return PATTERN_WORDS.get(str(ctx.get("pattern")), "is not in the form this field takes")
    if kind == "extra_forbidden":
        loc = list(error.get("loc", ()))
        names = _fields_at(model, loc[:-1])
        return unknown_field(str(loc[-1]) if loc else "", names) if names else "unknown field"
    shown = {k: f"{v:g}" if isinstance(v, float) else v for k, v in ctx.items()}
    try:
        return _MUST[kind].format(**shown)
    except (KeyError, IndexError):  # a type not worded here: pydantic's, in the same voice
        message = str(error.get("msg", "invalid")).removeprefix("Value error, ")
        for said in ("Input should", "String should", "List should", "Value should"):
            message = message.replace(said, "must")
        return message


def _fields_at(model: Any, loc: list[str | int]) -> list[str]:
    """The field names of the object at ``loc`` (``("body", "operations", 0)``) in ``model``."""
    kind: Any = model
    for step in loc[1:] if loc and loc[0] == "body" else loc:
        kind = _inner(_bare(kind), step)
    kind = _bare(kind)
    if isinstance(kind, type) and issubclass(kind, BaseModel):
        return [f.alias or name for name, f in kind.model_fields.items()]
    if isinstance(kind, type) and hasattr(kind, "__total__"):  # a TypedDict
        return list(get_type_hints(kind))
    return []


def _inner(kind: Any, step: str | int) -> Any:
    """The type of ``kind``'s item ``step`` (a field, a key or an index); None if unknown."""
    if isinstance(kind, type) and issubclass(kind, BaseModel) and isinstance(step, str):
        field = kind.model_fields.get(step)
        return None if field is None else field.annotation
    if isinstance(kind, type) and hasattr(kind, "__total__"):
        return get_type_hints(kind).get(str(step))
    args = get_args(kind)
    return args[-1] if get_origin(kind) in (list, dict) and args else None


def _bare(kind: Any) -> Any:
    """``kind`` without ``Annotated`` and ``| None``."""
    while get_origin(kind) in (Annotated, Union, types.UnionType):
        kind = next((a for a in get_args(kind) if a is not type(None)), None)
    return kind
