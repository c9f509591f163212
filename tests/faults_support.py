"""Helpers of the fault catalogue tests (tests/supervisor/test_faults.py, test_faults_loop.py):
the demonstration plan and the number of readings of one of its parts."""

from __future__ import annotations

from supervisor.inputs.plan import load_plan

from conftest import DEMO_PLAN

PLAN = load_plan(DEMO_PLAN)
#: Readings of a demo part: force and roughness of each of its six operations.
READINGS = 12
