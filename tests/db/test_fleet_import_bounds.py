"""``rcb models import`` refuses a learned model no plant could have learned (issue 32).

A process engineer's review: a document whose posterior mean was 1e300, whose variance was
negative or whose operation's force limit was -5 was stored (exit 0), and from then on every
``rcb plans create`` of the tool, and ``rcb fleet law``, ended in an OverflowError traceback.
Each is now refused naming the field, nothing is stored, and a new plan still starts.
"""

from __future__ import annotations

import copy
from collections.abc import Callable
from typing import Any

import pytest
from test_fleet_db import LEARN, _body, _learned
from test_fleet_import_once import _rows, _second

from api.services.fleet_models import exclude_from_fleet, export_tool, import_tool
from api.services.plans import create_plan
from models.errors import InputError
from supervisor.fleet.document import MAX_IMPORTED_MACHINES


def _set(*path: Any, value: Any) -> Callable[[dict[str, Any]], None]:
    """A change of the document's first item at ``path`` to ``value``."""

    def change(item: dict[str, Any]) -> None:
        *head, last = path
        for key in head:
            item = item[key]
        item[last] = value

    return change


def _drop(*path: Any) -> Callable[[dict[str, Any]], None]:
    """A change of the document's first item: the key at ``path`` taken out."""

    def change(item: dict[str, Any]) -> None:
        *head, last = path
        for key in head:
            item = item[key]
        del item[last]

    return change


def _band_of_a_ppb(item: dict[str, Any]) -> None:  # its tool's model known to 1e-9 of K
    model = item["tool"]["models"][item["posterior"]["quantity"]]
    model["dK"] = 1e-9 * model["K"]


def _pinned_cov(item: dict[str, Any]) -> None:  # ln Y and the first exponent all but one
    cov = item["posterior"]["cov"]
    for i in range(2, len(cov)):
        cov[0][i] = cov[i][0] = cov[1][i] = cov[i][1] = 0.0
    cov[0][1] = cov[1][0] = (1 - 1e-13) * (cov[0][0] * cov[1][1]) ** 0.5


def _swap_cov(item: dict[str, Any]) -> None:  # symmetric, but one eigenvalue negative
    cov = item["posterior"]["cov"]
    cov[0][1] = cov[1][0] = 10 * (cov[0][0] * cov[1][1]) ** 0.5


def _scaled_readings(factor: float) -> Callable[[dict[str, Any]], None]:
    """A change of the first item: its readings' information (not their vector) x ``factor``."""

    def change(item: dict[str, Any]) -> None:
        rows = item["posterior"]["readings_information"]
        item["posterior"]["readings_information"] = [[factor * v for v in r] for r in rows]

    return change


CASES = [
    (_set("posterior", "mean", 0, value=1e300), "posterior.mean[0]", "within ±27.631"),
    (_set("posterior", "mean", 0, value=50.0), "posterior.mean[0]", "within ±27.631"),
    (_set("posterior", "mean", 1, value=-620.0), "posterior.mean[1]", "within ±100"),
    (_set("posterior", "cov", 0, 0, value=-1.0), "posterior.cov[0][0]", "greater than 0"),
    (_set("posterior", "cov", 0, 1, value=1e-3), "posterior.cov[0][1]", "must equal cov[1][0]"),
    (_swap_cov, "posterior.cov", "positive definite"),
    (_set("posterior", "center", 0, value=1e5), "posterior.center[0]", "within ±27.631"),
    (_set("posterior", "noise_scale2", value=1e9), "posterior.noise_scale2", "> 0 and <= 10000"),
    (_set("posterior", "names", 0, value="spin"), "posterior.names", "not an input"),
    (_set("operation", "limits", "force_N", value=-5), "operation.limits.force_N", "than 0"),
    (_set("operation", "bounds", "feed_mm_rev", value=[0.5, 0.1]), "bounds.feed_mm_rev", "above"),
    (_set("operation", "bounds", "feed_mm_rev", value=[0.1]), "bounds.feed_mm_rev", "[low, high]"),
    (_set("start", value={"x": 1}), "start", "is not a posterior"),
    # a review: these were stored and counted ("1000000024 readings", machine "a@not-a-uu")
    (_set("posterior", "observations", value=-5), "posterior.observations", "in 0..2147483647"),
    (_set("posterior", "observations", value=10**12), "posterior.observations", "whole number"),
    (_set("posterior", "observations", value="12"), "posterior.observations", "whole number"),
    (_set("origin", value="not-a-uuid"), "origin", "a UUID (rcb models identity)"),
    # a review: stored, then every rcb plans create of the tool and rcb fleet law ended in a
    # KeyError traceback (a bound missing) or refused each new plan ("depth_mm = None")
    (_drop("operation", "bounds", "depth_mm"), "operation.bounds.depth_mm", "needs its bounds"),
    (_set("operation", "process", value="milling"), "operation.process", "process is turning"),
    # a review: refused as "posterior = 'dict': is not a posterior (could not convert string
    # to float: 'a')", naming neither the field nor its value
    (_set("posterior", "mean", 1, value="a"), "posterior.mean[1]", "must be a number"),
    (_set("posterior", "cov", 0, 0, value="x"), "posterior.cov[0][0]", "must be a number"),
    (_set("posterior", "names", 0, value=1), "posterior.names[0]", "an input's name"),
    (_set("posterior", "edge_max", value="b"), "posterior.edge_max", "whole number >= 0"),
    (_drop("posterior", "cov"), "posterior", "is not a posterior: no cov"),
    # a review: "document.learned = 'CNMG432RN': holds models of another tool" named the
    # document's tool, not the item or the tool it held
    (_set("tool", "name", value="OTHER"), "tool.name", "the document's tool is 'CNMG432RN'"),
    # a review: a machine named with an escape and a line feed was stored, and rcb fleet
    # imported wrote it to the terminal as it was (a plan file's names are refused so)
    (_set("machine", value="lathe\x1b[31m\nx"), "machine", "must not contain control"),
    (_set("plan", value="a\u200bb"), "plan", "must not contain invisible format"),
    (_set("operation", "name", value="od\nx"), "operation.name", "must not contain control"),
    # a review: stored, a force model whose dK was 1e-9 of K made the next plan's fleet law
    # K = 1.8e-8 N with a feed exponent of -17.8 (its evidence was round-off of 1e18)
    (_band_of_a_ppb, "tool.models.force_N", "knows the law (nearly) exactly"),
    (_pinned_cov, "posterior.cov", "knows the law (nearly) exactly"),
    # the readings' own information (2026-12-06): the evidence a fleet prior takes from it
    (_set("posterior", "readings_vector", 0, value="a"), "readings_vector[0]", "a number"),
    (_drop("posterior", "readings_vector"), "posterior.readings_vector", "information needs it"),
    (_set("posterior", "readings_information", value=[[1.0]]), "readings_information", " x "),
    (
        _set("posterior", "readings_information", 0, 1, value=1.0),
        "readings_information[0][1]",
        "must equal readings_information[1][0]",
    ),
    (_scaled_readings(-1.0), "posterior.readings_information", "is positive semidefinite"),
    (_scaled_readings(1e6), "posterior.readings_information", "more than the belief's"),
]


