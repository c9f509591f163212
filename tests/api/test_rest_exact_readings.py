"""Readings stated near exact, over REST: stored as reported, learned from as a chain can read.

An MES integrator's audit: ``force_N`` and ``roughness_um`` reported at their predictions
with ``uncertainty: 1e-9`` (the schema takes any ``u > 0``) made ``learn`` set setpoints past
the limits, then answer 500 on every later report of the plan (``LinAlgError`` in the
posterior's Cholesky factor), the part never stored. Through a real server on each database.
"""

from __future__ import annotations

from conftest import report_at

STATED = {"force_N": 1e-9, "roughness_um": 1e-9}


def test_near_exact_readings_are_stored_and_the_setpoints_stay_in_the_limits(server, plan):
    plan_id = plan["id"]
    with server.client("mes") as mes:
        for serial, fraction in (("E-1", 1.0), ("E-2", 1.01), ("E-3", 0.99)):
            setpoints = mes.get(f"/plans/{plan_id}/setpoints").json()
            body = report_at(serial, setpoints, STATED, fraction)
            key = {"Idempotency-Key": serial}
            made = mes.post(f"/plans/{plan_id}/parts", json=body, headers=key)
            assert made.status_code == 201, made.text
            after = mes.get(f"/plans/{plan_id}/setpoints").json()
            for op in after["operations"]:
                for quantity, predicted in op["predicted"].items():
                    if quantity in STATED:  # a power law's prediction, not a collapse to 0
                        assert predicted["value"] > 0.1 * _before(setpoints, op, quantity)
            stored = mes.get(f"/plans/{plan_id}/parts/{made.json()['part_id']}").json()
            force = stored["operations"][0]["measurements"]["force_N"]
            assert force["uncertainty"] == 1e-9  # stored as reported


def _before(setpoints, op, quantity):
    """The prediction of ``quantity`` in ``op`` before the report."""
    same = next(o for o in setpoints["operations"] if o["name"] == op["name"])
    return same["predicted"][quantity]["value"]
