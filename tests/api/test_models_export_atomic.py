"""``rcb models export --out`` is written whole or not at all, as every other ``--out``.

A review: the document was written with ``Path.write_text``, straight over the file named: a
disk that filled up half-way (``No space left on device``) left the earlier export cut short,
a JSON document ``rcb models import`` refuses, where ``rcb export`` and ``rcb report`` leave
the file as it was (:mod:`api.cli.atomic`). Now a temporary file is renamed over it.
"""

from __future__ import annotations

import errno
import io
import json
from pathlib import Path
from typing import Any

from test_fleet_db import _learned

from conftest import engine_url, invoke


class _FillsUp:
    """An open file whose first write stores half its data, then finds the disk full."""

    def __init__(self, file: Any) -> None:
        self._file = file

    def write(self, data: Any) -> int:
        self._file.write(data[: len(data) // 2])
        raise OSError(errno.ENOSPC, "No space left on device")

    def __enter__(self) -> _FillsUp:
        return self

    def __exit__(self, *exc: object) -> None:
        self._file.close()

    def __getattr__(self, name: str) -> Any:
        return getattr(self._file, name)


def test_a_full_disk_leaves_the_earlier_export_as_it_was(
    sqlite_engine, runner, tmp_path: Path, monkeypatch
) -> None:
    _learned(sqlite_engine, "fleet-a", 0, 2)
    url, out = engine_url(sqlite_engine), tmp_path / "models.json"
    done = invoke(runner, "models", "export", "CNMG432RN", "--out", str(out), "--db", url)
    assert done.exit_code == 0, done.output
    before = out.read_bytes()
    real_open = io.open

    def full_disk(file: Any, mode: str = "r", *args: Any, **kwargs: Any) -> Any:
        opened = real_open(file, mode, *args, **kwargs)
        return _FillsUp(opened) if "w" in mode else opened

    monkeypatch.setattr(io, "open", full_disk)
    failed = invoke(runner, "models", "export", "CNMG432RN", "--out", str(out), "--db", url)
    monkeypatch.undo()
    assert failed.exit_code == 2, failed.output
    assert f"--out = '{out}': cannot be written (No space left on device)" in " ".join(
        failed.output.split()
    )
    assert out.read_bytes() == before  # whole, as the first export wrote it
    assert json.loads(before)["tool"] == "CNMG432RN"
    assert sorted(p.name for p in tmp_path.iterdir() if "rcb.db" not in p.name) == ["models.json"]
