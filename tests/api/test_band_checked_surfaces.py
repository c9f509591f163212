"""Where the fleet's machines differ by more than the catalogue band, every surface says so.

A fleet prior whose machines differ by more than the band's ``dK/K`` checks the band's optimum
at 2 sd before it runs (:func:`supervisor.fleet.prior._beyond_band`, issue 32): the first
setpoint may then be slower than the catalogue's, and an engineer reading the plan must see
why. The JSON (REST, ``--json``) names the sd in a key of its own, ``band_checked_at_sd``
(null where the band is checked at the prior's mean); the report's overview and the prior
table of ``rcb plans create``/``show`` say it in words, for the quantities it holds for only.
"""

from __future__ import annotations

from typing import Any

from test_fleet_veto import PLAN, SETTINGS, _machine

from api.report.provenance import prior_caption, prior_line
from api.rest.schemas.setpoints import PriorProvenance
from db.fleet import prior_json
from db.fleet_names import bounded
from supervisor.fleet.prior import fleet_priors
from supervisor.fleet.provenance import FLEET_VETO_Z

SAID = (
    "rough-od force_N: the machines differ by more than the catalogue band, whose setpoint "
    "runs only where it holds at 2 sd of the fleet prior"
)


def _provenance(offsets: list[float]) -> dict[str, Any]:
    """rough-od force_N's stored provenance from machines at ``offsets`` in ln K."""
    learned = [_machine(f"m{i}", o) for i, o in enumerate(offsets)]
    stored = prior_json(fleet_priors(PLAN, learned, 2.0, SETTINGS.exponent_sd))
    assert stored is not None
    return dict(stored["rough-od|force_N"]["provenance"])


def _plan(line: dict[str, Any]) -> dict[str, Any]:
    operations = [{"name": "rough-od"}]
    return {"prior": "fleet", "operations": operations, "provenance": {"rough-od": [line]}}


def test_the_json_names_the_sd_where_the_machines_differ_by_more_than_the_band() -> None:
    """Three machines 20 % apart (past the 7 % force band): 2.0; 1 % apart: null. Both
    are what REST declares (``PriorProvenance``)."""
    far, near = _provenance([-0.2, 0.0, 0.2]), _provenance([-0.01, 0.0, 0.01])
    assert far["band_checked_at_sd"] == FLEET_VETO_Z == 2.0
    assert near["band_checked_at_sd"] is None
    for line in (far, near):
        shown = PriorProvenance.model_validate(bounded(line))
        assert shown.band_checked_at_sd == line["band_checked_at_sd"]


def test_the_report_and_the_prior_table_say_it_where_it_holds_only() -> None:
    far, near = _provenance([-0.2, 0.0, 0.2]), _provenance([-0.01, 0.0, 0.01])
    assert SAID in prior_line(_plan(far))
    assert "differ by more" not in prior_line(_plan(near))
    assert prior_caption([("rough-od", far)]) == SAID
    assert prior_caption([("rough-od", near)]) is None


def test_a_prior_stored_before_the_key_reads_as_checked_at_its_mean() -> None:
    """``plans.prior`` rows written before ``band_checked_at_sd`` lack it: null, no words."""
    old = _provenance([-0.01, 0.0, 0.01])
    del old["band_checked_at_sd"]
    assert PriorProvenance.model_validate(bounded(old)).band_checked_at_sd is None
    assert "differ by more" not in prior_line(_plan(old))


def test_a_check_stored_before_its_reason_names_none() -> None:
    """A line checked at 2 sd but stored before ``band_checked_because`` was kept: null over
    REST, and the words say the band is checked without saying why (it may have been a
    halt, not the spread)."""
    old = _provenance([-0.2, 0.0, 0.2])
    assert old["band_checked_because"] == ["spread"]
    del old["band_checked_because"]
    assert PriorProvenance.model_validate(bounded(old)).band_checked_because is None
    assert prior_caption([("rough-od", old)]) == (
        "rough-od force_N: the catalogue band's setpoint runs only where it holds at 2 sd of "
        "the fleet prior"
    )
