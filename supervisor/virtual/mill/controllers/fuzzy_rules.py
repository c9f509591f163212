"""The rule base of Kim & Jeon's fuzzy feed controller (Precision Engineering 2011, Table 2).

Eleven linguistic levels, from NVB (negative very big) to PVB (positive very big), for the
normalised error ``Ē`` (rows), its change ``CĒ`` (columns) and the output ``CŌ`` (cells).
The table is copied exactly as printed. Ē = NVB with CĒ = NVB gives NVB, a feed decrease,
so a negative error is a force above the reference: ``E = F_d − F_max`` (the text says only
"the difference between" them; Eq. 6 adds a positive output to the feed).

As printed, the table is antisymmetric (``rule(−e, −ce) = −rule(e, ce)``) in every cell but
one pair, :data:`ASYMMETRIC_CELLS`: (NB, NVS) = NM while (PB, PVS) = PB (NM would mirror
to PM). Every row and every column is non-decreasing, and the anti-diagonal (a change that
cancels the error, ``CĒ = −Ē``) is ZO throughout. The code keeps the printed cell.
"""

from __future__ import annotations

#: Linguistic levels in increasing order; index − 5 is the level's signed rank.
LEVELS = ("NVB", "NB", "NM", "NS", "NVS", "ZO", "PVS", "PS", "PM", "PB", "PVB")

_TABLE_2 = """
NVB  NVB NVB NVB NVB NVB NVB NB  NM  NS  NS  ZO
NB   NVB NVB NVB NB  NM  NM  NM  NS  NS  ZO  PS
NM   NVB NVB NB  NM  NM  NS  NS  NS  ZO  PS  PS
NS   NVB NB  NM  NM  NS  NVS NVS ZO  PS  PS  PM
NVS  NVB NB  NM  NS  NVS NVS ZO  PVS PS  PM  PB
ZO   NB  NM  NS  NVS NVS ZO  PVS PVS PS  PM  PB
PVS  NB  NM  NS  NVS ZO  PVS PVS PS  PM  PB  PVB
PS   NM  NS  NS  ZO  PVS PVS PS  PM  PM  PB  PVB
PM   NS  NS  ZO  PS  PS  PS  PM  PM  PB  PVB PVB
PB   NS  ZO  PS  PS  PM  PM  PB  PB  PVB PVB PVB
PVB  ZO  PS  PS  PM  PB  PVB PVB PVB PVB PVB PVB
"""


def _parse(text: str) -> tuple[tuple[str, ...], ...]:
    rows = []
    for i, line in enumerate(line for line in text.strip().splitlines()):
        words = line.split()
        if words[0] != LEVELS[i] or len(words) != 12 or not set(words[1:]) <= set(LEVELS):
            raise ValueError(f"Table 2 row {i} is malformed: {line!r}")
        rows.append(tuple(words[1:]))
    return tuple(rows)


#: Kim & Jeon Table 2: ``RULES[i][j]`` is the output for ``Ē = LEVELS[i]``, ``CĒ = LEVELS[j]``.
RULES: tuple[tuple[str, ...], ...] = _parse(_TABLE_2)


def rule(error_level: str, change_level: str) -> str:
    """Output level for an error level and a change-of-error level (Kim & Jeon Table 2)."""
    for name, value in (("error_level", error_level), ("change_level", change_level)):
        if value not in LEVELS:
            raise ValueError(f"{name} = {value!r}: not one of {', '.join(LEVELS)}")
    return RULES[LEVELS.index(error_level)][LEVELS.index(change_level)]


def rank(level: str) -> int:
    """Signed rank of a level, −5 (NVB) … 0 (ZO) … +5 (PVB)."""
    return LEVELS.index(level) - 5


def rank_table() -> tuple[tuple[int, ...], ...]:
    """:data:`RULES` as signed ranks."""
    return tuple(tuple(rank(cell) for cell in row) for row in RULES)


def asymmetric_cells() -> tuple[tuple[str, str], ...]:
    """Cells ``(Ē, CĒ)`` with ``rule(Ē, CĒ) ≠ −rule(−Ē, −CĒ)`` (each pair listed once)."""
    ranks = rank_table()
    cells = []
    for i in range(11):
        for j in range(11):
            if (i, j) < (10 - i, 10 - j) and ranks[i][j] != -ranks[10 - i][10 - j]:
                cells.append((LEVELS[i], LEVELS[j]))
    return tuple(cells)


#: Where the printed table is not antisymmetric (the negative-side cell of each pair).
ASYMMETRIC_CELLS = asymmetric_cells()
