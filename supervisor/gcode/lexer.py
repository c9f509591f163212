"""Reading a program: lines, words, comments, optional skip, ``%`` markers, block numbers N."""

from __future__ import annotations

import re
from collections.abc import Sequence
from dataclasses import dataclass
from decimal import Decimal
from typing import NamedTuple

_NUMBER = re.compile(r"[+-]?(?:\d+(?:\.\d*)?|\.\d+)")
_BOM = "\ufeff"
#: A line of nothing but spaces, comments and words, perhaps ended by a ``;`` comment: read by
#: :data:`_PIECES` alone (:func:`_plain_words`), as the character loop (:func:`_scanned_words`)
#: would; a test checks they agree. Any other line (an optional skip ``/``, something
#: unreadable) takes that loop.
_PLAIN = re.compile(
    r"(?:\s|\([^)]*\)|[A-Za-z:][ \t]*[+-]?(?:\d+(?:\.\d*)?|\.\d+))*(?:;.*)?", re.DOTALL
)
#: In a line :data:`_PLAIN` matches, from a word's end: the spaces and comments before the next
#: word, then the word (letter, spaces, number), a ``;`` comment, or the end of the line. Each
#: match starts where the one before ended, so the lengths give the columns.
_PIECES = re.compile(
    r"(\s*(?:\([^)]*\)\s*)*)(?:(;.*)|([A-Za-z:])([ \t]*)([+-]?(?:\d+(?:\.\d*)?|\.\d+))|$)",
    re.DOTALL,
)


class Word(NamedTuple):
    """One word of a block: a letter and a number (immutable; a named tuple: quick to make).

    Parameters
    ----------
    letter : str
        The address letter, upper case (``O`` for a ``:`` program number).
    number : str
        The number as written (``"0.25"``, ``".3"``, ``"200."``).
    value : decimal.Decimal
        The number's value.
    start : int
        Index of the letter in the line (0-based).
    number_start : int
        Index of the number's first character (after any spaces following the letter).
    end : int
        Index just after the number.
    """

    letter: str
    number: str
    value: Decimal
    start: int
    number_start: int
    end: int


@dataclass(frozen=True)
class Block:
    """One line of a program.

    Parameters
    ----------
    line : int
        Line number, from 1.
    text : str
        The line without its line ending.
    ending : str
        The line ending as found: LF, CR LF, or empty (a last line without one).
    words : tuple[Word, ...]
        The words, in order (those before the first unreadable character, if any).
    number : int or None
        The block number ``N``.
    optional_skip : bool
        Whether the block starts with ``/`` (skipped when block delete is on).
    marker : bool
        Whether the line is a ``%`` tape marker.
    problem : str or None
        Why the line cannot be read, or None.
    """

    line: int
    text: str
    ending: str
    words: tuple[Word, ...]
    number: int | None
    optional_skip: bool
    marker: bool
    problem: str | None

    def codes(self, letter: str) -> tuple[Decimal, ...]:
        """The values of the words with ``letter`` (e.g. every G code of the block)."""
        return tuple([w.value for w in self.words if w.letter == letter])

    def word(self, letter: str) -> Word | None:
        """The first word with ``letter``, or None."""
        for w in self.words:
            if w.letter == letter:
                return w
        return None


def parse_program(text: str) -> tuple[Block, ...]:
    """Split a program into lines and read each into words.

    Lines end at LF; a CR before it belongs to the line ending. A line that cannot
    be read is kept with its ``problem``; the caller decides whether it matters.

    Parameters
    ----------
    text : str
        The program.

    Returns
    -------
    tuple[Block, ...]
        One block per line, in order; ``"".join(b.text + b.ending for b in blocks) == text``.
    """
    blocks = []
    for index, match in enumerate(re.finditer(r"[^\n]*\n|[^\n]+\Z", text)):
        raw = match.group()
        ending = "\r\n" if raw.endswith("\r\n") else "\n" if raw.endswith("\n") else ""
        blocks.append(read_block(raw[: len(raw) - len(ending)], ending, index + 1))
    return tuple(blocks)


