"""A tool's learned models as a document that travels between databases (issue 32).

``rcb models export TOOL`` writes, and ``rcb models import FILE`` reads, a JSON document::

    {"format": "rcb-fleet-models/2", "tool": "CNMG432RN", "material": "AISI 1045",
     "learned": [{"origin": "6f1c…", "machine": ..., "plan": ..., "operation": {...}, "tool": {...},
                  "posterior": {...}, "start": {...} | null,
                  "coverage_k": 2.0, "exponent_sd": 0.15, "edge_sd": 0.1,
                  "chain": {"readings": 29.4, "excess": 31.0} | null}, ...]}

one item per operation and quantity a ``learn`` plan measured (:class:`~supervisor.fleet.prior.
Learned`): where it was learned, the operation's bounds and context and its catalogue tool (to
rebuild the prior its evidence is counted against), the posterior, and the fleet prior it
started from, and the operation's evidence on its measuring chain's noise (``chain``: readings'
worth and their excess squares, :mod:`supervisor.fleet.noise`; absent in documents written
before it, which then give no noise prior). ``origin`` names the database that learned the
model (:mod:`db.identity`; a model imported there keeps its own), so that an import counts
each model once however often it travels (:mod:`db.fleet_models`); version 1 documents have
none (read as ""). Nothing else of the database travels (no parts, no keys). Reading checks
every field and names the offending one (``learned[3].posterior.mean``).
"""

from __future__ import annotations

import math
import uuid
from collections.abc import Collection, Mapping, Sequence
from typing import Any

import numpy as np

from models import fields
from models.bounds import LARGEST, LARGEST_EXPONENT, LARGEST_WHOLE, MAX_IDENTITY
from models.errors import InputError
from models.kinematics import PARAMETERS, Process
from models.tool import process_of, tool_from_mapping, tool_mapping
from supervisor.fleet.evidence import LEAST_VARIANCE
from supervisor.fleet.learned import Learned, proper, start_of
from supervisor.fleet.posterior_fields import posterior_fields, readings_held, symmetric
from supervisor.inputs.plan import Operation
from supervisor.rcb.noise import NoiseScale
from supervisor.rcb.posterior import Posterior
from supervisor.rcb.posterior import from_json as posterior_from_json

FORMAT = "rcb-fleet-models/2"
#: The formats :func:`read_document` reads: version 1 is version 2 without ``origin``.
FORMATS = ("rcb-fleet-models/1", FORMAT)
#: The longest ``origin`` (a UUID's 36 characters).
MAX_ORIGIN = 36
#: The most items a document holds (about :data:`models.bounds.MAX_MODELS_BYTES` of them).
MAX_ITEMS = 25_000
#: The most machines a tool's imported models may be on in the fleet (those no engineer took
#: out), all imports together: a new plan's fleet prior reads each one's newest plans, about
#: 1.5 ms a model, so 1 150 machines (23 000 models, one 62 MB file) made every fleet prior
#: and ``rcb fleet law`` of the tool take 35 s (a year's plant, audited); 200 machines of 10
#: plans and 2 models, about 6 s. Several plants' exports of a tool hold far fewer.
MAX_IMPORTED_MACHINES = 200
_ITEM_KEYS = (
    "origin",
    "machine",
    "plan",
    "operation",
    "tool",
    "posterior",
    "start",
    "coverage_k",
    "exponent_sd",
    "edge_sd",
    "chain",
)
#: The largest ``|ln Y|`` at a posterior's centre, and ``|ln x|`` of its centre: a quantity or
#: an input within :data:`models.bounds.LARGEST`.
LN_LARGEST = math.log(LARGEST)
#: The largest variance in a posterior (of ``ln Y``, an exponent, the noise): a standard
#: deviation of :data:`models.bounds.LARGEST_EXPONENT`.
LARGEST_VARIANCE = LARGEST_EXPONENT**2
#: The most readings' worth a chain's evidence may claim in a document.
MAX_CHAIN_READINGS = 1e7


