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
The plan list takes ``cursor`` (its "next page" link); every other page takes none (the login
form's key comes in the body). A page that needs a session redirects to the sign-in first.
"""

from __future__ import annotations

import re
from functools import partial
from typing import Any
from urllib.parse import parse_qs, urlsplit

from fastapi import FastAPI, Request
from fastapi.responses import HTMLResponse, RedirectResponse, Response
from sqlalchemy import Engine
from starlette.concurrency import run_in_threadpool

from api.report.html import render_record
from api.report.html_parts import document, escaped, name_html, row, tag, td, th, timestamp
from api.services import auth, ui_sessions
from api.services.errors import NotFoundError
from api.services.read import plans as read_plans
from api.services.read import record
from db.api_keys import Actor
from db.tables import MAX_INT
from models.errors import InputError

PREFIX = "/ui"
COOKIE = "rcb_ui_key"
#: Roles that may look: every role is viewer or above.
ROLES = ("mes", "engineer", "viewer")
#: How long the login cookie lives [s] (a working shift).
COOKIE_MAX_AGE_S = 8 * 3600
#: Longest cookie read as a session's token (one is 49 characters).
MAX_TOKEN_CHARS = 128
#: Largest login form body [bytes]; a key is 47 characters.
MAX_FORM_BYTES = 4096
#: The last parts plotted and listed on a plan page (the totals count every part).
PLOTTED_PARTS = 100

_HEADERS = {
    "Cache-Control": "no-store",
    "Content-Security-Policy": (
        "default-src 'none'; style-src 'unsafe-inline'; img-src data:; "
        "form-action 'self'; frame-ancestors 'none'; base-uri 'none'"
    ),
    "X-Content-Type-Options": "nosniff",
    # not no-referrer: Chromium would then send "Origin: null" with the login form
    "Referrer-Policy": "same-origin",
}

_CSS = """
body { font: 14px/1.4 system-ui, -apple-system, "Segoe UI", Roboto, Arial, sans-serif;
       color: #222; margin: 2em auto; max-width: 60em; padding: 0 1em; }
table { border-collapse: collapse; margin: 0.5em 0 1em; font-size: 0.9em; }
th, td { border: 1px solid #ccc; padding: 0.2em 0.5em; }
th { background: #f3f3f3; text-align: left; } td.num { text-align: right; }
p.error, td.halted { color: #b00; } nav form { display: inline; }
/* a long plan name folds after a "-" or "_" between its pieces, never inside one */
.nw { white-space: nowrap; } .brk { white-space: normal; }
"""

_NAV_CSS = "nav.ui { font-size: 0.9em; margin-bottom: 1em; } nav.ui form { display: inline; }"


def install(app: FastAPI, engine: Engine) -> None:
    """Add the web view's routes to ``app``, reading the database of ``engine``."""
    _install_login(app, engine)
    _install_logout(app, engine)
    _install_pages(app, engine)


def _actor_of(engine: Engine, request: Request) -> Actor | None:
    """The actor of the cookie's session; None without one that holds.

    Not audited: a session ends as shifts do, and its token (256 random bits) is not guessed.
    """
    token = request.cookies.get(COOKIE)
    if not token or len(token) > MAX_TOKEN_CHARS:
        return None
    return ui_sessions.actor_of(engine=engine, token=token)


def _install_login(app: FastAPI, engine: Engine) -> None:
    """``/ui/login``: the form, and its post that checks the key and sets the cookie."""

    @app.get(f"{PREFIX}/login", include_in_schema=False)
    def login_form(request: Request) -> HTMLResponse:
        refused = _query_refused(request)
        return _login_page(None, 200) if refused is None else _bad_request(refused)

    @app.post(f"{PREFIX}/login", include_in_schema=False)
    async def login(request: Request) -> Response:
        if (refused := _query_refused(request)) is not None:
            return _bad_request(refused)  # before the key is read: nothing is checked
        if not _same_origin(request):
            return _login_page("This form must be sent from this site.", 403)
        body = await request.body()
        if len(body) > MAX_FORM_BYTES:
            return _login_page("The form is too large.", 413)
        fields = parse_qs(body.decode("utf-8", errors="replace"), max_num_fields=10)
        key = (fields.get("key") or [""])[0].strip()
        if not key:
            return _login_page("Enter an API key.", 401)
        action = f"POST {PREFIX}/login"
        client = request.client.host if request.client else ""
        try:
            opened = await run_in_threadpool(
                partial(
                    ui_sessions.sign_in,
                    engine=engine,
                    key=key,
                    action=action,
                    client=client,
                    roles=ROLES,
                    lasts_s=COOKIE_MAX_AGE_S,
                )
            )
        except auth.RateLimitedError as err:
            return _too_many(err)
        if opened is None:
            return _login_page("Unknown or revoked API key.", 401)
        response = RedirectResponse(f"{PREFIX}/", status_code=303, headers=_HEADERS)
        response.set_cookie(
            COOKIE,
            opened[0],
            max_age=COOKIE_MAX_AGE_S,
            path=PREFIX,
            secure=request.url.scheme == "https",
            httponly=True,
            samesite="strict",
        )
        return response


def _install_logout(app: FastAPI, engine: Engine) -> None:
    """``/ui/logout``: a post that ends the session on the server and deletes the cookie."""

    @app.post(f"{PREFIX}/logout", include_in_schema=False)
    def logout(request: Request) -> Response:
        if (refused := _query_refused(request)) is not None:
            return _bad_request(refused)  # the form sends none; the session is left as it is
        if not _same_origin(request):
            return _login_page("This form must be sent from this site.", 403)
        token = request.cookies.get(COOKIE)
        if token and len(token) <= MAX_TOKEN_CHARS:
            ui_sessions.sign_out(engine=engine, token=token)
        return _to_login(request)


def _install_pages(app: FastAPI, engine: Engine) -> None:
    """``/ui/``, the plans the key may see, and ``/ui/plans/{id}``, one plan's report."""

    @app.get(PREFIX, include_in_schema=False)
    def root(request: Request) -> Response:
        """``/ui`` to ``/ui/``, by a relative address (the app redirects no slash itself).

        The query goes along, so ``/ui/`` judges it (a page asked for is never dropped).
        """
        query = request.url.query
        to = f"{PREFIX}/?{query}" if query else f"{PREFIX}/"
        return RedirectResponse(to, status_code=307, headers=_HEADERS)

    @app.get(f"{PREFIX}/", include_in_schema=False)
    def plans(request: Request) -> Response:
        actor = _actor_of(engine, request)  # a session's token: no wrong-key limit to meet
        if actor is None:
            return _to_login(request)
        if (refused := _query_refused(request, "cursor")) is not None:
            return _bad_request(refused, actor)
        cursor = request.query_params.get("cursor")
        try:  # a scoped key's plans are filtered in the query: its page is full
            listed = read_plans.list_plans(engine=engine, cursor=cursor, only=actor.plans)
        except InputError as err:  # a cursor no "next page" link holds
            return _bad_request(err, actor)
        return _page("Plans", _plans_table(listed["plans"], listed["next_cursor"]), actor)

    @app.get(f"{PREFIX}/plans/{{plan_id}}", include_in_schema=False)
    def plan(request: Request, plan_id: str) -> Response:
        actor = _actor_of(engine, request)  # a session's token: no wrong-key limit to meet
        if actor is None:
            return _to_login(request)
        if (refused := _query_refused(request)) is not None:
            return _bad_request(refused, actor)
        number_id = int(plan_id) if re.fullmatch(r"[0-9]{1,10}", plan_id) else 0
        if not 1 <= number_id <= MAX_INT or not actor.may_see(number_id):
            return _not_found(plan_id, actor)
        try:
            data = record.report_record(engine=engine, plan_id=number_id, last=PLOTTED_PARTS)
            page = render_record(data)
        except NotFoundError:
            return _not_found(plan_id, actor)
        # the report page with the view's navigation; it stays well-formed XML
        nav = tag("style", _NAV_CSS) + _nav(actor)
        page = page.replace("</head><body>", f"</head><body>{nav}", 1)
        return HTMLResponse(page, headers=_HEADERS)


def _query_refused(request: Request, *known: str) -> InputError | None:
    """Why the page refuses the request's query (``known``: the parameters it takes), or None.

    A parameter it does not take, or one it takes given twice (which of the two was meant?),
    in the REST API's words (:mod:`api.rest.strict`): ``afer = '5': unknown query parameter``.
    """
    listed = ", ".join(known) if known else "none"
    for name in request.query_params:
        given = request.query_params.getlist(name)
        if name not in known:
            reason = f"unknown query parameter; this page takes {listed}"
            return InputError(name, given[0] if len(given) == 1 else given, reason)
        if len(given) > 1:
            return InputError(name, given, f"given {len(given)} times; it takes one value")
    return None


def _same_origin(request: Request) -> bool:
    """Whether a form post came from this site (an absent Origin header, as curl sends, is)."""
    origin = request.headers.get("origin")
    if origin is None:
        return True
    return urlsplit(origin).netloc == request.headers.get("host", "")


# --------------------------------------------------------------------------------------------
# HTML


def _document(title: str, body: str, status: int) -> HTMLResponse:
    return HTMLResponse(document(title, _CSS, body), status_code=status, headers=_HEADERS)


def _nav(actor: Actor) -> str:
    logout = tag(
        "form",
        tag("button", "Log out", type="submit"),
        method="post",
        action=f"{PREFIX}/logout",
    )
    links = tag("a", "Plans", href=f"{PREFIX}/")
    return tag(
        "nav",
        f"{links} · {escaped(f'signed in as {actor.name} ({actor.role})')} {logout}",
        class_="ui",
    )


def _page(title: str, content: str, actor: Actor, status: int = 200) -> HTMLResponse:
    return _document(f"rcb: {title}", _nav(actor) + tag("h1", escaped(title)) + content, status)


def _bad_request(err: InputError, actor: Actor | None = None) -> HTMLResponse:
    """400: the parameter and its value (as :class:`InputError` words them), and the way back.

    ``actor``: the session's, whose navigation the page has; None on the sign-in pages.
    """
    back = tag("p", tag("a", escaped("Back to the plan list"), href=f"{PREFIX}/"))
    text = tag("p", escaped(str(err)), class_="error", role="alert") + back
    if actor is not None:
        return _page("Bad request", text, actor, 400)
    return _document("rcb: Bad request", tag("h1", escaped("Bad request")) + text, 400)


def _login_page(message: str | None, status: int) -> HTMLResponse:
    error = tag("p", escaped(message), class_="error", role="alert") if message else ""
    field = tag("label", "API key ", for_="key") + (
        '<input id="key" name="key" type="password" autocomplete="current-password" '
        'required="required" size="50"/>'
    )
    form = tag(
        "form",
        tag("p", field) + tag("p", tag("button", "Log in", type="submit")),
        method="post",
        action=f"{PREFIX}/login",
    )
    hint = tag("p", escaped("A key of any role (from rcb keys create) shows the plans; read only."))
    title = "rcb: log in"
    return _document(title, tag("h1", escaped(title)) + error + form + hint, status)


def _too_many(err: auth.RateLimitedError) -> HTMLResponse:
    """429 with Retry-After: the client address failed to log in too often."""
    page = _login_page(f"Too many failed keys; try again in {err.retry_after_s} s.", 429)
    page.headers["Retry-After"] = str(err.retry_after_s)
    return page


def _to_login(request: Request) -> RedirectResponse:
    """To the sign-in form, deleting a cookie sent (a session ended, or its key revoked).

    The browser then stops sending it.
    """
    response = RedirectResponse(f"{PREFIX}/login", status_code=303, headers=_HEADERS)
    if COOKIE in request.cookies:
        response.delete_cookie(
            COOKIE,
            path=PREFIX,
            secure=request.url.scheme == "https",
            httponly=True,
            samesite="strict",
        )
    return response


#: The most characters of a path's plan id a "not found" page repeats.
SHOWN_ID = 20


def _not_found(plan_id: str, actor: Actor) -> HTMLResponse:
    shown = plan_id if len(plan_id) <= SHOWN_ID else plan_id[:SHOWN_ID] + "…"  # a path's echo
    text = tag("p", escaped(f"There is no plan with id {shown}."))
    return _page("Plan not found", text, actor, status=404)


def _plans_table(plans: list[dict[str, Any]], next_cursor: str | None = None) -> str:
    """A page of plans; ``next_cursor``: a "next" link to the page after it."""
    if not plans:
        return tag("p", escaped("No plans yet (rcb plan create, or POST /api/v1/plans)."))
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
            td(timestamp(p["created_at"])),
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
        return tag("td", tag("strong", escaped("REFUSED")), title=plan["settings_refused"])
    return td("running")
