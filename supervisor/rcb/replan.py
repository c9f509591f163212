"""An engineer's replan: changed limits, bounds or models, optionally fresh bands; re-optimised.

Changes, each keyed by a dotted name and checked like the plan file:

- ``limits``: ``{"OP.QUANTITY": value}`` sets an operation's limit (``null`` removes it);
- ``bounds``: ``{"OP.PARAM": [low, high]}`` sets a parameter's bounds;
- ``models``: ``{"TOOL.QUANTITY": {"K"?, "dK"?}}`` sets K and/or ΔK of that model in every
  operation using the tool (exponents stay; the band is the engineer's, not RCB's);
- ``rcb``: ``{"alpha": 0.3}`` changes RCB settings (:mod:`supervisor.rcb.settings`; the
  plan body's ``rcb`` table takes them too);
- ``reset_bands``: every operation's models go back to the tool's baseline (K and ΔK) and RCB
  forgets what it has seen, the rise per part of a worn edge and what it watched in the
  readings (:mod:`supervisor.rcb.monitor`), the ``learn`` strategy its
  posterior too, back to the prior it started from (Ivester & Heigel: the uncertainty is
  earned again, part by part); a fleet prior the machine let go stays let go.

The result is a new state (plan, models in force, setpoints); :mod:`api.services.plans` stores it
as a setpoint version with cause ``replan``.
"""

from __future__ import annotations

import copy
from collections.abc import Mapping
from dataclasses import dataclass, replace
from typing import Any

from models import fields
from models.errors import InputError, InputErrors
from models.tool import Tool
from supervisor.inputs.plan import plan_from_mapping
from supervisor.optimize.optimizer import optimize_plan
from supervisor.rcb.learning import restarted
from supervisor.rcb.settings import settings_from_table
from supervisor.rcb.start import learned_cones
from supervisor.rcb.state import RcbState, prior_sigma

_CHANGE_KEYS = ("limits", "bounds", "models", "reset_bands", "rcb")


@dataclass(frozen=True)
class Replanned:
    """The state after a replan and the plan structure it rests on."""

    state: RcbState
    body: dict[str, Any]
    reset_bands: bool


def replan_body(data: Mapping[str, Any]) -> dict[str, Any]:
    """JSON changes as :func:`replan` takes them: a ``null`` change is no change.

    Left out: a null ``limits``, ``bounds``, ``models``, ``reset_bands`` or ``rcb``, and a null
    setting of ``rcb`` or a null ``K``/``dK`` of a model change; a null limit stays (it removes
    the limit).
    """
    body: dict[str, Any] = fields.without_nulls(data)
    if "rcb" in body:
        body["rcb"] = fields.without_nulls(body["rcb"])
    if isinstance(body.get("models"), Mapping):
        body["models"] = {k: fields.without_nulls(v) for k, v in body["models"].items()}
    return body


def replan(
    state: RcbState,
    body: Mapping[str, Any],
    changes: Mapping[str, Any],
    library: Mapping[str, Tool] | None = None,
) -> Replanned:
    """Apply ``changes`` to the plan ``body`` and the models in force of ``state``; re-optimise.

    Raises
    ------
    InputError
        A change naming an unknown operation, quantity, parameter or tool, or a value the plan
        file would refuse (the field is named, e.g. ``limits.rough-od.force_N``).
    InfeasibleError
        No setpoint meets the changed limits.
    """
    table = fields.mapping(changes, "changes")
    fields.only_keys(table, _CHANGE_KEYS, "")
    if not any(table.get(k) for k in _CHANGE_KEYS):
        raise InputError("changes", dict(table), "nothing to change")
    new_body = changed_body(body, table)
    try:
        plan = plan_from_mapping(new_body, library)
    except InputError as err:  # a bad limit or bound is named as the change gave it
        raise _as_changed(err, new_body, table) from None
    settings = state.settings
    if table.get("rcb"):
        given = settings_from_table(table["rcb"])
        settings = replace(settings, **given)  # type: ignore[arg-type]
        new_body["rcb"] = {**new_body.get("rcb", {}), **given}
    reset = table.get("reset_bands", False)
    if not isinstance(reset, bool):
        raise InputError("reset_bands", reset, "must be true or false")
    tools = {
        op.name: (
            plan.tools[op.tool] if reset else _carried(state.tools[op.name], plan.tools[op.tool])
        )
        for op in plan.operations
    }
    for key, value in fields.mapping(table.get("models", {}), "models").items():
        tools = _set_model(tools, plan.operations, key, value)
        if not reset:
            _not_learned(state, plan.operations, key, value)
    kept = replace(state, plan=plan, tools=tools, settings=settings)
    if reset:
        kept = _forgotten(kept)
    # learn: what the posterior learned carries over (its cones), unless the bands are reset
    result = optimize_plan(plan, tools, cones=learned_cones(kept))
    new_state = replace(
        kept,
        setpoints=result,
        version=state.version + 1,
        halt=None,  # an engineer's replan resumes a halted plan
    )
    return Replanned(new_state, new_body, reset)


