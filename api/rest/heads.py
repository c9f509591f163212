"""Bounded request heads: a request line and header fields over :data:`MAX_HEAD_BYTES` are refused.

uvicorn's httptools protocol (0.55) sets no limit on a request's head: llhttp reads a header
field of any length and httptools joins its pieces in memory, so one 64 MB ``X-Big:`` header
was answered 200 after 8.8 s with the worker 135 MB larger, and 100 000 header fields were
answered too (uvicorn's ``h11_max_incomplete_event_size`` bounds its h11 protocol only). A URL
over 64 KiB got uvicorn's plain-text ``400 Invalid HTTP request received.`` (httptools'
``parse_url`` keeps 16-bit offsets).

:class:`HeadLimit` counts a request's head as its bytes arrive, before the parser holds them,
and hands the parser at most :data:`MAX_HEAD_BYTES` of it (nginx's default,
``large_client_header_buffers 4 8k``, and Node's 16 KiB are of this order). Past that, before
the app sees the request:

- while the request line is still being read: 414 ``uri_too_long``, field ``url``;
- else 431 ``header_fields_too_large``, field the header being read when it is alone over half
  the limit (``X-Big``), else ``headers`` (many header fields);

as RFC 9457 problem+json (:mod:`api.rest.problems`), and the connection is closed. An answer in
progress on the connection (HTTP/1.1 pipelining) is finished first; the refused request is
never read further.

A request the parser refuses (a header field's name with a space, a NUL in its value,
``Content-Length: abc``, two of them, or one beside ``Transfer-Encoding: chunked``) got
uvicorn's plain-text ``400 Invalid HTTP request received.``; it is 400 ``malformed_request``
problem+json too, field ``request``, its detail the parser's reason (llhttp's words, e.g.
"Invalid header value char"), and the connection is closed.
"""

from __future__ import annotations

import json
import sys
from typing import Any

from uvicorn.protocols.http.httptools_impl import STATUS_LINE, HttpToolsProtocol

from api.rest.problems import MEDIA_TYPE, clip

#: The most bytes of a request's head (request line and header fields, CRLFs included).
MAX_HEAD_BYTES = 32 * 1024
#: Seconds a refused connection is still read (and what comes dropped) before it is closed.
LINGER_S = 2.0
#: Bytes of the line being read kept to name the header field it starts.
_KEPT = 256
_TYPE_BASE = "urn:rcb-supervisor:problem:"
_TITLES = {400: "Bad request", 414: "URI too long", 431: "Request header fields too large"}


class HeadRefused(Exception):
    """A request's head refused before the app sees it; the problem that says so."""

    def __init__(self, status: int, code: str, detail: str, field: str, instance: str) -> None:
        self.status, self.code, self.detail = status, code, detail
        self.field, self.instance = field, instance
        super().__init__(detail)

    def answer(self, default_headers: list[tuple[bytes, bytes]]) -> bytes:
        """The whole HTTP response: problem+json, the connection closed after it."""
        body = json.dumps(
            {
                "type": _TYPE_BASE + self.code,
                "title": _TITLES[self.status],
                "status": self.status,
                "detail": self.detail,
                "instance": self.instance,
                "code": self.code,
                "field": self.field,
                "value": None,
            },
            separators=(",", ":"),
        ).encode("ascii")  # ASCII: names are shown escaped
        head = [STATUS_LINE[self.status]]
        head += [name + b": " + value + b"\r\n" for name, value in default_headers]
        head.append(b"content-type: " + MEDIA_TYPE.encode("ascii") + b"\r\n")
        head.append(b"content-length: %d\r\nconnection: close\r\n\r\n" % len(body))
        return b"".join(head) + body


class HeadTooLarge(HeadRefused):
    """A request's head passed :data:`MAX_HEAD_BYTES`."""