@pytest.fixture(scope="module")
def exported(tmp_path_factory) -> dict[str, Any]:
    """The document of a plan that made 2 parts on a plant's SQLite database, once."""
    first = _second(tmp_path_factory.mktemp("first"), "first")
    _learned(first, "fleet-a", 0, 2)
    document = export_tool(engine=first, tool="CNMG432RN")
    first.dispose()
    return document


@pytest.mark.parametrize(("change", "field", "reason"), CASES)
def test_a_model_no_plant_learned_is_refused_and_plans_still_start(
    engine, exported, change, field, reason
) -> None:
    """Imported into a second plant's database on each backend: refused, nothing stored."""
    document, second = copy.deepcopy(exported), engine
    bad = copy.deepcopy(document)
    change(bad["learned"][0])
    with pytest.raises(InputError) as refused:
        import_tool(engine=second, data=bad, source="bad.json")
    assert refused.value.field.startswith("document.learned[0].")
    assert refused.value.field.endswith(field) and reason in refused.value.reason
    assert _rows(second) == 0
    made = create_plan(engine=second, body=_body("after", "lathe-9"), settings=LEARN).body
    assert made["prior"] == "catalogue"  # nothing stored: the catalogue's, no traceback
    assert import_tool(engine=second, data=document, source="good.json").body["new"] == 2
    fleet = create_plan(engine=second, body=_body("fleet", "lathe-9"), settings=LEARN).body
    assert fleet["prior"] == "fleet"


def test_imports_past_the_machines_a_fleet_prior_reads_are_refused_whole(engine, exported):
    """A year's plant (audited): one 62 MB file put a tool's imported models on 1 150 machines,
    and every new plan's fleet prior and ``rcb fleet law`` of the tool then took 35 s."""
    document, second = copy.deepcopy(exported), engine
    item = document["learned"][0]
    many = copy.deepcopy(document)
    many["learned"] = [
        {**copy.deepcopy(item), "machine": f"m-{i:03d}", "plan": f"p-{i:03d}"}
        for i in range(MAX_IMPORTED_MACHINES)
    ]
    more = copy.deepcopy(many)
    more["learned"][0]["machine"], more["learned"][0]["plan"] = "m-new", "p-new"
    assert import_tool(engine=second, data=many, source="many.json").body["new"] == 200
    with pytest.raises(InputError) as refused:  # one machine more, in a second file
        import_tool(engine=second, data=more, source="more.json")
    assert (refused.value.field, refused.value.value) == ("document.learned", "200 models")
    assert "on 201 machines in the fleet, more than 200" in refused.value.reason
    assert _rows(second) == 200  # the second file stored nothing
    name = f"m-000@{item['origin'][:8]}"
    exclude_from_fleet(engine=second, plan_id=None, machine=name, reason="sold")
    assert import_tool(engine=second, data=more, source="more.json").body["new"] == 1
