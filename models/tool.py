"""Cutting tools (inserts, end mills) and the models that describe them."""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass, field
from typing import Any, Protocol, overload

from models import fields, kinematics
from models.bounds import LARGEST_EXPONENT
from models.errors import InputError
from models.kinematics import CONTEXT, PARAMETERS, PROCESSES, Process
from models.powerlaw import PowerLawModel, Prediction
from models.quantities import MODEL_QUANTITIES, QUANTITIES

_TOOL_KEYS = ("name", "process", "description", "material", "source", "models")
_MODEL_KEYS = ("K", "dK", "exponents", "source", "reference", "exponent_stderr")


@dataclass(frozen=True)
class Tool:
    """A cutting tool with its models, keyed by quantity name.

    Parameters
    ----------
    name : str
        Catalogue designation, e.g. ``CNMG432RN``.
    process : {"turning", "milling"}
        The process the tool and its models are for.
    models : Mapping[str, PowerLawModel]
        One model per predicted quantity (``force_N``, ``roughness_um``, ``tool_life_mm3`` ...).
    description, material, source : str
        Provenance: what the tool is, the work material the models hold for, where they come from.
    """

    name: str
    process: Process
    models: Mapping[str, PowerLawModel] = field(default_factory=dict)
    description: str = ""
    material: str = ""
    source: str = ""


def _at(path: str, key: str) -> str:
    return f"{path}.{key}" if path else key


def variables(process: Process) -> tuple[str, ...]:
    """Names a model of ``process`` may use as inputs: the parameters and the context."""
    return PARAMETERS[process] + CONTEXT[process]


def process_of(value: object, path: str) -> Process:
    """Check a process name."""
    for process in PROCESSES:
        if value == process:
            return process
    raise InputError(path, value, f"unknown process; expected one of: {', '.join(PROCESSES)}")


def model_from_mapping(
    quantity: str, data: object, process: Process, path: str, default_source: str = ""
) -> PowerLawModel:
    """Read one power-law model ``{K, dK, exponents, source?, reference?}``."""
    if quantity not in MODEL_QUANTITIES:
        known = ", ".join(MODEL_QUANTITIES)
        raise InputError(path, quantity, f"unknown model quantity; known: {known}")
    table = fields.mapping(data, path)
    fields.only_keys(table, _MODEL_KEYS, path)
    if "K" not in table:
        raise InputError(_at(path, "K"), None, "required field missing")
    exponents = fields.number_table(
        table.get("exponents", {}),
        _at(path, "exponents"),
        variables(process),
        largest=LARGEST_EXPONENT,
    )
    return PowerLawModel(
        quantity=quantity,
        K=fields.number(table["K"], _at(path, "K"), positive=True),
        dK=fields.number(table.get("dK", 0.0), _at(path, "dK"), minimum=0.0),
        exponents=exponents,
        source=fields.text(table, "source", path, default=default_source),
        reference=fields.text(table, "reference", path, default=""),
        exponent_stderr=_stderr(table.get("exponent_stderr", {}), exponents, path),
    )


def _stderr(data: object, exponents: Mapping[str, float], path: str) -> dict[str, float]:
    """A model's ``exponent_stderr``: a standard error >= 0 per exponent it names."""
    return fields.number_table(
        data,
        _at(path, "exponent_stderr"),
        tuple(exponents),
        minimum=0.0,
        largest=LARGEST_EXPONENT,
    )


class ModelFields(Protocol):
    """What a model's mapping shows: a :class:`PowerLawModel`, or a stored row of one."""

    @property
    def K(self) -> float:  # noqa: N802 (the papers' symbol)
        """Coefficient [unit of the quantity]."""
        ...

    @property
    def dK(self) -> float:  # noqa: N802
        """Half-width of the band on K [unit of the quantity]."""
        ...

    @property
    def exponents(self) -> Mapping[str, float]:
        """Exponent per input variable [-]."""
        ...

    @property
    def source(self) -> str:
        """Where the model comes from."""
        ...

    @property
    def reference(self) -> str:
        """The paper, table or dataset it cites."""
        ...


class ToolFields(Protocol):
    """What a tool's mapping shows besides its models: a :class:`Tool`, or its stored row."""

    @property
    def name(self) -> str:
        """Catalogue designation."""
        ...

    @property
    def process(self) -> str:
        """``turning`` or ``milling``."""
        ...

    @property
    def description(self) -> str:
        """What the tool is."""
        ...

    @property
    def material(self) -> str:
        """The work material its models hold for."""
        ...

    @property
    def source(self) -> str:
        """Where its models come from."""
        ...


def model_fields(model: ModelFields) -> dict[str, Any]:
    """A model's fields as :func:`model_from_mapping` reads them (a stored row's too)."""
    return {
        "K": model.K,
        "dK": model.dK,
        "exponents": dict(model.exponents),
        "source": model.source,
        "reference": model.reference,
    }


