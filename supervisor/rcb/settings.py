"""The RCB settings of a plan, declared once: name, type, range, default and doc of each.

Every other form of a setting is derived from :data:`SETTINGS`: the checks of
:class:`supervisor.rcb.state.RcbSettings`, a plan file's ``[rcb]`` table
(:func:`settings_from_table`), ``rcb replan --rcb NAME=VALUE`` and ``rcb plans create --rcb``
(:func:`assignments`), the query parameters of ``POST /plans``, the REST schemas
(``RcbSettingsIn``, ``RcbSettingsOut``), the stored JSON of ``plans.settings``
(:func:`settings_json`) and the docs. A new setting is one :class:`Setting` here and its field
of :class:`~supervisor.rcb.state.RcbSettings`. Every error names the field and its value, in
one style (``alpha``: ``must be a number in (0, 1]``).

A ``[rcb]`` table of a plan file, e.g.::

    [rcb]
    strategy = "bayes"
    alpha = 0.3
    floors = { force_N = 50 }
"""

from __future__ import annotations

import importlib
import math
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass, field
from typing import Any, Literal

from models.errors import InputError
from models.misspelt import meant
from models.quantities import MODEL_QUANTITIES
from supervisor.rcb.strategies import DEFAULT_ALPHA, DEFAULT_STRATEGY, REGISTRY

# No NumPy here (rcb --help derives its --rcb help from SETTINGS): models.fields is imported
# where a value is checked, and the learn posterior's defaults are read from
# supervisor.rcb.posterior when asked (:meth:`Setting.default_value`).

#: A reading past its limit by more than this fraction of the limit halts the plan [-] (TMAC's
#: extreme limit, Heidenhain AFC's overload reaction).
DEFAULT_HALT_OVER = 0.25
#: The least ``coverage_k``: a catalogue band of ±ΔK is at least half its scatter's standard
#: deviation. Below it the prior's ln K variance ``((ΔK/K)/k)²`` was astronomically wide (at
#: ``k = 10⁻³`` a learn plan's first report overflowed: a 500 where the input was wrong).
COVERAGE_K_LOW = 0.5

#: ``number``: a float in a range; ``choice``: one of :attr:`Setting.choices`; ``floors``: a
#: table of numbers >= 0 keyed by model quantity.
Kind = Literal["number", "choice", "floors"]


@dataclass(frozen=True)
class Setting:
    """One RCB setting.

    Parameters
    ----------
    name : str
        The field of :class:`supervisor.rcb.state.RcbSettings`, the key of ``[rcb]`` and of
        the stored JSON, the name of the query parameter.
    doc : str
        One line for the REST schema, the CLI help and the docs.
    default : object
        The value a plan gets when it names none (None: the strategy's, for ``discrepancy``);
        a callable: read when asked (:meth:`default_value`).
    kind : {"number", "choice", "floors"}
        What the value is.
    low, high : float
        ``number``: the range, ``low < value <= high`` when :attr:`open_low`, else
        ``low <= value <= high``; ``floors``: each floor is at least ``low``.
    open_low : bool
        Whether ``low`` itself is refused.
    among : Mapping[str, object]
        ``choice``: the values allowed are its keys, read when checked (a registry, which a
        test or a plug-in may extend).
    """

    name: str
    doc: str
    default: object
    kind: Kind = "number"
    low: float = 0
    high: float = math.inf
    open_low: bool = False
    among: Mapping[str, object] = field(default_factory=dict)

    @property
    def choices(self) -> tuple[str, ...]:
        """``choice``: the values allowed, now."""
        return tuple(self.among)

    def default_value(self) -> object:
        """The default (a callable one called)."""
        return self.default() if callable(self.default) else self.default

    @property
    def interval(self) -> str:
        """The range as an interval, ``(0, 1]``."""
        return f"{'(' if self.open_low else '['}{self.low:g}, {self.high:g}]"

    def check(self, value: object, path: str) -> object:
        """``value`` checked (a number as float); an error names ``path`` and ``value``."""
        from models import fields

        if self.kind == "choice":
            if not isinstance(value, str) or value not in self.choices:
                raise InputError(path, value, f"expected one of: {', '.join(self.choices)}")
            return value
        if self.kind == "floors":
            table = fields.mapping(value, path)
            for quantity, floor in table.items():
                if quantity not in MODEL_QUANTITIES:
                    raise InputError(f"{path}.{quantity}", floor, "unknown quantity")
                if isinstance(floor, bool) or not isinstance(floor, int | float):
                    raise InputError(f"{path}.{quantity}", floor, "must be a number >= 0")
                if not (math.isfinite(floor) and floor >= self.low):
                    raise InputError(f"{path}.{quantity}", floor, "must be a number >= 0")
            return {str(q): float(v) for q, v in table.items()}
        if value is None and self.default is None:
            return None
        if isinstance(value, bool) or not isinstance(value, int | float):
            raise InputError(path, value, f"must be a number in {self.interval}")
        number = float(value)
        above_low = number > self.low if self.open_low else number >= self.low
        if not (math.isfinite(number) and above_low and number <= self.high):
            raise InputError(path, value, f"must be a number in {self.interval}")
        return number


