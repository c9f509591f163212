"""Reading a program from a binary stream, a line at a time, each line at most 4096 bytes.

A program is read as bytes and never held whole: lines end at LF (a CR before it belongs to
the line ending), and each line is decoded as UTF-8 with ``surrogateescape``, so that every
byte, valid UTF-8 or not, comes back unchanged when the text is encoded the same way. A line
longer than :data:`MAX_LINE_BYTES` is refused after reading that many bytes of it, never more.
"""

from __future__ import annotations

from collections.abc import Iterator
from typing import NamedTuple, Protocol

from models.errors import MAX_ECHO
from supervisor.gcode.errors import GcodeError

#: The longest line read [bytes, without its line ending]: characters in an ASCII program.
#: A block of G-code is a few dozen characters (Fanuc's controls store at most a few hundred);
#: a longer line is not a program a lathe runs, and reading it whole could fill the memory.
MAX_LINE_BYTES = 4096
#: How the program's bytes become text and back: the same bytes out for every byte in.
ENCODING, BYTES = "utf-8", "surrogateescape"


class ProgramSource(Protocol):
    """A program's bytes, read a line at a time, from the start again as often as needed."""

    def readline(self, size: int = -1, /) -> bytes:
        """The next line, with its LF, of at most ``size`` bytes; ``b""`` at the end."""
        ...

    def seek(self, offset: int, whence: int = 0, /) -> int:
        """Move to ``offset`` (0: the start)."""
        ...


class Line(NamedTuple):
    """One line of a program as read (immutable; a named tuple: quick to make).

    Parameters
    ----------
    number : int
        Line number, from 1.
    raw : bytes
        The line as read, its line ending included.
    text : str
        The line without its ending, decoded (UTF-8, ``surrogateescape``).
    ending : str
        LF, CR LF, or empty (a last line without one).
    """

    number: int
    raw: bytes
    text: str
    ending: str


def read_lines(source: ProgramSource, program_name: str) -> Iterator[Line]:
    """Every line of ``source`` from its start.

    Raises
    ------
    GcodeError
        With field ``"<program> line <n>"`` for a line longer than :data:`MAX_LINE_BYTES`
        (its first characters are the value; the rest of it is not read).
    """
    source.seek(0)
    number = 0
    while raw := source.readline(MAX_LINE_BYTES + 2):  # + CR LF
        number += 1
        if raw.endswith(b"\r\n"):
            body, ending = raw[:-2], "\r\n"
        elif raw.endswith(b"\n"):
            body, ending = raw[:-1], "\n"
        else:
            body, ending = raw, ""
        if len(body) > MAX_LINE_BYTES:
            raise GcodeError(
                f"{program_name} line {number}",
                body[:MAX_ECHO].decode(ENCODING, BYTES),
                f"is longer than {MAX_LINE_BYTES} bytes: not a block of G-code (rcb gcode "
                f"reads lines of at most {MAX_LINE_BYTES} bytes, and no further)",
            )
        yield Line(number, raw, body.decode(ENCODING, BYTES), ending)
