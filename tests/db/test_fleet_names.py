"""A fleet prior names at most ten plans and ten machines, and counts them all (db.fleet_names).

Its provenance goes with every setpoint answer the MES reads: at 32 machines of ten plans each
(320 names a quantity) ``GET /setpoints`` was 44 kB. Stored and answered, each list holds the
first ten names, sorted, beside its count; a prior stored before (every name, no count) is
answered the same way; a key scoped to plans gets null lists and the counts; the report's
line counts the plans of all quantities together, and says "at least" where the lists are cut.
"""

from __future__ import annotations

import json

from api.report.provenance import prior_line
from db.fleet import prior_answer, provenance_json
from db.fleet_names import MAX_NAMED, bounded
from db.fleet_noise import noise_prior_json
from supervisor.fleet.noise import NoisePrior
from supervisor.fleet.provenance import Provenance
from supervisor.rcb.noise import NoiseScale

PLANS = tuple(f"plan-{i:03d}" for i in range(320))
MACHINES = tuple(f"lathe-{i:02d}" for i in range(32))


def _stored(plans=PLANS, machines=MACHINES):
    provenance = Provenance("force_N", plans, machines, 0.041, 96 * len(plans), 0.02)
    return {"rough-od|force_N": {"posterior": {}, "provenance": provenance_json(provenance)}}


def test_a_large_fleet_is_named_ten_at_a_time_and_counted_whole():
    stored = _stored()["rough-od|force_N"]["provenance"]
    assert stored["plans"] == list(PLANS[:MAX_NAMED]) and stored["plans_total"] == 320
    assert stored["machines"] == list(MACHINES[:MAX_NAMED]) and stored["machines_total"] == 32
    assert "prior from 320 plans on 32 machines" in stored["text"]  # the whole fleet, told
    noise = NoisePrior("force_N", NoiseScale(4.0, 3.0), MACHINES, 540, 0.3)
    chain = noise_prior_json({"force_N": noise})["force_N"]["provenance"]
    assert chain["machines"] == list(MACHINES[:MAX_NAMED]) and chain["machines_total"] == 32
    answer = prior_answer(_stored(), noise_prior_json({"force_N": noise}))
    (line,) = answer["provenance"]["rough-od"]
    assert (line["plans_total"], line["machines_total"]) == (320, 32)
    assert len(json.dumps(answer)) < 1500  # 320 names a quantity were ~5 kB each


def test_a_prior_stored_with_every_name_is_answered_cut_and_counted():
    before = _stored()["rough-od|force_N"]["provenance"]
    before = {k: v for k, v in before.items() if not k.endswith("_total")}
    before |= {"plans": list(PLANS), "machines": list(MACHINES)}  # as stored until 2026-12-02
    answered = bounded(before)
    assert answered["plans"] == list(PLANS[:MAX_NAMED]) and answered["plans_total"] == 320
    assert answered["machines_total"] == 32
    scoped = bounded(before, names=False)
    assert scoped["plans"] is None and scoped["machines"] is None
    assert (scoped["plans_total"], scoped["machines_total"]) == (320, 32)


def test_the_reports_line_counts_all_quantities_and_says_at_least_where_cut():
    few = _stored(plans=("a", "b"), machines=("m1",))
    other = Provenance("roughness_um", ("b", "c"), ("m1", "m2"), 0.03, 10, 0.02)
    few["finish|roughness_um"] = {"posterior": {}, "provenance": provenance_json(other)}
    plan = {"prior": "fleet", "operations": [{"name": "rough-od"}, {"name": "finish"}]}
    line = prior_line({**plan, **prior_answer(few)})
    assert line.startswith("the fleet: 3 plans on 2 machines,")  # a, b, c on m1, m2
    scoped = prior_line({**plan, **prior_answer(few, names=False)})
    assert scoped.startswith("the fleet: at least 2 plans on at least 2 machines,")
    many = prior_line({**plan, **prior_answer(_stored())})
    assert many.startswith("the fleet: at least 320 plans on at least 32 machines,")
