"""The RCB settings over REST, derived from their one declaration.

:data:`supervisor.rcb.settings.SETTINGS` declares each setting's name, type, range, default and
doc; the input schema (a plan's ``rcb`` table, a replan's ``rcb`` change), the output schema
(a plan's ``settings``) and the query parameters of ``POST /plans``
(:func:`settings_query_parameters`) are made from it here, never restated.
"""

# no "from __future__ import annotations": FastAPI reads the parameters' annotations at run time

import inspect
from typing import Annotated, Any

from fastapi import Query, Request
from pydantic import BaseModel, ConfigDict, Field, create_model

from api.rest.schemas.common import STRATEGY_DOC, NonNegative, Out, Strategy, keys_schema
from api.services.plans import floors_from
from models.quantities import MODEL_QUANTITIES
from supervisor.rcb.settings import SETTINGS, Setting

#: The settings a plan shows as fields of its own, beside ``settings`` (PlanSummary).
OWN_FIELDS = ("strategy", "alpha")
#: The query parameter of ``floors``: repeated ``QUANTITY=VALUE``.
FLOOR_QUERY = "floor"
_FLOOR_DOC = "least band QUANTITY=VALUE (repeatable); default: the u"


def _bounds(setting: Setting) -> dict[str, Any]:
    low = {"gt": setting.low} if setting.open_low else {"ge": setting.low}
    return {**low, "le": setting.high, "allow_inf_nan": False}


def _input(setting: Setting) -> tuple[Any, Any]:
    """The optional field of ``setting`` in :class:`RcbSettingsIn` (omitted: unchanged)."""
    if setting.kind == "choice":
        return Strategy | None, Field(None, description=STRATEGY_DOC)
    if setting.kind == "floors":
        floors = dict[str, NonNegative] | None
        names = keys_schema(list(MODEL_QUANTITIES))
        return floors, Field(None, description=setting.doc, json_schema_extra=names)
    number = Annotated[float, Field(strict=True, **_bounds(setting))]
    return number | None, Field(None, description=setting.doc)


def _output(setting: Setting) -> tuple[Any, Any]:
    """The field of ``setting`` in :class:`RcbSettingsOut` (every setting resolved)."""
    kind: Any = dict[str, float] if setting.kind == "floors" else float
    return kind, Field(description=setting.doc)


_RcbSettingsFields: type[BaseModel] = create_model(
    "_RcbSettingsFields",
    __config__=ConfigDict(extra="forbid", allow_inf_nan=False),
    **{name: _input(s) for name, s in SETTINGS.items()},  # type: ignore[call-overload]
)


class RcbSettingsIn(_RcbSettingsFields):  # type: ignore[misc,valid-type]
    """RCB settings, as a plan file's [rcb] table; omitted: unchanged (a new plan: default)."""


_RcbSettingsOutFields: type[Out] = create_model(  # type: ignore[call-overload]
    "_RcbSettingsOutFields",
    __base__=Out,
    **{name: _output(s) for name, s in SETTINGS.items() if name not in OWN_FIELDS},
)


class RcbSettingsOut(_RcbSettingsOutFields):  # type: ignore[misc,valid-type]
    """The plan's RCB settings beyond strategy and alpha."""


def _query(setting: Setting) -> inspect.Parameter:
    """The query parameter of ``setting`` in ``POST /plans``."""
    keyword = inspect.Parameter.KEYWORD_ONLY
    if setting.kind == "choice":
        strategy = Annotated[Strategy, Query(description=STRATEGY_DOC)]
        return inspect.Parameter(
            setting.name, keyword, annotation=strategy, default=setting.default
        )
    if setting.kind == "floors":
        floors = Annotated[list[str] | None, Query(description=_FLOOR_DOC)]
        return inspect.Parameter(FLOOR_QUERY, keyword, annotation=floors, default=None)
    default = setting.default_value()
    kind: Any = float if default is not None else float | None
    number = Annotated[kind, Query(**_bounds(setting), description=setting.doc)]
    return inspect.Parameter(setting.name, keyword, annotation=number, default=default)


def settings_in_query(request: Request, **values: Any) -> dict[str, object]:
    """A dependency: the settings the query of ``request`` names (others left out).

    One query parameter per setting: its signature is made from :data:`SETTINGS` below.
    """
    given: dict[str, object] = {}
    for name, setting in SETTINGS.items():
        key = FLOOR_QUERY if setting.kind == "floors" else name
        if key in request.query_params:
            value = values[key]
            given[name] = floors_from(value, FLOOR_QUERY) if key == FLOOR_QUERY else value
    return given


_REQUEST = inspect.Parameter("request", inspect.Parameter.POSITIONAL_OR_KEYWORD, annotation=Request)
settings_in_query.__signature__ = inspect.Signature(  # type: ignore[attr-defined]
    [_REQUEST, *(_query(s) for s in SETTINGS.values())], return_annotation=dict[str, object]
)
