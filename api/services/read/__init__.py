"""The use cases that only read, by resource; each one read transaction, answers as JSON dicts.

- :mod:`~api.services.read.plans`: one plan (``get_plan``) and the list of plans.
- :mod:`~api.services.read.setpoints`: the setpoints in force (what the MES reads).
- :mod:`~api.services.read.plan_parts`: a plan's parts a page at a time, their RCB decisions.
- :mod:`~api.services.read.plan_models`: a plan's models in force and its model versions.
- :mod:`~api.services.read.tools`: one tool, and the list of tools.
- :mod:`~api.services.read.history`: the setpoint history a page at a time.
- :mod:`~api.services.read.record`: what a plan's report shows, in bounded reads.
- :mod:`~api.services.read.common`: what they share (a read session, pages, cursors).

The routes, commands and report import the module of their resource; the names below gather
them for callers that use several (the tests, the benchmarks).
"""

from api.services.read.common import LIST_PAGE as LIST_PAGE
from api.services.read.common import MAX_PAGE as MAX_PAGE
from api.services.read.history import HISTORY_PAGE as HISTORY_PAGE
from api.services.read.history import full_history as full_history
from api.services.read.history import plan_history as plan_history
from api.services.read.plan_models import model_versions as model_versions
from api.services.read.plan_models import models_in_force as models_in_force
from api.services.read.plan_parts import all_parts as all_parts
from api.services.read.plan_parts import decision_json as decision_json
from api.services.read.plan_parts import decisions as decisions
from api.services.read.plan_parts import part_json as part_json
from api.services.read.plan_parts import part_pages as part_pages
from api.services.read.plan_parts import parts as parts
from api.services.read.plans import get_plan as get_plan
from api.services.read.plans import list_plans as list_plans
from api.services.read.record import report_record as report_record
from api.services.read.setpoints import current_setpoints as current_setpoints
from api.services.read.tools import get_tool as get_tool
from api.services.read.tools import list_tools as list_tools
