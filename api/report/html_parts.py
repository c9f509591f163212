"""The small HTML helpers the HTML report and the web view share: escaped text, elements, a page.

Every text from the database goes through :func:`escaped` (:func:`html.escape`, quotes
included); :func:`tag` writes well-formed XML as well as HTML, so XML tools can read the pages.
"""

from __future__ import annotations

import html
import re
from collections.abc import Iterable
from datetime import datetime

#: Longest name or serial a page keeps on one line [characters]; a longer one may break.
ONE_LINE_CHARS = 24
#: Longest piece of a long name that is never broken [characters]: pieces are grouped up to it.
PIECE_CHARS = 12


def escaped(value: object) -> str:
    """``str(value)`` as HTML text: ``&``, ``<``, ``>`` and both quotes escaped."""
    return html.escape(str(value), quote=True)


def tag(name: str, content: str, **attributes: object) -> str:
    """``<name attributes>content</name>``; ``content`` must already be HTML.

    An attribute ``class_`` is written ``class``, ``data_kind`` is written ``data-kind``; an
    attribute whose value is ``None`` is left out.
    """
    attrs = "".join(
        f' {key.rstrip("_").replace("_", "-")}="{escaped(v)}"'
        for key, v in attributes.items()
        if v is not None
    )
    return f"<{name}{attrs}>{content}</{name}>"


def row(cells: Iterable[str], **attributes: object) -> str:
    """A table row of cells that are already HTML."""
    return tag("tr", "".join(cells), **attributes)


def th(text: object, **attributes: object) -> str:
    """A header cell holding ``text`` (escaped)."""
    return tag("th", escaped(text), **attributes)


def td(text: object, **attributes: object) -> str:
    """A data cell holding ``text`` (escaped)."""
    return tag("td", escaped(text), **attributes)


def timestamp(moment: object) -> str:
    """A time as the pages print it (``2026-01-31 12:00:00 UTC``); anything else as ``str``."""
    if isinstance(moment, datetime):
        return moment.strftime("%Y-%m-%d %H:%M:%S %Z").strip()
    return str(moment)


def nowrap(text: object) -> str:
    """``text`` (escaped) in a span that never breaks across lines (``class="nw"``)."""
    return tag("span", escaped(text), class_="nw")


def name_html(value: object) -> str:
    """A name or a serial as HTML: whole on one line, or, if long, broken only between pieces.

    Up to :data:`ONE_LINE_CHARS` characters it is one unbreakable span (``rough-od``). A
    longer one (names and serials may have 200) would push a table past a 1280 px window: it
    may break after a ``-``, ``_``, ``/`` or ``.`` that ends a piece of up to
    :data:`PIECE_CHARS` characters (or a run that long without one), each break offered by a
    ``<wbr/>`` between pieces that never break themselves (``class="brk"``).
    """
    text = str(value)
    if len(text) <= ONE_LINE_CHARS:
        return nowrap(text)
    pieces: list[str] = []
    for run in re.split(r"(?<=[-_/.])", text):
        for i in range(0, len(run), PIECE_CHARS):
            piece = run[i : i + PIECE_CHARS]
            if pieces and len(pieces[-1]) + len(piece) <= PIECE_CHARS:
                pieces[-1] += piece
            elif piece:
                pieces.append(piece)
    # a piece a browser could break inside (after its own "-") in a span that never breaks
    return tag(
        "span",
        "<wbr/>".join(escaped(p) if p[:-1].isalnum() else nowrap(p) for p in pieces),
        class_="brk",
    )


def timestamp_html(moment: object) -> str:
    """:func:`timestamp` as HTML: the date and the time each on one line (never ``2026-12-``)."""
    return " ".join(nowrap(word) for word in timestamp(moment).split(" ", 1))


def document(title: str, css: str, body: str) -> str:
    """An HTML5 page: UTF-8, ``title`` (escaped), inline ``css``, ``body`` (already HTML)."""
    head = '<meta charset="utf-8"/>' + tag("title", escaped(title)) + tag("style", css)
    return f'<!DOCTYPE html>\n<html lang="en">{tag("head", head)}{tag("body", body)}</html>\n'
