"""The small HTML helpers the HTML report and the web view share: escaped text, elements, a page.

Every text from the database goes through :func:`escaped` (:func:`html.escape`, quotes
included); :func:`tag` writes well-formed XML as well as HTML, so XML tools can read the pages.
"""

from __future__ import annotations

import html
from collections.abc import Iterable
from datetime import datetime


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


def document(title: str, css: str, body: str) -> str:
    """An HTML5 page: UTF-8, ``title`` (escaped), inline ``css``, ``body`` (already HTML)."""
    head = '<meta charset="utf-8"/>' + tag("title", escaped(title)) + tag("style", css)
    return f'<!DOCTYPE html>\n<html lang="en">{tag("head", head)}{tag("body", body)}</html>\n'