def document(tool: str, material: str, learned: Sequence[tuple[str, Learned]]) -> dict[str, Any]:
    """The document of ``learned``, each with its origin (module docstring)."""
    return {
        "format": FORMAT,
        "tool": tool,
        "material": material,
        "learned": [{"origin": origin, **item_json(item)} for origin, item in learned],
    }


def item_json(item: Learned) -> dict[str, Any]:
    """One learned model as the document holds it."""
    op = item.operation
    return {
        "machine": item.machine,
        "plan": item.plan,
        "operation": {
            "name": op.name,
            "process": op.process,
            "volume_mm3": op.volume_mm3,
            "limits": dict(op.limits),
            "bounds": {k: list(v) for k, v in op.bounds.items()},
            "context": dict(op.context),
        },
        "tool": tool_mapping(item.tool),
        "posterior": item.posterior.to_json(),
        "start": None if item.start is None else item.start.to_json(),
        "coverage_k": item.coverage_k,
        "exponent_sd": item.exponent_sd,
        "edge_sd": item.edge_sd,
        "chain": None if item.chain is None else _chain_json(item.chain),
    }


def _chain_json(chain: NoiseScale) -> dict[str, float]:
    """A chain's evidence as readings' worth and excess squares (beyond the default prior)."""
    return {"readings": chain.readings, "excess": chain.excess}


def _chain(data: object, path: str) -> NoiseScale | None:
    """:func:`_chain_json` read back; None for none."""
    if data is None:
        return None
    table = fields.mapping(data, path)
    fields.only_keys(table, ("readings", "excess"), path)
    readings = fields.number_within(table, "readings", path, low=0.0, high=MAX_CHAIN_READINGS)
    excess = fields.number_within(table, "excess", path, low=0.0, high=1e3 * MAX_CHAIN_READINGS)
    return NoiseScale.of_evidence(readings, excess)


def read_document(data: object, path: str = "document") -> tuple[str, list[tuple[str, Learned]]]:
    """The tool and the learned models of a document, each with its origin ("" for none).

    Refuses anything the document does not hold.
    """
    table = fields.mapping(data, path)
    fields.only_keys(table, ("format", "tool", "material", "learned"), path)
    if table.get("format") not in FORMATS:
        raise InputError(
            f"{path}.format", table.get("format"), f"must be one of {', '.join(FORMATS)}"
        )
    tool = fields.text(table, "tool", path)
    items = table.get("learned")
    if not isinstance(items, list) or len(items) > MAX_ITEMS:
        raise InputError(
            f"{path}.learned", type(items).__name__, f"must be a list of <= {MAX_ITEMS}"
        )
    version_1 = table.get("format") == FORMATS[0]
    return tool, [
        (_origin(item, f"{path}.learned[{i}]", version_1), read_item(item, f"{path}.learned[{i}]"))
        for i, item in enumerate(items)
    ]


def _origin(data: object, path: str, version_1: bool) -> str:
    """An item's ``origin``: required from version 2, absent from version 1."""
    table = fields.mapping(data, path)
    if version_1:
        if "origin" in table:
            raise InputError(f"{path}.origin", table["origin"], "version 1 documents have none")
        return ""
    origin = fields.text(table, "origin", path, most=MAX_ORIGIN)
    try:  # as rcb models identity names a database; one spelling of each
        return str(uuid.UUID(origin))
    except ValueError:
        raise InputError(
            f"{path}.origin", origin, "must be a database's identity, a UUID (rcb models identity)"
        ) from None


def read_item(data: object, path: str) -> Learned:
    """One learned model of a document (:func:`item_json`)."""
    table = fields.mapping(data, path)
    fields.only_keys(table, _ITEM_KEYS, path)
    tool = tool_from_mapping(table.get("tool"), f"{path}.tool")
    posterior = _posterior(table.get("posterior"), f"{path}.posterior")
    start = table.get("start")
    if posterior.quantity not in tool.models:
        raise InputError(
            f"{path}.posterior.quantity", posterior.quantity, "not a model of the tool"
        )
    inputs = tool.models[posterior.quantity].exponents
    for name in (*posterior.names, *posterior.context_exponents):
        if name not in inputs:
            raise InputError(f"{path}.posterior.names", name, "not an input of the tool's model")
    operation = _operation(table.get("operation"), tool.name, f"{path}.operation")
    _operation_fits(operation, tool.process, inputs, f"{path}.operation")
    item = Learned(
        _name(table, "machine", path),
        _name(table, "plan", path),
        operation,
        tool,
        posterior,
        fields.number(table.get("coverage_k"), f"{path}.coverage_k", positive=True),
        fields.number(table.get("exponent_sd"), f"{path}.exponent_sd", minimum=0.0),
        fields.number(table.get("edge_sd"), f"{path}.edge_sd", minimum=0.0),
        None if start is None else _posterior(start, f"{path}.start"),
        _chain(table.get("chain"), f"{path}.chain"),
    )
    _posed(item, path)
    return item


