"""A read-only web view under ``/ui/``: the plans, and per plan the page of ``rcb report``.

Browsers send no ``Authorization`` header when they navigate, so the API key is entered once in
a form (``/ui/login``), checked, and a session opened (:mod:`api.services.ui_sessions`): the
cookie holds the session's random token, never the key (a copied cookie was the key, for every
route of its role, until 0030). The cookie is HttpOnly (no script can read it), SameSite=Strict
(no other site's page can make the browser send it), ``Path=/ui`` (never sent to ``/api/v1``),
Secure when the request came over HTTPS. Every request finds its actor by the token, so a
revoked key's sessions end at once (and the browser's cookie is cleared), signing out ends the
session on the server, and a session ends after a working shift; a key scoped to plans sees
only those (another plan's page is "no such plan"). Any role may look: mes, engineer and
viewer are all viewer or above.

The pages are self-contained (inline CSS and SVG, no script, nothing loaded from elsewhere); a
Content-Security-Policy says so to the browser as well. Every text from the database is escaped.
The routes are left out of the OpenAPI document.

As the REST API refuses a query parameter its route does not take, so does the view: a page
asked with one (``/ui/?afer=5``), with a parameter given twice, or with a malformed ``cursor``
is a 400 page naming the parameter and its value, never the first page shown as if asked for.
The plan list takes ``cursor`` (its "next page" link), a plan's page none. A page asked for
without a session goes to the sign-in and comes back to it (:mod:`api.report.ui_login`); what
every page shares is :mod:`api.report.ui_base`.
"""

from __future__ import annotations

import re
from typing import Any

from fastapi import FastAPI, Request
from fastapi.responses import HTMLResponse, RedirectResponse, Response
from sqlalchemy import Engine

from api.report import ui_login
from api.report.html import render_record
from api.report.html_parts import escaped, name_html, row, tag, td, th, timestamp_html
from api.report.ui_base import (
    HEADERS,
    NAV_CSS,
    PREFIX,
    actor_of,
    bad_request,
    nav,
    page,
    query_refused,
)
from api.report.ui_login import to_login
from api.services.errors import NotFoundError
from api.services.read import plans as read_plans
from api.services.read import record
from db.api_keys import Actor
from db.tables import MAX_INT
from models.errors import InputError

#: The last parts plotted and listed on a plan page (the totals count every part).
PLOTTED_PARTS = 100


def install(app: FastAPI, engine: Engine) -> None:
    """Add the web view's routes to ``app``, reading the database of ``engine``."""
    ui_login.install(app, engine)
    _install_pages(app, engine)


def _install_pages(app: FastAPI, engine: Engine) -> None:
    """``/ui/``, the plans the key may see, and ``/ui/plans/{id}``, one plan's report."""

    @app.get(PREFIX, include_in_schema=False)
    def root(request: Request) -> Response:
        """``/ui`` to ``/ui/``, by a relative address (the app redirects no slash itself).

        The query goes along, so ``/ui/`` judges it (a page asked for is never dropped).
        """
        query = request.url.query
        to = f"{PREFIX}/?{query}" if query else f"{PREFIX}/"
        return RedirectResponse(to, status_code=307, headers=HEADERS)

    @app.get(f"{PREFIX}/", include_in_schema=False)
    def plans(request: Request) -> Response:
        actor = actor_of(engine, request)  # a session's token: no wrong-key limit to meet
        if actor is None:
            return to_login(request)
        if (refused := query_refused(request, "cursor")) is not None:
            return bad_request(refused, actor)
        cursor = request.query_params.get("cursor")
        try:  # a scoped key's plans are filtered in the query: its page is full
            listed = read_plans.list_plans(engine=engine, cursor=cursor, only=actor.plans)
        except InputError as err:  # a cursor no "next page" link holds
            return bad_request(err, actor)
        return page("Plans", _plans_table(listed["plans"], listed["next_cursor"]), actor)

    @app.get(f"{PREFIX}/plans/{{plan_id}}", include_in_schema=False)
    def plan(request: Request, plan_id: str) -> Response:
        actor = actor_of(engine, request)  # a session's token: no wrong-key limit to meet
        if actor is None:
            return to_login(request)
        if (refused := query_refused(request)) is not None:
            return bad_request(refused, actor)
        number_id = int(plan_id) if re.fullmatch(r"[0-9]{1,10}", plan_id) else 0
        if not 1 <= number_id <= MAX_INT or not actor.may_see(number_id):
            return _not_found(plan_id, actor)
        try:
            data = record.report_record(engine=engine, plan_id=number_id, last=PLOTTED_PARTS)
            report = render_record(data)
        except NotFoundError:
            return _not_found(plan_id, actor)
        # the report page with the view's navigation; it stays well-formed XML
        bar = tag("style", NAV_CSS) + nav(actor)
        report = report.replace("</head><body>", f"</head><body>{bar}", 1)
        return HTMLResponse(report, headers=HEADERS)


#: The most characters of a path's plan id a "not found" page repeats.
SHOWN_ID = 20


def _not_found(plan_id: str, actor: Actor) -> HTMLResponse:
    shown = plan_id if len(plan_id) <= SHOWN_ID else plan_id[:SHOWN_ID] + "…"  # a path's echo
    text = tag("p", escaped(f"There is no plan with id {shown}."))
    return page("Plan not found", text, actor, status=404)


def _plans_table(plans: list[dict[str, Any]], next_cursor: str | None = None) -> str:
    """A page of plans; ``next_cursor``: a "next" link to the page after it."""
    if not plans:
        return tag("p", escaped("No plans yet (rcb plans create, or POST /api/v1/plans)."))
    head = "".join(
        th(h)
        for h in ("ID", "Name", "Machine", "Setpoint version", "Parts", "Created", "Status", "")
    )
    rows = []
    for p in plans:
        link = tag("a", "record, plots", href=f"{PREFIX}/plans/{int(p['id'])}")
        cells = [
            td(p["id"], class_="num"),
            tag("td", name_html(p["name"])),  # folds after a "-" or "_", never mid-piece
            tag("td", name_html(p["machine"])),
            td(p["setpoint_version"], class_="num"),
            td(p["parts"], class_="num"),
            tag("td", timestamp_html(p["created_at"])),  # never "2026-12-" over "04"
            _status_cell(p),
            tag("td", link),
        ]
        rows.append(row(cells, data_plan=p["id"]))
    body = tag("thead", tag("tr", head)) + tag("tbody", "".join(rows))
    more = ""
    if next_cursor is not None:
        link = tag(
            "a", escaped("next page"), href=f"{PREFIX}/?cursor={int(next_cursor)}", rel="next"
        )
        more = tag("p", link)
    return tag("table", body, id="plans") + more


def _status_cell(plan: dict[str, Any]) -> str:
    if plan["status"] == "halted":
        return tag("td", tag("strong", escaped("HALTED")), class_="halted")
    if plan.get("settings_refused"):  # its reports are refused until a replan sets it anew
        # the reason opens under the word (a click, Enter, a touch): a title showed it on
        # hover alone, which no keyboard or touch screen can
        said = tag("summary", tag("strong", escaped("REFUSED")))
        return tag("td", tag("details", said + escaped(plan["settings_refused"])))
    return td("running")
