"""The name a misspelt one likely means: one rule for every "did you mean" of rcb.

A file's field, a request's, a measured quantity, an ``--rcb`` setting: each refusal of an
unknown name says the known one it is close to, chosen here.
"""

from __future__ import annotations

import difflib
from collections.abc import Iterable


def meant(name: str, known: Iterable[str]) -> str | None:
    """The one of ``known`` that ``name`` likely misspells, or None.

    The same name but for case and white space (``Force_N``, ``force_N ``), else the closest
    by :func:`difflib.get_close_matches` at its default cutoff 0.6 (``alfa``: ``alpha``;
    ``forse_N``: ``force_N``). One rule for every "did you mean" of a file, a request and
    the command line.
    """
    known = tuple(known)
    plain = name.strip().casefold()
    same = [each for each in known if each.casefold() == plain]
    close = same or difflib.get_close_matches(name.strip(), known, n=1)
    return close[0] if close else None


def unknown_field(name: str, allowed: Iterable[str]) -> str:
    """Why ``name`` is refused among the fields ``allowed``: the one it may mean, the list.

    ``unknown field (did you mean 'feed_mm_rev'?); expected one of: ...``
    """
    allowed = tuple(allowed)
    close = meant(name, allowed)
    hint = f" (did you mean {close!r}?)" if close is not None else ""
    return f"unknown field{hint}; expected one of: {', '.join(allowed)}"