def _posterior(name: str) -> Callable[[], float]:
    """A default of :mod:`supervisor.rcb.posterior`, read when asked."""

    def read() -> float:
        value: float = getattr(importlib.import_module("supervisor.rcb.posterior"), name)
        return value

    return read


#: Every RCB setting, in the order of :class:`supervisor.rcb.state.RcbSettings`.
SETTINGS: Mapping[str, Setting] = {
    s.name: s
    for s in (
        Setting("strategy", "RCB strategy", DEFAULT_STRATEGY, "choice", among=REGISTRY),
        Setting("alpha", "fraction of the margin", DEFAULT_ALPHA, low=0, high=1, open_low=True),
        Setting("floors", "least band per quantity; default: the u", {}, "floors", low=0),
        Setting("coverage_k", "the band as k σ", 2.0, low=COVERAGE_K_LOW, high=100),
        Setting("discrepancy", "τ; default: the strategy's", None, low=0, high=10),
        # at least 1: a cone narrower than 1 σ would sit nearer its limit than the setpoint's own
        # uncertainty (supervisor.optimize.optimizer.KEEP_Z_FLOOR)
        Setting("z", "learn: the cone's z", _posterior("DEFAULT_Z"), low=1, high=100),
        Setting(
            "exponent_sd", "learn: exponent prior sd", _posterior("DEFAULT_EXPONENT_SD"), high=10
        ),
        Setting(
            "edge_sd", "wear: prior sd of the rise per edge", _posterior("DEFAULT_EDGE_SD"), high=10
        ),
        Setting(
            "halt_over",
            "a reading past its limit by more than this fraction of it halts",
            DEFAULT_HALT_OVER,
            low=0,
            high=10,
            open_low=True,
        ),
    )
}


def checked(given: Mapping[str, object], path: str, sep: str = ".") -> dict[str, object]:
    """``given`` settings checked against :data:`SETTINGS` (unknown names refused).

    Errors name ``path`` + ``sep`` + the setting (``rcb.alpha``, ``--rcb alpha``; ``path``
    empty: ``alpha``).
    """
    from models import fields

    fields.only_keys(given, SETTINGS, path)
    prefix = f"{path}{sep}" if path else ""
    return {k: SETTINGS[k].check(v, f"{prefix}{k}") for k, v in given.items()}


def settings_from_table(data: object, path: str = "rcb") -> dict[str, object]:
    """A plan file's ``[rcb]`` table (absent: ``None``), checked: the settings it names."""
    from models import fields

    if data is None:
        return {}
    return checked(fields.mapping(data, path), path)


def assignments(items: Sequence[str], path: str) -> dict[str, object]:
    """Settings given as ``NAME=VALUE`` (``--rcb alpha=0.3``, ``--rcb floors.force_N=50``).

    A number is read as a float, ``strategy`` as its name, ``discrepancy=none`` as the
    strategy's default; each is then checked as :func:`checked` does, naming ``path NAME``.
    """
    given: dict[str, Any] = {}
    for item in items:
        name, sep, text = (part.strip() for part in item.partition("="))
        key, _, quantity = name.partition(".")
        setting = SETTINGS.get(key)
        known = ", ".join(n if n != "floors" else "floors.QUANTITY" for n in SETTINGS)
        if not sep:
            raise InputError(path, item, f"must be NAME=VALUE, NAME one of: {known}")
        if setting is None or (setting.kind == "floors") != bool(quantity):
            raise InputError(f"{path} {name}", text, _unknown(key, setting, known))
        if name in given or quantity in given.get(key, {}):
            raise InputError(path, item, f"{name} is given twice; give each setting once")
        value: object = text
        if setting.default is None and text.lower() == "none":
            value = None
        elif setting.kind != "choice":
            value = _float(text, f"{path} {name}")
        if quantity:
            given.setdefault(key, {})[quantity] = value
        else:
            given[name] = value
    return checked(given, path, " ")


def _unknown(key: str, setting: Setting | None, known: str) -> str:
    """Why ``NAME`` of a ``NAME=VALUE`` is no setting, with the close match if there is one."""
    if setting is None:
        close = meant(key, SETTINGS)
        hint = f" (did you mean {close!r}?)" if close is not None else ""
        return f"unknown setting {key!r}{hint}; one of: {known}"
    if setting.kind == "floors":
        return "give each floor as floors.QUANTITY=VALUE (floors.force_N=50)"
    return f"{key} is one setting: give it as {key}=VALUE, without .QUANTITY"


def _float(text: str, path: str) -> float:
    try:
        return float(text)
    except ValueError:
        raise InputError(path, text, "must be a number") from None


def settings_json(settings: object) -> dict[str, Any]:
    """Every setting of an :class:`~supervisor.rcb.state.RcbSettings` as ``plans.settings``.

    By name, in :data:`SETTINGS` order; ``floors`` a plain table.
    """
    out: dict[str, Any] = {}
    for name in SETTINGS:
        value = getattr(settings, name)
        out[name] = dict(value) if isinstance(value, Mapping) else value
    return out
