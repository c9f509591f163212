"""A file written whole or not at all, streamed: what ``rcb`` writes for ``--out``.

:func:`written_atomically` yields a temporary file beside the target; when the block
succeeds it is synced, given the mode a new file would have (not ``mkstemp``'s 0600) and
renamed over the target; on any error it is removed and the target is as it was. A write
error is an error of the option that named the file (``--out = PATH: cannot be written
(No space left on device)``), never a traceback.
"""

from __future__ import annotations

import os
import tempfile
from collections.abc import Iterator
from contextlib import contextmanager, suppress
from pathlib import Path
from typing import IO

from models.errors import InputError


class AtomicFile:
    """The temporary file being written: a write error is an error of ``field``."""

    def __init__(self, file: IO[bytes], path: Path, field: str) -> None:
        self._file, self._path, self._field = file, path, field

    def write(self, data: bytes, /) -> int:
        """Write ``data``."""
        try:
            return self._file.write(data)
        except OSError as err:
            raise unwritable(self._path, err, self._field) from None

    @property
    def raw(self) -> IO[bytes]:
        """The open file, for a writer that takes one (pyarrow's); its errors are OSError."""
        return self._file


def unwritable(path: Path, err: OSError, field: str = "--out") -> InputError:
    """``field = PATH: cannot be written (reason)``."""
    reason = err.strerror or err.__class__.__name__
    return InputError(field, str(path), f"cannot be written ({reason})")


@contextmanager
def written_atomically(path: Path, field: str = "--out") -> Iterator[AtomicFile]:
    """A file that becomes ``path`` whole when the block succeeds, else nothing at all."""
    try:
        handle, temporary = tempfile.mkstemp(
            prefix=f".{path.name}.", suffix=".tmp", dir=path.parent
        )
    except OSError as err:
        raise unwritable(path, err, field) from None
    try:
        with os.fdopen(handle, "wb") as file:
            yield AtomicFile(file, path, field)
            file.flush()
            os.fsync(file.fileno())
        os.chmod(temporary, 0o666 & ~_umask())
        os.replace(temporary, path)
    except OSError as err:
        _remove(temporary)
        raise unwritable(path, err, field) from None
    except BaseException:
        _remove(temporary)
        raise


def _remove(temporary: str) -> None:
    with suppress(OSError):
        os.unlink(temporary)


def _umask() -> int:
    current = os.umask(0o022)
    os.umask(current)
    return current
