"""``rcb gcode`` counts a word as changed only where its text changes (new-user review, item 3).

The demonstration program's finish-od block holds ``S190`` and the plan's finish-od speed is
190 m/min: it printed ``S190 → S190`` and ``6 words changed`` where 5 differ. A word whose
text the setpoint leaves as it is is neither rewritten, listed nor counted
(``supervisor/gcode/rewrite.py``, ``_edit``).
"""

from __future__ import annotations

import json

from gcode_support import cli_args, store_demo_plan

from conftest import invoke


def test_a_word_that_keeps_its_text_is_not_counted_as_changed(runner, tmp_path_factory):
    url, plan_id, _ = store_demo_plan(tmp_path_factory)
    out = tmp_path_factory.mktemp("out") / "OUT.nc"
    done = invoke(runner, "gcode", *cli_args(url, plan_id, out, "--json"))
    assert done.exit_code == 0, done.stderr
    result = json.loads(done.stdout)
    assert result["changes_truncated"] == 0  # every change listed: the count can be checked
    differ = [c for c in result["changes"] if c["old"] != c["new"]]
    assert len(differ) == 5  # S187, F0.25, F0.3, F0.25 (rough-od); F.1 (finish-od)
    assert result["changes_total"] == len(result["changes"]) == len(differ)
    by_operation = {op["name"]: op["words_changed"] for op in result["operations"]}
    assert by_operation == {"rough-od": 4, "finish-od": 1}
    assert "(5 words changed)" in done.stderr