def _posed(item: Learned, path: str) -> None:
    """``item``'s belief, and the one it started from, each :func:`~.learned.proper`.

    Stored, an item that is not would add nothing to a fleet prior (its evidence is not made),
    yet be counted and listed as if it did: a ``dK`` of 1e-9 of K, say, hand-written. A start
    that knows a parameter exactly (``exponent_sd = 0``, a plan's setting) is let in, as a
    plan here with it is: that model adds nothing, the plan's others do.
    """
    quantity = item.posterior.quantity
    if not proper(item.posterior):
        raise InputError(f"{path}.posterior.cov", None, _NOT_PROPER)
    start = start_of(item, quantity)
    if proper(start) or min(start.cov[i][i] for i in range(len(start.cov))) <= 0.0:
        return
    if item.start is not None:
        raise InputError(f"{path}.start.cov", None, _NOT_PROPER)
    model = item.tool.models[quantity]
    raise InputError(
        f"{path}.tool.models.{quantity}",
        {"K": model.K, "dK": model.dK},
        f"the prior it makes over the operation's bounds (dK, exponent_stderr) {_NOT_PROPER}",
    )


_NOT_PROPER = (
    f"knows the law (nearly) exactly, a variance under {LEAST_VARIANCE:g}: no evidence can "
    "be made of its readings"
)


def _operation_fits(
    operation: Operation, process: Process, inputs: Collection[str], path: str
) -> None:
    """The operation is of the tool's process and bounds each of its parameters the model uses.

    The prior its plan started from is rebuilt over those bounds
    (:func:`supervisor.rcb.posterior.prior`): a document whose operation lacked one was
    stored, and every later fleet prior of the tool failed (``rcb plans create``: a
    ``KeyError`` traceback; another process: every new plan with the tool refused).
    """
    if operation.process != process:
        raise InputError(f"{path}.process", operation.process, f"the tool's process is {process}")
    for name in PARAMETERS[process]:
        if name in inputs and name not in operation.bounds:
            raise InputError(
                f"{path}.bounds.{name}", None, "missing: the model's parameter needs its bounds"
            )


def _posterior(data: object, path: str) -> Posterior:
    """A posterior whose mean and covariance are finite and of matching sizes."""
    table = fields.mapping(data, path)
    seen = table.get("observations", 0)  # its readings, as a provenance counts them
    if isinstance(seen, bool) or not isinstance(seen, int) or not 0 <= seen <= LARGEST_WHOLE:
        raise InputError(
            f"{path}.observations", seen, f"must be a whole number in 0..{LARGEST_WHOLE}"
        )
    posterior_fields(table, path)
    try:
        belief = posterior_from_json(table)
    except (KeyError, TypeError, ValueError, AssertionError) as err:
        raise InputError(path, type(data).__name__, f"is not a posterior ({err})") from None
    size = len(belief.mean)
    if size != 1 + len(belief.names) + (1 if belief.edge_max else 0) or any(
        len(row) != size for row in belief.cov
    ):
        raise InputError(f"{path}.cov", size, "sizes of mean and cov do not match its names")
    if not all(math.isfinite(v) for v in (*belief.mean, *(x for r in belief.cov for x in r))):
        raise InputError(f"{path}.mean", "non-finite", "mean and cov must be finite numbers")
    most = f"{LARGEST_VARIANCE:g}"
    if not (math.isfinite(belief.noise_scale2) and 0 < belief.noise_scale2 <= LARGEST_VARIANCE):
        raise InputError(
            f"{path}.noise_scale2", belief.noise_scale2, f"must be a number > 0 and <= {most}"
        )
    if not (
        math.isfinite(belief.prior_widening) and 0 <= belief.prior_widening <= LARGEST_VARIANCE
    ):
        raise InputError(
            f"{path}.prior_widening", belief.prior_widening, f"must be a number >= 0 and <= {most}"
        )
    _within_bounds(belief, path)
    readings_held(belief, path)
    return belief


