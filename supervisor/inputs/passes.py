"""Stock removed in whole passes: an operation's ``stock_mm`` and its optional finishing pass.

An operation may give the stock to remove, ``stock_mm`` (turning: radially, in the direction
of ``depth_mm``; milling: axially, in the direction of ``axial_depth_mm``), instead of letting
the optimiser take any depth: it is then cut in a whole number of passes ``n``, each
``stock_mm / n`` deep (:mod:`supervisor.optimize.passes`). An optional finishing pass,

.. code-block:: toml

    finish = { depth_mm = 0.5, limits = { roughness_um = 1.6 } }   # milling: axial_depth_mm

takes the last ``depth_mm`` of the stock under the operation's limits and its own (``limits``
here add to the operation's and override a limit of the same name, so a roughness limit may
hold on the last pass only); the ``n − 1`` roughing passes share the rest equally.

The depth bound of the process becomes optional: without it a roughing pass may be anything
from ``stock / MAX_PASSES`` to the whole roughing stock, and that range is written into the
operation's bounds; with it, some whole number of passes must fit in it.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Collection, Mapping
from dataclasses import dataclass
from typing import Any

from models import fields, quantities
from models.errors import InputError
from models.kinematics import Process

#: The most passes an operation may take; the search for the best count stops there.
MAX_PASSES = 1000
#: The cutting parameter a pass's depth is, per process: the direction of ``stock_mm``.
DEPTH: dict[Process, str] = {"turning": "depth_mm", "milling": "axial_depth_mm"}
#: A depth bound holds a pass depth this close to it (the stock divided by ``n`` in floats).
DEPTH_RTOL = 1e-9


@dataclass(frozen=True)
class FinishPass:
    """The last pass of a multi-pass operation, at its own depth and limits.

    Parameters
    ----------
    depth_mm : float
        Depth of the finishing pass (turning depth, milling axial depth) [mm].
    limits : Mapping[str, float]
        The limits of the finishing pass: the operation's, with these added or overriding.
    """

    depth_mm: float
    limits: Mapping[str, float]


@dataclass(frozen=True)
class PassSpec:
    """How an operation's stock is removed: ``stock_mm`` in whole passes, maybe a finish."""

    stock_mm: float
    finish: FinishPass | None = None

    @property
    def roughing_stock_mm(self) -> float:
        """The stock the equal (roughing) passes share [mm]."""
        return self.stock_mm - (0.0 if self.finish is None else self.finish.depth_mm)


def pass_spec(
    table: Mapping[str, Any],
    path: str,
    process: Process,
    limits: Mapping[str, float],
    check_limits: Callable[[object, str], dict[str, float]],
    models: Collection[str],
) -> PassSpec | None:
    """``stock_mm`` and ``finish`` of an operation's table (None: neither given).

    ``limits`` are the operation's (checked); ``check_limits(data, path)`` checks a limits
    table as the plan reader does; ``models``: the quantities the tool has models of.
    """
    if "stock_mm" not in table:
        if "finish" in table:
            raise InputError(f"{path}.finish", table["finish"], "a finishing pass needs stock_mm")
        return None
    stock = fields.number(table["stock_mm"], f"{path}.stock_mm", positive=True)
    if table.get("objective", "mrr") != "mrr":
        raise InputError(
            f"{path}.stock_mm", stock, "passes minimise the time: only with objective = 'mrr'"
        )
    if "finish" not in table:
        return PassSpec(stock)
    where = f"{path}.finish"
    data = fields.mapping(table["finish"], where)
    depth = DEPTH[process]
    fields.only_keys(data, (depth, "limits"), where)
    if depth not in data:
        raise InputError(f"{where}.{depth}", None, "required: the finishing pass's depth")
    finish_depth = fields.number(data[depth], f"{where}.{depth}", positive=True)
    if finish_depth >= stock:
        raise InputError(
            f"{where}.{depth}", finish_depth, f"must be less than stock_mm = {stock:g}"
        )
    own = check_limits(data.get("limits", {}), f"{where}.limits")
    for key, value in own.items():  # power, torque ... scale a model the tool must have
        base = quantities.limited_by(key).based_on
        if base is not None and base not in models:
            raise InputError(f"{where}.limits.{key}", value, f"the tool has no {base} model")
    return PassSpec(stock, FinishPass(finish_depth, {**limits, **own}))


def with_depth_bound(data: object, path: str, process: Process, spec: PassSpec | None) -> object:
    """The bounds table, with the depth bound a multi-pass operation may leave out.

    Refuses a stock that no whole number of passes up to :data:`MAX_PASSES` cuts within a
    given depth bound, naming ``stock_mm``.
    """
    if spec is None or not isinstance(data, Mapping):
        return data
    depth = DEPTH[process]
    stock = spec.roughing_stock_mm
    where = f"{path.removesuffix('.bounds')}.stock_mm"
    if depth not in data:
        return {**data, depth: [stock / MAX_PASSES, stock]}
    pair = data[depth]
    if not isinstance(pair, list | tuple) or len(pair) != 2:
        return data  # the bounds reader names it
    low = fields.number(pair[0], f"{path}.{depth}[0]", positive=True)
    high = fields.number(pair[1], f"{path}.{depth}[1]", positive=True)
    fewest = max(1, math.ceil(stock / high * (1 - DEPTH_RTOL)))
    if fewest > MAX_PASSES:
        raise InputError(
            where, spec.stock_mm, f"needs more than {MAX_PASSES} passes of at most {high:g} mm"
        )
    if stock / fewest < low * (1 - DEPTH_RTOL):
        raise InputError(
            where,
            spec.stock_mm,
            f"no whole number of passes cuts {stock:g} mm at a depth within "
            f"{path}.{depth} = [{low:g}, {high:g}]",
        )
    return data
