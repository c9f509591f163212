"""One reading of a request: strict JSON, one value per single-valued parameter, digit ids.

Issue 29: FastAPI (through Python's ``json``) reads a UTF-16 or UTF-32 body as JSON, keeps the
last of two equal keys in an object, takes the last of a repeated query parameter, and reads a
path id ``%201`` (`` 1``), ``+1`` or ``١`` as plan 1. A client that sends either spelling then
gets an answer to a request it did not mean. Here, before the route's own parameters are read:

- the body (of a route that takes JSON) is UTF-8 (RFC 8259 §8.1): a NUL byte (UTF-16 or UTF-32
  text) or an invalid UTF-8 sequence is 400 ``body_not_utf8``; an empty body sent as JSON
  (every route that takes one requires it; none and no ``Content-Type``: 422 ``body`` missing),
  invalid JSON, or JSON nested over :data:`MAX_DEPTH` levels is 400
  ``malformed_json`` saying which; an object with a key twice is 400 ``duplicate_key`` naming
  the key;
- a query parameter the route does not declare is 422 ``invalid`` naming it and the known ones
  (``limitt: unknown query parameter; known: cursor, limit``): it was ignored, and
  ``GET /plans?limitt=5`` answered the default page as if the client had asked for it. Every
  route that takes input (a path, query or body) checks it, as every such route declares a 422
  (:mod:`api.rest.answers`); ``GET /health``, which takes none, answers whatever its query;
- a query parameter that takes one value, given twice, is 400 ``repeated_parameter`` naming it;
- an integer path parameter is ASCII digits only, else 422 ``invalid`` naming it.

Each as RFC 9457 problem+json (:mod:`api.rest.problems`).
"""

from __future__ import annotations

import json
import re
import types
from collections.abc import Callable, Coroutine, Sequence
from typing import Any, Union, get_args, get_origin

from fastapi import HTTPException
from fastapi.dependencies.models import Dependant
from fastapi.routing import APIRoute
from starlette.requests import ClientDisconnect, Request
from starlette.responses import Response

from api.rest.problems import ProblemError

_DIGITS = re.compile(r"[0-9]+")
#: The most levels of objects and arrays nested in a body (a plan's go 5 deep). Deeper JSON is
#: valid, but Python's reader refuses it past its recursion limit, which is no fixed number.
MAX_DEPTH = 64
_TOO_DEEP = (
    f"the body nests objects and arrays more than {MAX_DEPTH} levels deep, "
    "the most the service reads"
)
_MANY = (list, set, frozenset, tuple, Sequence)


class DuplicateKeyError(Exception):
    """An object of the body names ``key`` twice."""

    def __init__(self, key: str) -> None:
        self.key = key
        super().__init__(key)


def _no_duplicates(pairs: list[tuple[str, Any]]) -> dict[str, Any]:
    table: dict[str, Any] = {}
    for key, value in pairs:
        if key in table:
            raise DuplicateKeyError(key)
        table[key] = value
    return table


def loads(body: bytes) -> Any:
    """The JSON document in ``body``, read strictly; :class:`ProblemError` when it is not one."""
    if not body.strip(b" \t\r\n"):  # JSON's white space (RFC 8259 §2)
        empty = "the body is empty" + (" (white space only)" if body else "")
        raise ProblemError(400, "malformed_json", f"{empty}; send a JSON document", "body")
    if b"\x00" in body:
        at = body.index(b"\x00")
        detail = (
            f"the body has a NUL byte at offset {at}: it is not UTF-8 (UTF-16 or UTF-32?); "
            "send JSON as UTF-8 (RFC 8259 §8.1)"
        )
        raise ProblemError(400, "body_not_utf8", detail, "body")
    try:
        text = body.decode("utf-8")
    except UnicodeDecodeError as err:
        detail = (
            f"the body is not UTF-8 (byte 0x{body[err.start]:02x} at offset {err.start}); "
            "send JSON as UTF-8 (RFC 8259 §8.1)"
        )
        raise ProblemError(400, "body_not_utf8", detail, "body") from None
    try:
        document = json.loads(text, object_pairs_hook=_no_duplicates)
    except DuplicateKeyError as err:
        detail = f"the key {err.key!r} appears twice in one object; send each key once"
        raise ProblemError(400, "duplicate_key", detail, err.key, err.key) from None
    except json.JSONDecodeError as err:
        detail = f"the body is not valid JSON: {err.msg} (line {err.lineno} column {err.colno})"
        raise ProblemError(400, "malformed_json", detail, "body") from None
    except RecursionError:  # valid, but past the reader's recursion limit
        raise ProblemError(400, "malformed_json", _TOO_DEEP, "body") from None
    except ValueError:  # an integer of over 4300 digits
        raise ProblemError(400, "malformed_json", "the body is not valid JSON", "body") from None
    if _may_nest_deeper(body) and _depth(document) > MAX_DEPTH:
        raise ProblemError(400, "malformed_json", _TOO_DEEP, "body")
    return document