def model_mapping(model: PowerLawModel, stderr: bool = True) -> dict[str, Any]:
    """``model`` as :func:`model_from_mapping` reads it (``exponent_stderr`` when it has any)."""
    out = model_fields(model)
    if stderr and model.exponent_stderr:
        out["exponent_stderr"] = dict(model.exponent_stderr)
    return out


def tool_mapping(tool: Tool, stderr: bool = True) -> dict[str, Any]:
    """``tool`` as :func:`tool_from_mapping` reads it (a plan file's tool table)."""
    return fields_mapping(tool, {q: model_mapping(m, stderr) for q, m in tool.models.items()})


def fields_mapping(tool: ToolFields, models: Mapping[str, dict[str, Any]]) -> dict[str, Any]:
    """A tool's fields (a :class:`Tool`'s or its stored row's) with its models' mappings."""
    return {
        "name": tool.name,
        "process": tool.process,
        "description": tool.description,
        "material": tool.material,
        "source": tool.source,
        "models": dict(models),
    }


@overload
def tool_body(data: Mapping[str, Any]) -> dict[str, Any]: ...
@overload
def tool_body(data: object) -> object: ...
def tool_body(data: object) -> object:
    """A JSON tool with every ``null`` field of it and of its models left out.

    A null inside a model's ``exponents`` stays, for :func:`tool_from_mapping` to refuse.
    """
    tool = fields.without_nulls(data)
    if isinstance(tool, dict) and isinstance(tool.get("models"), Mapping):
        tool["models"] = {q: fields.without_nulls(m) for q, m in tool["models"].items()}
    return tool


def tool_from_mapping(data: object, path: str) -> Tool:
    """Read a tool ``{name, process, models: {quantity: model}, ...}`` as in a plan file."""
    table = fields.mapping(data, path)
    fields.only_keys(table, _TOOL_KEYS, path)
    name = fields.identity_field(table, "name", path)
    if "/" in name or name in (".", ".."):  # a client resolves ".." away, a server splits at /
        why = "a tool's name is a segment of its URL (/api/v1/tools/NAME): no '/', not . or .."
        raise InputError(_at(path, "name"), name, why)
    process = process_of(table.get("process"), _at(path, "process"))
    source = fields.text(table, "source", path, default="plan file")
    models_table: Mapping[str, Any] = fields.mapping(table.get("models", {}), _at(path, "models"))
    if not models_table:
        raise InputError(_at(path, "models"), {}, "a tool needs at least one model")
    models = {
        q: model_from_mapping(q, m, process, _at(path, f"models.{q}"), source)
        for q, m in models_table.items()
    }
    return Tool(
        name=name,
        process=process,
        models=models,
        description=fields.text(table, "description", path, default=""),
        material=fields.text(table, "material", path, default=""),
        source=source,
    )


def predict_all(
    tool: Tool,
    point: Mapping[str, float],
    rel_uncertainty: Mapping[str, float] | None = None,
) -> dict[str, Prediction]:
    """Every model of ``tool`` at ``point``, and the machine quantities that follow from them.

    Parameters
    ----------
    tool : Tool
        The tool whose models to evaluate.
    point : Mapping[str, float]
        The cutting parameters of the tool's process, and whichever context values are known
        (``workpiece_diameter_mm`` or ``tool_diameter_mm`` and ``flute_count``,
        ``flank_wear_mm``).
    rel_uncertainty : Mapping[str, float], optional
        Relative setpoint uncertainties ``Δx/x`` [-].

    Returns
    -------
    dict[str, Prediction]
        Model quantities, then every derived quantity of :data:`models.quantities.QUANTITIES`
        whose inputs are known: its factor times the prediction it is based on (band scaled
        alike), or the factor alone (exact kinematics: band 0). Today ``power_kW``
        (``F·v/60000``) when the tool has a force model; ``torque_Nm`` (``F·D/2000``),
        ``spindle_rpm`` and ``feed_rate_mm_min`` when the diameter (and flute count) is known.
    """
    process = tool.process
    predicted = {q: m.predict(point, rel_uncertainty) for q, m in tool.models.items()}
    parameters = set(kinematics.PARAMETERS[process])
    for derived in QUANTITIES.values():
        if derived.kind != "derived":
            continue
        base = None if derived.based_on is None else predicted.get(derived.based_on)
        if derived.based_on is not None and base is None:
            continue  # no model of what it scales
        factor = derived.factor_of(process)
        if not (factor.exponents.keys() - point.keys()) <= parameters:
            continue  # a context input (diameter, flute count) not known here
        value = factor.evaluate(point)
        if base is None:
            predicted[derived.name] = Prediction(value, 0.0)
        else:
            predicted[derived.name] = Prediction(base.value * value, base.band * value)
    return predicted
