"""RFC 9457 problem details: every error the REST service returns, as ``application/problem+json``.

Each problem carries a machine-readable ``code`` and, where one is to blame, the offending
``field`` (a dotted path like ``operations[0].measurements.force_N.value``) and its ``value``.
An error body never echoes more than :data:`MAX_ECHO` characters of an offending value (issue
17), and a value that is no valid Unicode (a lone surrogate) is echoed escaped, never sent raw.
"""

from __future__ import annotations

import json
import logging
import math
from collections.abc import Awaitable, Callable
from typing import Any

from fastapi import FastAPI, Request
from fastapi.exceptions import RequestValidationError
from fastapi.responses import JSONResponse
from sqlalchemy.exc import OperationalError
from sqlalchemy.exc import TimeoutError as PoolTimeoutError
from starlette.exceptions import HTTPException as StarletteHTTPException

from api.rest import no_route
from api.rest.refused_audit import audit_refused
from api.rest.schemas.common import field_path, plain_message
from api.rest.unavailable import RETRY_AFTER_S, reason, unavailable
from api.services.errors import NotFoundError, PlanHaltedError
from api.services.idempotency import InFlightError, KeyReuseError
from db.errors import ConflictError
from db.plan_state import halt_json
from models.errors import InputError, InputErrors
from models.fields import escaped
from supervisor.errors import InfeasibleError, SolverError
from supervisor.rcb.state import Halt, HaltedOperation

MEDIA_TYPE = "application/problem+json"
#: The most characters of an offending value (or of a field path) an error body echoes.
MAX_ECHO = 200
#: The most entries of a validation error's ``errors`` list.
MAX_ERRORS = 20
KEY_HEADER = "Idempotency-Key"
_TYPE_BASE = "urn:rcb-supervisor:problem:"
_log = logging.getLogger("rcb.api")


class ProblemError(Exception):
    """An error the REST layer itself raises (authentication, a missing header).

    ``reason``: what ``errors[].message`` of an ``invalid`` one says, the reason alone as an
    input's (the field and value are its own members); the whole ``detail`` if not given.
    """

    def __init__(
        self,
        status: int,
        code: str,
        detail: str,
        field: str | None = None,
        value: object = None,
        headers: dict[str, str] | None = None,
        reason: str | None = None,
    ) -> None:
        self.status, self.code, self.detail = status, code, detail
        self.field, self.value, self.headers = field, value, headers
        self.reason = detail if reason is None else reason
        super().__init__(detail)


_TITLES = {
    400: "Bad request",
    401: "Unauthorized",
    403: "Forbidden",
    404: "Not found",
    405: "Method not allowed",
    409: "Conflict",
    413: "Content too large",
    415: "Unsupported media type",
    422: "Unprocessable content",
    429: "Too many requests",
    500: "Internal server error",
    503: "Service unavailable",
}


def problem(
    request: Request,
    status: int,
    code: str,
    detail: str,
    field: str | None = None,
    value: object = None,
    errors: list[dict[str, Any]] | None = None,
    headers: dict[str, str] | None = None,
    conflicts: list[dict[str, Any]] | None = None,
    extensions: dict[str, Any] | None = None,
) -> JSONResponse:
    """A problem+json response (``conflicts``: a halted plan's, an RFC 9457 extension member).

    ``extensions``: further extension members (``plan_id``: the plan that has a name taken).
    """
    body: dict[str, Any] = {
        "type": _TYPE_BASE + code,
        "title": _TITLES.get(status, "Error"),
        "status": status,
        "detail": _detail(detail, value, field),
        "instance": clip(request.url.path),  # a path of a long name is not echoed whole
        "code": code,
        "field": None if field is None else clip(field),
        "value": echo(value),
    }
    if errors is not None:
        body["errors"] = errors[:MAX_ERRORS]
    if conflicts is not None:
        body["conflicts"] = conflicts
    body.update(extensions or {})
    return JSONResponse(escaped(body), status_code=status, media_type=MEDIA_TYPE, headers=headers)


def clip(text: str, limit: int = MAX_ECHO) -> str:
    """``text`` cut to ``limit`` characters, the last one ``…`` when it was cut."""
    return text if len(text) <= limit else text[: limit - 1] + "…"


def echo(value: object) -> Any:
    """An offending value as an error body shows it: JSON, at most :data:`MAX_ECHO` characters.

    A string or number is echoed as itself (a long string cut); anything else as itself when
    its JSON is short, else as the start of its JSON text; a NaN or infinity as its name.
    """
    if isinstance(value, float) and not math.isfinite(value):
        return str(value)
    if isinstance(value, str):
        return clip(value)
    if value is None or isinstance(value, bool | float):
        return value
    try:
        text = str(value) if isinstance(value, int) else json.dumps(value, allow_nan=False)
    except (TypeError, ValueError):  # not JSON, or an int of more digits than str() allows
        return clip(repr(value)) if not isinstance(value, int) else "(a number too long to echo)"
    return value if len(text) <= MAX_ECHO else clip(text)


