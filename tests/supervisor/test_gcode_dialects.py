"""Which controls read what ``rcb gcode`` writes (issue 28; README "Dialects").

``rcb gcode`` rewrites the F and S words of a lathe program and keeps every other byte, so
its output is in its input's dialect: the samples here are Fanuc lathe programs (``G50 S``
spindle clamp, ``T0101`` tool and offset, X in diameter). LinuxCNC's ``rs274`` refuses them:
``G50`` is no LinuxCNC code, and ``T0101`` is tool 101 there. The golden files are what
``rcb gcode`` writes (``tests/supervisor/test_gcode.py::test_golden_files``).
"""

from __future__ import annotations

import pytest
from rs274_support import needs_rs274, rs274_rejects

from conftest import ROOT

DATA = ROOT / "tests" / "data" / "gcode"


@needs_rs274
@pytest.mark.parametrize("name", ["demo_g95_g96.golden.nc", "cycles.nc", "mixed.nc"])
def test_linuxcnc_rejects_the_fanuc_lathe_spindle_clamp(name, tmp_path):
    message = rs274_rejects((DATA / name).read_text(), tmp_path)
    assert message.splitlines()[0] == "Unknown g code used"
    assert "G50 S" in message.splitlines()[1]


@needs_rs274
def test_linuxcnc_reads_t0101_as_tool_101(tmp_path):
    message = rs274_rejects((DATA / "g94_g97.golden.nc").read_text(), tmp_path)
    assert message.splitlines() == ["Requested tool 101 not found in the tool table", "N10 T0101"]
