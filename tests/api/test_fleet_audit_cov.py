"""A hand-edited covariance in ``rcb models import`` is refused naming what is wrong with it.

Found by a user's walk through two plants (2026-12-04): a file whose ``cov[0][1]`` was
edited (no longer its mirror's ``cov[1][0]``) was refused as ``posterior.cov = 'not positive
definite'``: neither the element nor its value, and not what was wrong (it was not
symmetric). A matrix that is not positive definite now gives its smallest eigenvalue.
Refused, the import stores nothing.
"""

from __future__ import annotations

import json

from sqlalchemy import func, select
from sqlalchemy.orm import Session
from test_fleet_db import _learned

from db import tables as t

from conftest import engine_url, invoke


def _import(engine, runner, tmp_path, edit) -> str:  # type: ignore[no-untyped-def]
    """The error of importing this database's export of CNMG432RN after ``edit``."""
    url = engine_url(engine)
    file = tmp_path / "a.json"
    done = invoke(runner, "models", "export", "CNMG432RN", "--out", str(file), "--db", url)
    assert done.exit_code == 0, done.output
    data = json.loads(file.read_text())
    edit(data["learned"][0]["posterior"]["cov"])
    file.write_text(json.dumps(data))
    done = invoke(runner, "models", "import", str(file), "--db", url)
    assert done.exit_code == 2, done.output
    with Session(engine) as session:
        assert session.scalar(select(func.count()).select_from(t.ImportedModel)) == 0
    (line,) = done.output.splitlines()
    return line


def test_an_edited_covariance_names_the_element_and_its_mirror(engine, runner, tmp_path) -> None:
    _learned(engine, "fleet-a", 0, 1)

    def edit(cov: list[list[float]]) -> None:
        cov[0][1] += 1.0

    line = _import(engine, runner, tmp_path, edit)
    assert line.startswith("rcb: error: document.learned[0].posterior.cov[0][1] = ")
    assert line.endswith(": a covariance is symmetric")
    assert "must equal cov[1][0] = " in line


def test_a_covariance_not_positive_definite_gives_its_eigenvalue(engine, runner, tmp_path) -> None:
    _learned(engine, "fleet-a", 0, 1)

    def edit(cov: list[list[float]]) -> None:
        cov[0][1] = cov[1][0] = 10 * (cov[0][0] * cov[1][1]) ** 0.5

    line = _import(engine, runner, tmp_path, edit)
    assert line.startswith("rcb: error: document.learned[0].posterior.cov = '")
    assert ", smallest eigenvalue -" in line
    assert line.endswith(": must be positive definite: a covariance")