def _detail(detail: str, value: object, field: str | None) -> str:
    """``detail`` with long echoes cut: of ``value`` (a ``{value!r}``), of ``field`` (a key)."""
    if field is not None and len(field) > MAX_ECHO:
        detail = detail.replace(field, clip(field))
    if value is None or isinstance(value, bool):
        return detail
    try:
        shown = repr(value)
    except (ValueError, RecursionError):  # an int of more digits than repr allows
        return clip(detail, 2 * MAX_ECHO)
    if len(shown) > MAX_ECHO and shown in detail:
        detail = detail.replace(shown, clip(shown))
    return detail


async def _problem(request: Request, err: ProblemError) -> JSONResponse:
    """``err`` as raised; an ``invalid`` one with its ``errors`` list, as every 422 has."""
    errors = None
    if err.code == "invalid":
        errors = [
            {"field": clip(err.field or "body"), "message": err.reason, "value": echo(err.value)}
        ]
    return problem(
        request,
        err.status,
        err.code,
        err.detail,
        err.field,
        err.value,
        errors=errors,
        headers=err.headers,
    )


async def _input(request: Request, err: InputError) -> JSONResponse:
    """422 naming the field; ``errors``: every one (a plan's reader gathers several)."""
    every = err.errors if isinstance(err, InputErrors) else (err,)
    errors = [
        {"field": clip(e.field or "body"), "message": e.reason, "value": echo(e.value)}
        for e in every[:MAX_ERRORS]
    ]
    detail = str(err) if len(every) == 1 else f"{len(every)} errors; the first: {every[0]}"
    field = err.field or "body"  # a key "" of the body (field_path's name for the whole body)
    return problem(request, 422, "invalid", detail, field, err.value, errors=errors)


async def _infeasible(request: Request, err: InfeasibleError) -> JSONResponse:
    field = f"operations.{err.operation}.limits"
    return problem(
        request, 422, "infeasible", str(err), field, err.operation, conflicts=conflicts_of(err)
    )


async def _solver(request: Request, err: SolverError) -> JSONResponse:
    _log.error("solver failure: %s", err)
    return problem(request, 500, "solver", str(err))


async def _not_found(request: Request, err: NotFoundError) -> JSONResponse:
    return problem(request, 404, "not_found", str(err), err.field, err.value)


async def _conflict(request: Request, err: ConflictError) -> JSONResponse:
    # plan_name_taken names the stored plan of that name too, a serial taken its part
    extra = err.extensions()
    return problem(request, 409, err.code, str(err), err.field, err.value, extensions=extra)


async def _halted(request: Request, err: PlanHaltedError) -> JSONResponse:
    return problem(
        request, 409, "plan_halted", str(err), err.field, err.value, conflicts=err.conflicts
    )


async def _in_flight(request: Request, err: InFlightError) -> JSONResponse:
    return problem(request, 409, "in_flight", str(err), err.field, err.value)


async def _reuse(request: Request, err: KeyReuseError) -> JSONResponse:
    return problem(request, 422, "idempotency_key_reused", str(err), err.field, err.value)


async def _validation(request: Request, err: RequestValidationError) -> JSONResponse:
    answer = _invalid(request, err)
    said = json.loads(bytes(answer.body))  # a write's refusal is audited (refused_audit)
    await audit_refused(request, said["code"], said.get("field"), said["detail"])
    return answer


def _invalid(request: Request, err: RequestValidationError) -> JSONResponse:
    """The 400 or 422 of a request its route's schema refused, in the service's words."""
    body = getattr(request.scope.get("route"), "body_field", None)
    model = None if body is None else body.field_info.annotation
    errors = [
        {
            "field": clip(field_path(e.get("loc", ()))),
            "message": plain_message(e, model),
            # a missing field's "input" is the object it is missing from: no value to echo
            "value": None if e.get("type") == "missing" else echo(e.get("input")),
        }
        for e in err.errors()[:MAX_ERRORS]
    ]
    first = errors[0] if errors else {"field": "body", "message": "invalid", "value": None}
    if any(e.get("type") == "json_invalid" for e in err.errors()):
        return problem(request, 400, "malformed_json", "the body is not valid JSON", "body")
    for e in err.errors():  # the Idempotency-Key header: 400, as the IETF draft asks
        loc = [str(part).lower() for part in e.get("loc", ())]
        if loc[:2] == ["header", "idempotency-key"]:
            if e.get("type") == "missing":
                detail = "this POST needs an Idempotency-Key header"
                return problem(request, 400, "idempotency_key_missing", detail, KEY_HEADER)
            detail = "Idempotency-Key must be 1 to 255 visible ASCII characters"
            value = e.get("input")
            return problem(request, 400, "idempotency_key_invalid", detail, KEY_HEADER, value)
    missing = bool(err.errors()) and err.errors()[0].get("type") == "missing"
    named = first["field"] if missing else f"{first['field']} = {first['value']!r}"
    detail = f"{named}: {first['message']}"
    return problem(request, 422, "invalid", detail, first["field"], first["value"], errors=errors)


