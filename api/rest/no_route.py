"""A request no route takes, said as what was asked: the path, the method, what exists instead.

Starlette's router answers ``Not Found`` and ``Method Not Allowed`` and nothing more; an MES
integrator who typed ``/api/v1/plans/`` or ``/plans/1/part`` learns from it neither which
request was refused nor what to send. Here (:func:`api.rest.problems` words the problem):

- 404 names the path, ``field`` ``path``: ``no such path: /api/v1/plans/``, and where the path
  with (or without) a trailing slash exists, ``did you mean /api/v1/plans?`` (paths are exact:
  no redirect, :func:`api.rest.app.create_app`);
- 405 names the method and the path, ``field`` ``method``, and the methods the path takes, as
  its ``Allow`` header does (RFC 9110 §15.5.6).
"""

from __future__ import annotations

from starlette.requests import Request
from starlette.routing import Match


def not_found(request: Request, shown: str) -> str:
    """The detail of a 404 for a path no route has, with the path one slash away if it has.

    ``shown``: the path as the detail shows it (a long one cut).
    """
    path = request.url.path
    near = path[:-1] if path.endswith("/") and path != "/" else f"{path}/"
    meant = f"; did you mean {near}?" if path == shown and _matched(request, near) else ""
    return f"no such path: {shown}{meant}"


def not_allowed(request: Request, shown: str) -> str:
    """The detail of a 405: the method, the path (``shown``) and the methods it takes."""
    return f"the method {request.method} is not allowed on {shown}; allowed: {allowed(request)}"


def allowed(request: Request) -> str:
    """Every method of the resource at the request's path (RFC 9110 ``Allow``).

    Starlette answers 405 from the first route whose path matched, naming only that route's
    methods; a path can have several routes (``GET`` and ``POST /plans``). A path with a GET
    answers HEAD too (:mod:`api.rest.head_method`), so it lists ``HEAD``.
    """
    methods: set[str] = set()
    for route in request.app.router.routes:
        match, _ = route.matches(request.scope)
        if match is not Match.NONE:
            methods |= getattr(route, "methods", None) or set()
    if "GET" in methods:
        methods.add("HEAD")
    return ", ".join(sorted(methods))


def _matched(request: Request, path: str) -> bool:
    """Whether a route of the app takes ``path`` (by any method)."""
    scope = {**request.scope, "path": path, "raw_path": path.encode()}
    return any(route.matches(scope)[0] is not Match.NONE for route in request.app.router.routes)
