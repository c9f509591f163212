"""A machine-limited quantity is its registry entry and its monomial (issue 31, item 1).

The entry here (a registry line of models/quantities.py) and its factor (a monomial of
models/kinematics.py) are all it takes: a plan file's ``[machine]`` table takes its limit, the
optimiser binds on it, the database stores it and the read side writes it out, and a REST app
built after the registration takes it in ``MachineIn``.
"""

from __future__ import annotations

import json
import subprocess
import sys
import textwrap
from pathlib import Path

import pytest
from numpy.testing import assert_allclose
from test_quantities import registered

from api.services import plans as use_cases
from api.services import read as queries
from models import quantities
from models.errors import InputError
from models.monomial import Monomial
from models.quantities import Quantity
from supervisor.inputs.plan import plan_from_mapping
from supervisor.optimize.optimizer import optimize_plan

from conftest import FINE, renamed, step1_plan


def cutting_speed_m_s_monomial(process: str) -> Monomial:
    """Cutting speed ``v / 60`` [m/s] with v [m/min] (what models/kinematics.py would hold)."""
    return Monomial(1.0 / 60.0, {"speed_m_min": 1.0})


#: The registry entry (what models/quantities.py would hold).
CUTTING_SPEED = Quantity(
    "cutting_speed_m_s", "m/s", "max", "cutting speed", "cutting speed",
    "derived", "max_cutting_speed_m_s", cutting_speed_m_s_monomial,
)  # fmt: skip


def _plan(**machine: float) -> dict:
    data = step1_plan(FINE)
    return {**data, "machine": {**data["machine"], **machine}}


def test_the_optimiser_binds_on_a_new_machine_limit():
    # without it the optimum runs at v = 200 m/min (test_optimizer.test_step1_row_r);
    # 3 m/s is 180 m/min
    with registered(CUTTING_SPEED):
        plan = plan_from_mapping(_plan(max_cutting_speed_m_s=3.0))
        assert plan.machine.limits()["cutting_speed_m_s"] == 3.0
        op = optimize_plan(plan).operations[0]
        assert "cutting_speed_m_s" in op.binding
        assert_allclose(op.setpoint["speed_m_min"], 180.0, rtol=1e-6)
        assert_allclose(op.predicted["cutting_speed_m_s"].value, 3.0, rtol=1e-6)
    with pytest.raises(InputError) as refused:  # unregistered: an unknown field, named
        plan_from_mapping(_plan(max_cutting_speed_m_s=3.0))
    assert refused.value.field == "machine.max_cutting_speed_m_s"


def test_a_bad_value_of_a_new_machine_limit_is_named():
    with registered(CUTTING_SPEED), pytest.raises(InputError) as refused:
        plan_from_mapping(_plan(max_cutting_speed_m_s=-3.0))
    assert refused.value.field == "machine.max_cutting_speed_m_s"
    assert "-3" in str(refused.value)


def test_the_database_stores_and_reads_a_new_machine_limit(engine):
    with registered(CUTTING_SPEED):
        body = renamed(_plan(max_cutting_speed_m_s=3.0, max_power_kW=22))
        created = use_cases.create_plan(engine=engine, body=body)
        plan = queries.get_plan(engine=engine, plan_id=created.body["id"])
        limits = plan["machine_limits"]
        assert list(limits) == [*quantities.machine_fields()]  # the registry's, in its order
    assert limits["max_cutting_speed_m_s"] == 3.0 and limits["max_power_kW"] == 22.0
    assert plan["body"]["machine"]["max_cutting_speed_m_s"] == 3.0


_REST = """
import json, sys
from fastapi.testclient import TestClient
from sqlalchemy.orm import Session
from models import quantities
sys.path[:0] = {tests!r}
from test_machine_limits_registry import CUTTING_SPEED, _plan
quantities.register(CUTTING_SPEED)
from api.rest.app import create_app
from db.api_keys import create_key
from db.engine import make_engine, upgrade
upgrade({url!r})
with Session(make_engine({url!r})) as session, session.begin():
    _, key = create_key(session=session, role="engineer")
client = TestClient(create_app({url!r}), headers={{"Authorization": f"Bearer {{key}}"}})
created = client.post("/api/v1/plans", json=_plan(max_cutting_speed_m_s=3.0))
read = client.get(f"/api/v1/plans/{{created.json()['id']}}").json()
schema = client.get("/api/v1/openapi.json").json()["components"]["schemas"]["MachineIn"]
print(json.dumps({{
    "fields": sorted(schema["properties"]),
    "binding": created.json()["operations"][0]["binding"],
    "limits": read["machine_limits"],
}}))
"""


def test_a_rest_app_built_after_the_registration_takes_it(tmp_path):
    url = f"sqlite:///{tmp_path / 'rcb.db'}"
    here = Path(__file__).parent
    tests = [str(here), str(here.parent)]  # this module's folder and the helpers' (conftest)
    program = _REST.format(url=url, tests=tests)
    done = subprocess.run(
        [sys.executable, "-c", textwrap.dedent(program)],
        capture_output=True, text=True, check=False, cwd=tmp_path,
    )  # fmt: skip
    assert done.returncode == 0, done.stderr
    answer = json.loads(done.stdout.splitlines()[-1])
    assert "max_cutting_speed_m_s" in answer["fields"]
    assert set(quantities.machine_fields()) < set(answer["fields"])
    assert "cutting_speed_m_s" in answer["binding"]
    assert answer["limits"]["max_cutting_speed_m_s"] == 3.0