async def _http(request: Request, err: StarletteHTTPException) -> JSONResponse:
    code = {404: "not_found", 405: "method_not_allowed"}.get(err.status_code, "http_error")
    headers = getattr(err, "headers", None)
    detail, field, value = str(err.detail), None, None
    if err.status_code == 400:
        field = "body"  # a body FastAPI could not read
    elif err.status_code == 404:  # no route has the path (a missing resource: NotFoundError)
        detail = no_route.not_found(request, clip(request.url.path))
        field, value = "path", request.url.path
    elif err.status_code == 405:
        headers = {**(headers or {}), "Allow": no_route.allowed(request)}
        detail = no_route.not_allowed(request, clip(request.url.path))
        field, value = "method", request.method
    return problem(request, err.status_code, code, detail, field, value, headers=headers)


async def _database(request: Request, err: Exception) -> JSONResponse:
    if not unavailable(err):
        return await unexpected(request, err)
    _log.warning("503 on %s %s: %s", request.method, request.url.path, err)
    detail = f"{reason(err)}{_nothing_stored(request)}; retry later"
    headers = {"Retry-After": str(RETRY_AFTER_S)}
    return problem(request, 503, "database_busy", detail, headers=headers)


async def unexpected(request: Request, err: Exception) -> JSONResponse:
    """The 500 of an error no other handler takes, its traceback logged.

    :class:`api.rest.unexpected.UnexpectedAsProblem` sends it, the connection kept open.
    """
    _log.exception("unexpected error on %s %s", request.method, request.url.path)
    return problem(request, 500, "internal", f"internal error{_nothing_stored(request)}")


def _nothing_stored(request: Request) -> str:
    """``; nothing was stored`` where the request could have stored something (not a read)."""
    return "" if request.method in ("GET", "HEAD", "OPTIONS") else "; nothing was stored"


#: Each error class and its handler, in the order :func:`install` registers them.
_HANDLERS: tuple[tuple[type[Exception], Callable[..., Awaitable[JSONResponse]]], ...] = (
    (ProblemError, _problem),
    (InputError, _input),
    (InfeasibleError, _infeasible),
    (SolverError, _solver),
    (NotFoundError, _not_found),
    (ConflictError, _conflict),
    (PlanHaltedError, _halted),
    (InFlightError, _in_flight),
    (KeyReuseError, _reuse),
    (RequestValidationError, _validation),
    (StarletteHTTPException, _http),
    (OperationalError, _database),
    (PoolTimeoutError, _database),
    (Exception, unexpected),
)


def install(app: FastAPI) -> None:
    """Register the handlers that turn every error into problem+json, and document them so."""
    _document(app)
    for error, handler in _HANDLERS:
        app.exception_handler(error)(handler)


def conflicts_of(err: InfeasibleError) -> list[dict[str, Any]]:
    """The limits in conflict as a halted plan's ``conflicts`` and ``rcb optimize --json``."""
    halted = HaltedOperation(err.operation, err.conflicts, err.against, str(err))
    conflicts: list[dict[str, Any]] = halt_json(Halt((halted,)))["conflicts"]
    return conflicts


def _document(app: FastAPI) -> None:
    """Document error responses as what the handlers send: ``application/problem+json``.

    A ``responses`` entry with a ``model`` puts the model's schema under ``application/json``,
    which no error is sent as, and leaves the ``application/problem+json`` entry without a
    schema; this moves the schema to the problem media type.
    """
    generate = app.openapi

    def openapi() -> dict[str, Any]:
        document = generate()
        for item in document.get("paths", {}).values():
            for operation in item.values():
                if not isinstance(operation, dict):
                    continue
                for response in operation.get("responses", {}).values():
                    content = response.get("content", {})
                    if MEDIA_TYPE in content and "schema" not in content[MEDIA_TYPE]:
                        if "schema" in content.get("application/json", {}):
                            content[MEDIA_TYPE] = content.pop("application/json")
        return document

    app.openapi = openapi  # type: ignore[method-assign]
