"""What the read use cases share: a read session, page bounds, cursors, UTC times, a plan.

A list's cursor is opaque (:func:`_token`): the ``next_cursor`` of the previous page, null on
the last page; a page of plans pages by id (:func:`_cursor`). A list that pages either way
through time (parts, setpoint versions) has cursors that say which way
(:func:`ordered_cursor`): an id or version (``"41"``) pages forward from the oldest, ``"n41"``
back from the newest (the REST ``order=newest``); one of the other order is refused, naming the
order it continues, so that a client mixing them does not get rows it has already seen, or
skip some, without a word.
"""

from __future__ import annotations

import base64
import binascii
import json
import re
from typing import Any

from sqlalchemy import Engine, select
from sqlalchemy.orm import Session

from api.services import request_limits
from api.services.errors import NotFoundError
from db import tables as t
from db.engine import reader
from db.plans import get_plan_row, plan_id_by_name
from models.bounds import MAX_IDENTITY
from models.errors import InputError
from models.fields import identity, storable

#: Most parts (or setpoint versions) one page may hold.
MAX_PAGE = request_limits.READ_PAGE
#: Plans, tools or model versions on a page unless asked otherwise.
LIST_PAGE = 100
#: Longest cursor of a list keyed by text (a tool's name is at most 200 characters).
MAX_CURSOR = 1200
#: A PLAN argument of only these characters is a plan's id; any other, its name.
PLAN_ID = re.compile(r"[0-9]+")
#: What starts a cursor that pages back from the newest (``next_cursor`` of ``order=newest``).
NEWEST = "n"
_ORDERED = re.compile(rf"({NEWEST})?([0-9]{{1,10}})")


def resolve_plan(*, engine: Engine, plan: str) -> int:
    """The id of the plan that ``plan`` names: its id (digits), else its name.

    Names are unique (:class:`db.errors.PlanNameTakenError`) and compared as they are stored
    (:func:`models.fields.identity`, as REST reads a name: NFKC, no white space around it), so
    ``' virtual-lathe-part '`` and full-width ``ｖｉｒｔｕａｌ-lathe-part`` name
    ``virtual-lathe-part``. An id is checked against the range the database holds (the use
    case that reads the plan says so when there is none); a name no plan could have (longer
    than any, or with a control or invisible character) is refused before the database is asked.
    """
    text = plan.strip()
    if PLAN_ID.fullmatch(text):
        if not 1 <= int(text) <= t.MAX_INT:
            raise InputError("PLAN", plan, f"a plan's id is 1 to {t.MAX_INT}")
        return int(text)
    if len(text) > MAX_IDENTITY:  # as REST's Name: the length as given, then normalised
        raise InputError("PLAN", plan, f"a plan's name is at most {MAX_IDENTITY} characters")
    try:
        name = identity(plan)
    except ValueError as err:
        raise InputError("PLAN", plan, f"a plan's name {err}") from None
    with Session(engine) as session:
        plan_id = plan_id_by_name(session=session, name=name)
    if plan_id is None:
        raise InputError("PLAN", plan, f"no plan named {plan!r} (rcb plans lists them)")
    return plan_id


def resolve_audited_plan(*, engine: Engine, plan: str) -> int:
    """As :func:`resolve_plan`, but an id must be a stored plan's or one the audit log is about.

    For ``rcb audit --plan``: an id never stored is refused as an unknown name is (it answered
    an empty page). One the audit log is about is kept though no plan has it: no command
    deletes a plan today, but the log's ``plan_id`` is no foreign key, and its entries are
    what someone asking after a plan gone from a restored or pruned database wants.
    """
    plan_id = resolve_plan(engine=engine, plan=plan)
    with Session(engine) as session:
        if get_plan_row(session=session, plan_id=plan_id) is not None:
            return plan_id
        about = select(t.AuditEntry.id).where(t.AuditEntry.plan_id == plan_id).limit(1)
        if session.scalars(about).first() is not None:
            return plan_id
    raise InputError("PLAN", plan, f"no plan with id {plan_id} (rcb plans lists them)")


def _read(engine: Engine) -> Session:
    # rows are read after the transaction ends: keep their loaded attributes
    return Session(reader(engine), expire_on_commit=False)


def _cursor(cursor: str | None) -> int:
    if cursor is None:
        return 0
    if re.fullmatch(r"[0-9]{1,10}", cursor) is None or int(cursor) > t.MAX_INT:
        raise InputError("cursor", cursor, "not a cursor returned by this endpoint")
    return int(cursor)


def ordered_cursor(edge: int, *, newest: bool) -> str:
    """The cursor that continues after ``edge`` (an id or version) in its order."""
    return f"{NEWEST}{edge}" if newest else str(edge)


def ordered_value(cursor: str | None, *, newest: bool) -> int:
    """The id or version a cursor of :func:`ordered_cursor` continues from (0: none).

    InputError naming ``cursor`` for a text no page of this order handed out (module docstring).
    """
    if cursor is None:
        return 0
    found = _ORDERED.fullmatch(cursor)
    if found is None or int(found[2]) > t.MAX_INT:
        raise InputError("cursor", cursor, "not a cursor returned by this endpoint")
    made_in = "newest" if found[1] else "oldest"
    if (made_in == "newest") != newest:
        raise InputError(
            "cursor",
            cursor,
            f"continues order={made_in}: send it with order={made_in}, or start the other "
            "order without a cursor",
        )
    return int(found[2])


def _plan(session: Session, plan_id: int) -> t.Plan:
    row = get_plan_row(session=session, plan_id=plan_id)
    if row is None:
        raise NotFoundError("plan_id", plan_id)
    return row


def _bounded(page_size: int) -> None:
    if not 1 <= page_size <= MAX_PAGE:
        raise InputError("limit", page_size, f"must be between 1 and {MAX_PAGE}")


def _token(values: list[Any]) -> str:
    """An opaque cursor: the values as JSON, base64url without padding."""
    text = json.dumps(values, separators=(",", ":"), ensure_ascii=False)
    return base64.urlsafe_b64encode(text.encode("utf-8")).decode("ascii").rstrip("=")


def _untoken(cursor: str, size: int) -> list[Any]:
    """The values of a cursor of :func:`_token` (``size`` of them); else InputError on cursor."""
    refused = InputError("cursor", cursor, "not a cursor returned by this endpoint")
    if len(cursor) > MAX_CURSOR:
        raise refused
    try:
        raw = base64.urlsafe_b64decode(cursor + "=" * (-len(cursor) % 4))
        values = json.loads(raw.decode("utf-8"))
    except (binascii.Error, ValueError, RecursionError):  # and the Unicode, JSON errors
        raise refused from None
    kinds = {3: (int, int, str), 2: (str, str)}.get(size, (str,))
    if not isinstance(values, list) or len(values) != size:
        raise refused
    if not all(
        isinstance(v, k) and not isinstance(v, bool) for v, k in zip(values, kinds, strict=True)
    ):
        raise refused
    if size == 3 and not (0 <= values[0] <= t.MAX_INT and 0 <= values[1] <= t.MAX_INT):
        raise refused
    try:  # "\ud800" or a NUL: text no database holds (models.fields.storable's rule)
        for value in values:
            if isinstance(value, str):
                storable(value)
    except ValueError:
        raise refused from None
    return values
