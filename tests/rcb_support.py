"""Helpers of the RCB law tests (tests/supervisor/test_rcb.py, test_rcb_reports.py): the
demonstration plan's start under the paper's law and a part report made at a state's version."""

from __future__ import annotations

from supervisor.inputs.part_report import PartReport
from supervisor.inputs.plan import load_plan
from supervisor.rcb.state import RcbSettings
from supervisor.rcb.update import start

from conftest import DEMO_PLAN


def paper_start():
    """The demonstration plan's RCB start under the ivester strategy."""
    return start(load_plan(DEMO_PLAN), RcbSettings(strategy="ivester"))  # the paper's law


def _report(state, measurements, tool_wear=None, version=None):
    return PartReport("S-1", version or state.version, measurements, tool_wear or {})
