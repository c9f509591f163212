"""Signing in to the web view (``/ui/login``) and out of it (``/ui/logout``), and back.

The API key is entered once in the form, checked (a wrong one counts towards the client's
limit, :mod:`api.services.throttle`), and a session opened (:mod:`api.services.ui_sessions`);
the cookie holds the session's token, never the key. Both forms must come from this site (its
``Origin``), and take no query parameter but ``next``.

A page asked for without a session (a link to ``/ui/plans/42`` from the MES, a mail, a
bookmark) sends the browser to the form with ``next`` naming it, the form carries it, and the
sign-in goes there; it went to the plan list, and the page asked for was lost. ``next`` is one
of the view's own pages (:data:`NEXT_PAGE`): anything else (another site, ``//host``, an API
path) is a 400 naming it and never followed, so the form cannot be made to send a signed-in
browser elsewhere (an open redirect).
"""

from __future__ import annotations

import re
from functools import partial
from urllib.parse import parse_qs, urlencode, urlsplit

from fastapi import FastAPI, Request
from fastapi.responses import HTMLResponse, RedirectResponse, Response
from sqlalchemy import Engine
from starlette.concurrency import run_in_threadpool

from api.report.html_parts import escaped, tag
from api.report.ui_base import (
    COOKIE,
    COOKIE_MAX_AGE_S,
    HEADERS,
    MAX_FORM_BYTES,
    MAX_TOKEN_CHARS,
    PREFIX,
    ROLES,
    bad_request,
    html_document,
    query_refused,
)
from api.services import auth, ui_sessions
from models.errors import InputError

#: The pages a sign-in may go back to: the plan list (a page of it) and a plan's page.
NEXT_PAGE = re.compile(rf"{PREFIX}/(\?cursor=[0-9]{{1,10}}|plans/[0-9]{{1,10}})?")
#: Where a sign-in goes when no page was asked for.
HOME = f"{PREFIX}/"


def install(app: FastAPI, engine: Engine) -> None:
    """Add ``/ui/login`` (the form and its post) and ``/ui/logout`` to ``app``."""

    @app.get(f"{PREFIX}/login", include_in_schema=False)
    def login_form(request: Request) -> HTMLResponse:
        if (refused := query_refused(request, "next")) is not None:
            return bad_request(refused)
        try:
            back = next_page(request.query_params.get("next"))
        except InputError as err:
            return bad_request(err)
        return login_page(None, 200, back)

    @app.post(f"{PREFIX}/login", include_in_schema=False)
    async def login(request: Request) -> Response:
        if (refused := query_refused(request)) is not None:
            return bad_request(refused)  # before the key is read: nothing is checked
        if not _same_origin(request):
            return login_page("This form must be sent from this site.", 403)
        body = await request.body()
        if len(body) > MAX_FORM_BYTES:
            return login_page("The form is too large.", 413)
        fields = parse_qs(body.decode("utf-8", errors="replace"), max_num_fields=10)
        try:
            back = next_page((fields.get("next") or [""])[0])
        except InputError as err:
            return bad_request(err)  # a form this view never makes: nothing is checked
        key = (fields.get("key") or [""])[0].strip()
        if not key:
            return login_page("Enter an API key.", 401, back)
        return await _signed_in(engine, request, key, back)

    @app.post(f"{PREFIX}/logout", include_in_schema=False)
    def logout(request: Request) -> Response:
        if (refused := query_refused(request)) is not None:
            return bad_request(refused)  # the form sends none; the session is left as it is
        if not _same_origin(request):
            return login_page("This form must be sent from this site.", 403)
        token = request.cookies.get(COOKIE)
        if token and len(token) <= MAX_TOKEN_CHARS:
            ui_sessions.sign_out(engine=engine, token=token)
        return to_login(request, back=False)


async def _signed_in(engine: Engine, request: Request, key: str, back: str) -> Response:
    """Check ``key``, open a session and go to ``back``; the form again if the key is refused."""
    client = request.client.host if request.client else ""
    try:
        opened = await run_in_threadpool(
            partial(
                ui_sessions.sign_in,
                engine=engine,
                key=key,
                action=f"POST {PREFIX}/login",
                client=client,
                roles=ROLES,
                lasts_s=COOKIE_MAX_AGE_S,
            )
        )
    except auth.RateLimitedError as err:
        page = login_page(f"Too many failed keys; try again in {err.retry_after_s} s.", 429, back)
        page.headers["Retry-After"] = str(err.retry_after_s)
        return page
    if opened is None:
        return login_page("Unknown or revoked API key.", 401, back)
    response = RedirectResponse(back, status_code=303, headers=HEADERS)
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


def next_page(value: str | None) -> str:
    """The page a sign-in goes to: ``value`` if it is one of the view's (else InputError)."""
    if not value:
        return HOME
    if len(value) > 64 or not NEXT_PAGE.fullmatch(value):
        reason = f"must be a page of this view: {HOME}, {HOME}?cursor=N or {PREFIX}/plans/N"
        raise InputError("next", value, reason)
    return value


def login_page(message: str | None, status: int, back: str = HOME) -> HTMLResponse:
    """The sign-in form (``message``: why it is shown again); it goes to ``back`` once in."""
    error = tag("p", escaped(message), class_="error", role="alert") if message else ""
    field = tag("label", "API key ", for_="key") + (
        '<input id="key" name="key" type="password" autocomplete="current-password" '
        'required="required" size="50"/>'
    )
    kept = "" if back == HOME else f'<input type="hidden" name="next" value="{escaped(back)}"/>'
    form = tag(
        "form",
        tag("p", field) + kept + tag("p", tag("button", "Log in", type="submit")),
        method="post",
        action=f"{PREFIX}/login",
    )
    hint = tag("p", escaped("A key of any role (from rcb keys create) shows the plans; read only."))
    title = "rcb: log in"
    return html_document(title, tag("h1", escaped(title)) + error + form + hint, status)


def to_login(request: Request, back: bool = True) -> RedirectResponse:
    """To the sign-in form, deleting a cookie sent (a session ended, or its key revoked).

    The browser then stops sending it. ``back``: the form is to come back to the page asked
    for, when it is one a sign-in may go to (:data:`NEXT_PAGE`; with a query the page refuses,
    to the plan list, as the page itself would not be shown).
    """
    asked = request.url.path + (f"?{request.url.query}" if request.url.query else "")
    keep = back and asked != HOME and NEXT_PAGE.fullmatch(asked) is not None
    target = f"{PREFIX}/login" + (f"?{urlencode({'next': asked})}" if keep else "")
    response = RedirectResponse(target, status_code=303, headers=HEADERS)
    if COOKIE in request.cookies:
        response.delete_cookie(
            COOKIE,
            path=PREFIX,
            secure=request.url.scheme == "https",
            httponly=True,
            samesite="strict",
        )
    return response


def _same_origin(request: Request) -> bool:
    """Whether a form post came from this site (an absent Origin header, as curl sends, is)."""
    origin = request.headers.get("origin")
    if origin is None:
        return True
    return urlsplit(origin).netloc == request.headers.get("host", "")