def _may_nest_deeper(body: bytes) -> bool:
    """Whether ``body`` has more than :data:`MAX_DEPTH` opening brackets in all.

    Fewer cannot nest deeper (a bracket inside a string only adds to the count), and a part
    report has about 30: counting them is a tenth of the cost of walking the document.
    """
    return body.count(b"{") + body.count(b"[") > MAX_DEPTH


def _depth(document: Any) -> int:
    """How many levels of objects and arrays ``document`` nests (a scalar: 0)."""
    deepest, stack = 0, [(document, 1)]
    while stack:
        item, level = stack.pop()
        if not isinstance(item, dict | list):
            continue
        deepest = max(deepest, level)
        children = item.values() if isinstance(item, dict) else item
        stack.extend((child, level + 1) for child in children if isinstance(child, dict | list))
    return deepest


class _Read(Request):
    """A request whose body was read and parsed by :func:`loads`."""

    def __init__(self, request: Request, body: bytes, document: Any) -> None:
        super().__init__(request.scope, request.receive)
        self._read, self._document = body, document

    async def body(self) -> bytes:
        """The body's bytes, as read once."""
        return self._read

    async def json(self) -> Any:
        """The body's JSON document, as :func:`loads` read it."""
        return self._document


def _many(annotation: Any) -> bool:
    """Whether a parameter of type ``annotation`` takes several values (``list[str] | None``)."""
    origin = get_origin(annotation)
    if origin in (Union, types.UnionType):
        return any(_many(arg) for arg in get_args(annotation) if arg is not type(None))
    return (origin or annotation) in _MANY


def _integer(annotation: Any) -> bool:
    origin = get_origin(annotation)
    if origin in (Union, types.UnionType):
        return any(_integer(arg) for arg in get_args(annotation))
    return annotation is int


def _params(dependant: Dependant) -> tuple[list[str], list[str], list[str]]:
    """The aliases of the query, single-valued query and integer path parameters.

    Every query parameter in the order declared, and a dependency's too.
    """
    known, single, integers = [], [], []
    for field in dependant.query_params:
        known.append(field.alias)
        if not _many(field.field_info.annotation):
            single.append(field.alias)
    for field in dependant.path_params:
        if _integer(field.field_info.annotation):
            integers.append(field.alias)
    for sub in dependant.dependencies:
        more_known, more_single, more_integers = _params(sub)
        known += [name for name in more_known if name not in known]
        single += more_single
        integers += more_integers
    return known, single, integers


def _unknown_query(request: Request, known: list[str]) -> None:
    """A query parameter the route does not declare: 422 naming it and the known ones."""
    for name in request.query_params:
        if name not in known:
            listed = ", ".join(known) if known else "none"
            given = request.query_params.getlist(name)
            reason = f"unknown query parameter; known: {listed}"
            value = given[0] if len(given) == 1 else given
            raise ProblemError(422, "invalid", f"{name}: {reason}", name, value, reason=reason)


class StrictRoute(APIRoute):
    """An API route that reads its request as the module's docstring says, then as FastAPI does."""

    def get_route_handler(self) -> Callable[[Request], Coroutine[Any, Any, Response]]:
        """FastAPI's handler, after the checks."""
        handler = super().get_route_handler()
        known, single, integers = _params(self.dependant)
        takes_json = self.body_field is not None
        takes_input = bool(known or self.param_convertors or takes_json)

        async def strict(request: Request) -> Response:
            if takes_input:
                _unknown_query(request, known)
            for name in single:
                given = request.query_params.getlist(name)
                if len(given) > 1:
                    detail = (
                        f"the query parameter {name!r} is given {len(given)} times "
                        f"({', '.join(map(repr, given))}); it takes one value"
                    )
                    raise ProblemError(400, "repeated_parameter", detail, name, given)
            for name in integers:
                raw = request.path_params.get(name)
                if isinstance(raw, str) and not _DIGITS.fullmatch(raw):
                    reason = "must be a whole number in digits 0-9"
                    detail = f"{name} = {raw!r}: {reason}"
                    raise ProblemError(422, "invalid", detail, name, raw, reason=reason)
            if takes_json:
                try:
                    body = await request.body()
                except ClientDisconnect:  # or cut by api.rest.limits, whose 413 replaces this
                    raise HTTPException(400, "the body was not received whole") from None
                # an empty body sent as JSON is 400; none at all (no Content-Type either) is
                # FastAPI's 422 of a required body missing
                if body or "content-type" in request.headers:
                    request = _Read(request, body, loads(body))
            return await handler(request)

        return strict
