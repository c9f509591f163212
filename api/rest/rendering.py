"""A page's JSON rendered in the worker thread, a few items at a time, writes first.

FastAPI validates a sync route's answer in a worker thread but renders its JSON in the event
loop, in one call: a 500 kB history page then holds the loop (and the interpreter lock)
while an MES report waits. :func:`page_response` validates and converts the page's items a
chunk at a time in the route's own thread, pausing between chunks while a write is in
flight (:mod:`api.services.writes_first`), and returns the finished response: the document is
the one FastAPI would render from ``response_model`` (same validation, same JSON values).
"""

from __future__ import annotations

import json
import typing
from collections.abc import Mapping
from functools import cache
from typing import Any

from fastapi.responses import Response
from pydantic import BaseModel, TypeAdapter

from api.services.writes_first import GATE

#: Items validated and converted between two pauses.
CHUNK = 10


@cache
def _item_adapter(model: type[BaseModel], key: str) -> TypeAdapter[Any]:
    (item,) = typing.get_args(model.model_fields[key].annotation)
    return TypeAdapter(item)


def page_response(model: type[BaseModel], data: Mapping[str, Any], key: str) -> Response:
    """``data`` (whose list ``key`` holds the page's items) as ``model``'s JSON response."""
    adapter = _item_adapter(model, key)
    items: list[Any] = []
    page = data[key]
    for start in range(0, len(page), CHUNK):
        GATE.pause()
        for item in page[start : start + CHUNK]:
            items.append(adapter.dump_python(adapter.validate_python(item), mode="json"))
    document = model.model_validate({**data, key: []}).model_dump(mode="json")
    document[key] = items
    GATE.pause()
    body = json.dumps(document, ensure_ascii=False, allow_nan=False, separators=(",", ":"))
    return Response(body.encode("utf-8"), media_type="application/json")