def read_block(text: str, ending: str, line: int) -> Block:
    """Read one line (without its ending) into words; ``line`` is its number, from 1.

    A byte-order mark at the start of line 1 is skipped; a line that cannot be read is kept
    with its ``problem``.
    """
    i = 1 if line == 1 and text.startswith(_BOM) else 0
    if text[i:].lstrip().startswith("%"):
        return Block(line, text, ending, (), None, False, True, None)
    if _PLAIN.fullmatch(text, i):
        return _checked(line, text, ending, _plain_words(text, i), False, None)
    return _checked(line, text, ending, *_scanned_words(text, i))


def _scanned_words(text: str, i: int) -> tuple[list[Word], bool, str | None]:
    """The words of any line from index ``i``, whether it is an optional skip, its problem."""
    words: list[Word] = []
    skip = False
    problem = None
    while i < len(text):
        char = text[i]
        if char.isspace():
            i += 1
        elif char == "(":
            close = text.find(")", i + 1)
            if close < 0:
                problem = f"the comment opened at column {i + 1} is not closed"
                break
            i = close + 1
        elif char == ";":
            break
        elif char == "/" and not words and not skip:
            skip = True
            i += 2 if text[i + 1 : i + 2].isdigit() else 1
        elif (char.isascii() and char.isalpha()) or char == ":":
            j = i + 1
            while j < len(text) and text[j] in " \t":
                j += 1
            found = _NUMBER.match(text, j)
            if found is None:
                problem = (
                    f"{char!r} at column {i + 1} is not followed by a number "
                    "(macro statements are not supported)"
                )
                break
            letter = "O" if char == ":" else char.upper()
            written = found.group()
            words.append(Word(letter, written, Decimal(written), i, j, found.end()))
            i = found.end()
        else:
            problem = (
                f"unexpected {char!r} at column {i + 1} "
                "(macro variables and expressions are not supported)"
            )
            break
    return words, skip, problem


def _plain_words(text: str, start: int) -> list[Word]:
    """The words of a line :data:`_PLAIN` matches from ``start``."""
    words = []
    at = start
    for before, semicolon, char, spaces, written in _PIECES.findall(text, start):
        if semicolon or not char:
            break
        at += len(before)
        number_start = at + 1 + len(spaces)
        end = number_start + len(written)
        letter = "O" if char == ":" else char.upper()
        words.append(Word(letter, written, Decimal(written), at, number_start, end))
        at = end
    return words


def _checked(
    line: int, text: str, ending: str, words: list[Word], skip: bool, problem: str | None
) -> Block:
    """The block of ``words``, with its number, and a problem for two N, F or S words."""
    number, number_problem = _block_number(words)
    letters = [w.letter for w in words]
    for letter in "FS":
        if letters.count(letter) > 1:
            number_problem = number_problem or f"two {letter} words in one block"
    return Block(line, text, ending, tuple(words), number, skip, False, problem or number_problem)


def _block_number(words: Sequence[Word]) -> tuple[int | None, str | None]:
    numbers = [w for w in words if w.letter == "N"]
    if not numbers:
        return None, None
    if len(numbers) > 1:
        return None, "two block numbers (N) in one block"
    value = numbers[0].value
    if value < 0 or value != value.to_integral_value():
        return None, f"block number N{numbers[0].number} is not a whole number"
    return int(value), None


#: The most characters of a word a message shows (``F0.25``; a word of 4000 digits is cut).
MAX_WORD_SHOWN = 40


def _text(block: Block, word: Word) -> str:
    """The word as written, as messages show it: cut with ``…`` past :data:`MAX_WORD_SHOWN`."""
    text = block.text[word.start : word.end]
    return text if len(text) <= MAX_WORD_SHOWN else text[: MAX_WORD_SHOWN - 1] + "…"