class HeadLimit(HttpToolsProtocol):
    """uvicorn's httptools protocol that refuses a head over :data:`MAX_HEAD_BYTES`."""

    max_head = MAX_HEAD_BYTES

    def __init__(self, *args: Any, **kwargs: Any) -> None:
        super().__init__(*args, **kwargs)
        self._head_open = True  # the bytes now arriving are a request's head
        self._head_bytes = 0
        self._line = b""  # the start of the line being read (of the byte stream)
        self._line_bytes = 0
        self._refused: HeadRefused | None = None

    def data_received(self, data: bytes) -> None:
        """Hand ``data`` to the parser; at most the limit's worth of a head."""
        if self._refused is not None:
            return  # refused: nothing more of this connection is read
        try:
            while data and not self.transport.is_closing():
                if not self._head_open:  # a body (and the head of a request pipelined after it)
                    super().data_received(data)
                    return
                room = self.max_head - self._head_bytes
                if room <= 0:
                    raise self._too_large()
                piece, data = data[:room], data[room:]
                self._count(piece)
                super().data_received(piece)
        except HeadTooLarge as refused:
            self._refuse(refused)

    def send_400_response(self, msg: str) -> None:
        """The parser refused the request: 400 ``malformed_request`` problem+json, then close.

        uvicorn calls this while it handles the parser's exception, whose reason is the detail.
        """
        error = sys.exc_info()[1]
        reason = str(error).strip() if error is not None else ""
        detail = f"the request is not valid HTTP/1.1: {reason or msg}"
        path = clip((getattr(self, "url", None) or b"").split(b"?")[0].decode("latin-1"))
        refused = HeadRefused(400, "malformed_request", clip(detail), "request", path)
        self.transport.write(refused.answer(self.server_state.default_headers))
        self.transport.close()

    def on_headers_complete(self) -> None:
        """The head is in: what follows is its body, not counted."""
        self._head_open = False
        super().on_headers_complete()

    def on_message_complete(self) -> None:
        """The request is in: what follows is the next request's head.

        Its bytes in the read that ended this request are not counted (at most one read).
        """
        self._head_open, self._head_bytes = True, 0
        super().on_message_complete()

    def on_response_complete(self) -> None:
        """An answer is sent: a refusal that waited for it goes out now."""
        super().on_response_complete()
        if self._refused is not None and not self.transport.is_closing():
            self._refuse(self._refused)

    def _count(self, piece: bytes) -> None:
        """Count ``piece`` of a head, keeping the start of the line being read."""
        self._head_bytes += len(piece)
        end = piece.rfind(b"\n")
        if end >= 0:
            rest = piece[end + 1 :]
            self._line, self._line_bytes = rest[:_KEPT], len(rest)
        else:
            self._line += piece[: max(0, _KEPT - len(self._line))]
            self._line_bytes += len(piece)

    def _too_large(self) -> HeadTooLarge:
        """The problem of this head: the URL, one header field, or all of them."""
        limit = self.max_head
        path = clip((getattr(self, "url", None) or b"").split(b"?")[0].decode("latin-1"))
        name = self._line.partition(b":")[0]
        if b" " in name:  # "GET /path...": a field's name has no space, a request line has
            detail = f"the request line is over {limit} bytes: send a shorter URL"
            return HeadTooLarge(414, "uri_too_long", detail, "url", path)
        fields = len(getattr(self, "headers", None) or ())  # the head's, as parsed so far
        if self._line_bytes > limit // 2:
            field = clip(name.strip().decode("latin-1")) or "headers"
            detail = (
                f"the header field {field!r} is over {self._line_bytes} bytes; a request's "
                f"head (request line and header fields) may have at most {limit}"
            )
        else:
            field = "headers"
            detail = (
                f"the request's head is over {limit} bytes after {fields} header fields; a "
                f"request's head (request line and header fields) may have at most {limit}"
            )
        return HeadTooLarge(431, "header_fields_too_large", detail, field, path)

    def _refuse(self, refused: HeadRefused) -> None:
        """Answer ``refused`` and close, once the answer in progress (if any) is sent."""
        self._refused = refused
        busy = self.cycle is not None and not self.cycle.response_complete
        if busy or self.pipeline:
            self.flow.pause_reading()  # on_response_complete sends it
            return
        self.transport.write(refused.answer(self.server_state.default_headers))
        if not self.transport.can_write_eof():
            self.transport.close()
            return
        # a lingering close (nginx's lingering_close): the answer, then FIN, then what the
        # client still sends is read and dropped for a while, so that its kernel does not get a
        # reset, which can discard the answer before the client has read it
        self.transport.write_eof()
        self.flow.resume_reading()
        self.loop.call_later(LINGER_S, self.transport.close)