def _within_bounds(belief: Posterior, path: str) -> None:
    """Every number of ``belief`` as a learned model can hold it, the covariance a covariance.

    ``ln Y`` at the centre within ±ln 1e12 (:data:`models.bounds.LARGEST`, as a quantity's
    input), the exponents, the edge's rise and their standard deviations within
    :data:`models.bounds.LARGEST_EXPONENT` (the noise and the widening: :func:`_posterior`),
    and ``cov`` symmetric positive definite: a
    document with a mean of 1e300 or a negative variance was stored, and every later fleet
    prior of the tool overflowed (``rcb plans create``: a traceback).
    """
    for i, centre in enumerate(belief.center):
        fields.number(centre, f"{path}.center[{i}]", largest=LN_LARGEST)
    for name, exponent in belief.context_exponents.items():
        fields.number(exponent, f"{path}.context_exponents.{name}", largest=LARGEST_EXPONENT)
    for i, value in enumerate(belief.mean):
        fields.number(
            value, f"{path}.mean[{i}]", largest=LN_LARGEST if i == 0 else LARGEST_EXPONENT
        )
    for i, row in enumerate(belief.cov):
        fields.number(row[i], f"{path}.cov[{i}][{i}]", positive=True, largest=LARGEST_VARIANCE)
    cov = np.array(belief.cov)
    symmetric(cov, f"{path}.cov", "a covariance")
    least = float(np.linalg.eigvalsh(cov).min())
    if least <= 0:
        raise InputError(
            f"{path}.cov",
            f"{len(cov)}x{len(cov)}, smallest eigenvalue {least:.3g}",
            "must be positive definite: a covariance",
        )


def _operation(data: object, tool: str, path: str) -> Operation:
    table = fields.mapping(data, path)
    fields.only_keys(table, ("name", "process", "volume_mm3", "limits", "bounds", "context"), path)
    bounds = fields.mapping(table.get("bounds", {}), f"{path}.bounds")
    return Operation(
        name=_name(table, "name", path),
        process=process_of(table.get("process"), f"{path}.process"),
        tool=tool,
        volume_mm3=fields.number(table.get("volume_mm3"), f"{path}.volume_mm3", positive=True),
        limits=_numbers(table.get("limits", {}), f"{path}.limits", positive=True),
        bounds={str(k): _bound(v, f"{path}.bounds.{k}") for k, v in bounds.items()},
        context=_numbers(table.get("context", {}), f"{path}.context"),
    )


def _name(table: Mapping[str, Any], key: str, path: str) -> str:
    """A machine's, plan's or operation's name, refused as a plan file's would be.

    At most :data:`~models.bounds.MAX_IDENTITY` characters, none a terminal would not show as
    written (:func:`models.fields.identity`): the fleet's listings print it.
    """
    value = fields.text(table, key, path, most=MAX_IDENTITY)
    try:
        return fields.identity(value)
    except ValueError as err:
        raise InputError(f"{path}.{key}", value, str(err)) from None


def _numbers(data: object, path: str, positive: bool = False) -> dict[str, float]:
    table = fields.mapping(data, path)
    return {str(k): fields.number(v, f"{path}.{k}", positive=positive) for k, v in table.items()}


def _bound(data: object, path: str) -> tuple[float, float]:
    """An operation's ``[low, high]`` bound of one cutting parameter."""
    if not isinstance(data, list) or len(data) != 2:
        raise InputError(path, data, "must be [low, high]")
    low, high = (fields.number(v, f"{path}[{i}]", positive=True) for i, v in enumerate(data))
    if low > high:
        raise InputError(path, data, f"low {low:g} is above high {high:g}")
    return low, high
