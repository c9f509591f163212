"""What the routers share: prefix and problems, path and header parameters, a write's answer."""

# no "from __future__ import annotations": FastAPI reads these annotations at run time

from typing import Annotated, Any

from fastapi import APIRouter, Header, Path, Request
from fastapi.responses import Response
from pydantic import AfterValidator

from api.rest.schemas.common import NO_NUL
from api.rest.strict import StrictRoute
from api.services.idempotency import Idempotency, Written, fingerprint
from db.bulk import Encoded
from db.tables import MAX_INT
from models.bounds import MAX_IDENTITY
from models.fields import identity

#: Where the service lives (the web view is at /ui, api.report.ui).
PREFIX = "/api/v1"

#: Largest id (the tables' integer keys are 32-bit on PostgreSQL).
MAX_ID = MAX_INT
#: Idempotency-Key: 1 to 255 visible ASCII characters (an sf-string; the column's width).
KEY_PATTERN = r"^[\x21-\x7e]{1,255}$"
_KEY_DOC = (
    "a client-chosen unique key per request (IETF Idempotency-Key draft); 1-255 visible ASCII"
)

PlanId = Annotated[int, Path(ge=1, le=MAX_ID)]
#: A part's id in a path (``/plans/{plan_id}/parts/{part_id}``).
PartId = Annotated[int, Path(ge=1, le=MAX_ID)]


def _named(value: str | None) -> str | None:
    """A name in a path or a query, compared as a body's is (:func:`models.fields.identity`).

    NFKC, no white space around it; None: not given.
    """
    return None if value is None else identity(value)


#: A name as a path or query parameter gives it: ``/tools/ＣＮＭＧ432RN%20`` is CNMG432RN's.
Named = AfterValidator(_named)
#: A tool's name in a path (``/tools/{name}``).
ToolName = Annotated[str, Path(max_length=MAX_IDENTITY, pattern=NO_NUL), Named]
#: The Idempotency-Key header of a write that may go without one.
OptionalKey = Annotated[str | None, Header(pattern=KEY_PATTERN, description=_KEY_DOC)]
#: The Idempotency-Key header of a write that needs one (a part report).
RequiredKey = Annotated[str, Header(pattern=KEY_PATTERN, description=_KEY_DOC)]

#: ``Location`` of a 201 that created a resource with a path of its own (a plan, a part).
LOCATION: dict[str, Any] = {
    "Location": {
        "description": "The created resource's path (`/api/v1/plans/7`)",
        "schema": {"type": "string"},
    }
}
#: The header a replayed answer carries (documented on the 201 of a write).
REPLAYED: dict[str, Any] = {
    "Idempotent-Replayed": {
        "description": "`true` when this is the stored response of an earlier request",
        "schema": {"type": "string"},
    }
}


def resource_router(tag: str) -> APIRouter:
    """A resource's router: its routes under :data:`PREFIX`, tagged.

    Each route reads its request strictly (:class:`api.rest.strict.StrictRoute`); the problems
    it can answer are declared when the app is built (:func:`api.rest.answers.declare`).
    """
    return APIRouter(prefix=PREFIX, tags=[tag], route_class=StrictRoute)


def idempotency_of(request: Request, key: str | None, body: object) -> Idempotency | None:
    """The request's key and fingerprint, or None without a key."""
    # presence (where required) and form were checked by FastAPI: a 400 (api.rest.problems)
    if key is None:
        return None
    return Idempotency(key, fingerprint("POST", request.url.path, body))


def answer(written: Written, location: str | None = None) -> Response:
    """The HTTP answer of a write, marked ``Idempotent-Replayed`` when it is a stored one.

    ``location``: the created resource's path, sent as ``Location`` with a 201 (RFC 9110
    §15.3.2), a replay's too; a relative reference, never built from the Host header.
    """
    headers = {"Idempotent-Replayed": "true"} if written.replayed else {}
    if location is not None and written.status == 201:
        headers["Location"] = location
    # a new answer's text was encoded once, for the database and for this answer; a replay's
    # is encoded as it was (db.bulk.Encoded): the same bytes as the first answer's
    text = written.text if written.text is not None else Encoded.of(written.body).text
    return Response(text, written.status, headers=headers, media_type="application/json")
