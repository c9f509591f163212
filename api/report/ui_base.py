"""What every page of the web view (:mod:`api.report.ui`) shares: its paths, headers and frame.

The session's cookie and its limits, the security headers every page carries, the page's frame
(style, navigation), the 400 page of a request the view refuses, and the query check: a page
refuses a parameter it does not take, or one given twice, in the REST API's words
(:mod:`api.rest.strict`), never showing another page as if it were the one asked for.
"""

from __future__ import annotations

from fastapi import Request
from fastapi.responses import HTMLResponse
from sqlalchemy import Engine

from api.report.html_parts import document, escaped, tag
from api.services import ui_sessions
from db.api_keys import Actor
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

HEADERS = {
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

NAV_CSS = "nav.ui { font-size: 0.9em; margin-bottom: 1em; } nav.ui form { display: inline; }"


def actor_of(engine: Engine, request: Request) -> Actor | None:
    """The actor of the cookie's session; None without one that holds.

    Not audited: a session ends as shifts do, and its token (256 random bits) is not guessed.
    """
    token = request.cookies.get(COOKIE)
    if not token or len(token) > MAX_TOKEN_CHARS:
        return None
    return ui_sessions.actor_of(engine=engine, token=token)


def query_refused(request: Request, *known: str) -> InputError | None:
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


def html_document(title: str, body: str, status: int) -> HTMLResponse:
    """A page of the view: its style and headers around ``body``."""
    return HTMLResponse(document(title, _CSS, body), status_code=status, headers=HEADERS)


def nav(actor: Actor) -> str:
    """The navigation of a signed-in page: the plans, who is signed in, and signing out."""
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


def page(title: str, content: str, actor: Actor, status: int = 200) -> HTMLResponse:
    """A signed-in page: the navigation, its title and ``content``."""
    return html_document(f"rcb: {title}", nav(actor) + tag("h1", escaped(title)) + content, status)


def bad_request(err: InputError, actor: Actor | None = None) -> HTMLResponse:
    """400: the parameter and its value (as :class:`InputError` words them), and the way back.

    ``actor``: the session's, whose navigation the page has; None on the sign-in pages.
    """
    back = tag("p", tag("a", escaped("Back to the plan list"), href=f"{PREFIX}/"))
    text = tag("p", escaped(str(err)), class_="error", role="alert") + back
    if actor is not None:
        return page("Bad request", text, actor, 400)
    return html_document("rcb: Bad request", tag("h1", escaped("Bad request")) + text, 400)