def changed_body(body: Mapping[str, Any], table: Mapping[str, Any]) -> dict[str, Any]:
    """``body`` with the ``limits`` and ``bounds`` of ``table`` set (a deep copy).

    Also what a stored plan refused by this version's check is read as by the replan that
    repairs it (:mod:`db.refused`).
    """
    new_body = copy.deepcopy(dict(body))
    # by name as the reader reads it (a stored body keeps the spelling it was sent with)
    ops = {fields.identity(op["name"]): op for op in new_body["operations"]}
    for key, value in fields.mapping(table.get("limits", {}), "limits").items():
        op, quantity = _split(key, "limits", ops)
        limits = ops[op].setdefault("limits", {})
        if value is None:
            limits.pop(quantity, None)
        else:
            limits[quantity] = value
    for key, value in fields.mapping(table.get("bounds", {}), "bounds").items():
        op, param = _split(key, "bounds", ops)
        ops[op].setdefault("bounds", {})[param] = value
    return new_body


def _as_changed(err: InputError, body: Mapping[str, Any], table: Mapping[str, Any]) -> InputError:
    """``err`` of the changed plan, its field named by the change that made it.

    The plan's reader names ``operations[0].limits.force_N``, a path the change
    (``{"limits": {"rough-od.force_N": -5}}``) does not have; a field no change touched (a
    stored plan this version's check refuses) keeps the plan's path.
    """
    index = {fields.identity(op["name"]): i for i, op in enumerate(body["operations"])}
    paths = {}
    for where in ("limits", "bounds"):
        for key in fields.mapping(table.get(where, {}), where):
            given, _, name = key.rpartition(".")
            paths[f"operations[{index[fields.identity(given)]}].{where}.{name}"] = f"{where}.{key}"

    def renamed(one: InputError) -> InputError:
        for path, change in paths.items():
            if one.field == path or one.field.startswith((path + ".", path + "[")):
                return InputError(change + one.field[len(path) :], one.value, one.reason)
        return one

    if isinstance(err, InputErrors):
        return InputErrors([renamed(e) for e in err.errors])
    return renamed(err)


def _forgotten(state: RcbState) -> RcbState:
    """``state`` with fresh bands: what RCB saw, the wear, monitors and posteriors forgotten.

    ``learn`` goes back to the priors it started from, a fleet prior the machine let go still
    let go (:func:`~supervisor.rcb.learning.restarted`), as a stored plan loads them.
    """
    sigma = {
        (op, q): prior_sigma(m, state.settings)
        for op, tool in state.tools.items()
        for q, m in tool.models.items()
    }
    priors = {key: restarted(p, state.posterior.get(key)) for key, p in state.priors.items()}
    return replace(
        state, sigma=sigma, seen={}, posterior=dict(priors), priors=priors, wear={}, monitors={}
    )


def _split(key: str, where: str, ops: Mapping[str, Any]) -> tuple[str, str]:
    given, sep, name = key.rpartition(".")
    if not sep or not given or not name:
        raise InputError(f"{where}.{key}", key, "must be OPERATION.NAME")
    try:
        op = fields.identity(given)
    except ValueError:
        op = given  # no name of an operation: unknown
    if op not in ops:
        raise InputError(f"{where}.{key}", given, f"unknown operation; known: {', '.join(ops)}")
    return op, name


def _carried(in_force: Tool, baseline: Tool) -> Tool:
    """The models in force, for the quantities the (possibly changed) tool still models."""
    return replace(
        baseline,
        models={q: in_force.models.get(q, m) for q, m in baseline.models.items()},
    )


def _not_learned(state: RcbState, operations: Any, key: str, value: object) -> None:
    """Refuse a model change that ``learn``'s readings would hide (kept bands only).

    Where a ``learn`` posterior holds readings, the setpoint follows what they taught (its
    cone, :mod:`supervisor.optimize.learned`), and the band only where it is the faster and
    the readings agree: a changed ``K`` or ``ΔK`` would be stored and change nothing.
    """
    tool_name, _, quantity = key.rpartition(".")
    readings = max(
        (
            belief.observations
            for op in operations
            if op.tool == tool_name
            and (belief := state.posterior.get((op.name, quantity))) is not None
        ),
        default=0,
    )
    if readings > 0:
        raise InputError(
            f"models.{key}",
            value,
            f"the plan learns: its {readings} readings govern this model, not K and dK; a limit"
            " still binds (limits), and reset_bands (rcb replan --reset-bands) starts learning"
            " again from the new model",
        )


def _set_model(
    tools: Mapping[str, Tool], operations: Any, key: str, value: object
) -> dict[str, Tool]:
    tool_name, sep, quantity = key.rpartition(".")
    where = f"models.{key}"
    users = [op.name for op in operations if op.tool == tool_name]
    if not sep or not users:
        raise InputError(where, tool_name, "not a tool of the plan's operations (TOOL.QUANTITY)")
    change = fields.mapping(value, where)
    fields.only_keys(change, ("K", "dK"), where)
    if not change:
        raise InputError(where, {}, "give K and/or dK")
    out = dict(tools)
    for name in users:
        model = tools[name].models.get(quantity)
        if model is None:
            raise InputError(where, quantity, f"tool {tool_name!r} has no such model")
        K = fields.number(change.get("K", model.K), f"{where}.K", positive=True)
        dK = fields.number(change.get("dK", model.dK), f"{where}.dK", minimum=0.0)
        models = {**tools[name].models, quantity: replace(model, K=K, dK=dK)}
        out[name] = replace(out[name], models=models)
    return out
