r"""The rise of a quantity as an edge wears, learned from the current edge's readings.

Force, roughness and spindle current rise as an edge wears (Ivester & Heigel, Eq. 8: the tool
life ends each edge at the allowable flank wear). The band law of :mod:`supervisor.rcb.law`
shrinks a band by a fraction of the margin a part shows; a part made by a new edge shows a
margin the same edge no longer has ten parts later, so a law that shrinks on it crosses the
limit near the end of the edge (measured: ``ivester`` under a 5 % rise per edge life, 13
violations in 1000 scenarios x 30 parts). The law therefore takes its margin from the reading
*projected to the edge's last part* when the MES reports the edge's age (``edge_parts``) and the
operation has a ``parts_per_edge`` limit; how much the reading rises per part is learned here.

The model, per operation and wearing quantity: the reading of the ``n``-th part of an edge
(``n = 0`` for a new edge) is

.. math:: \ln y_n = \ln K + \sum_i e_i \ln x_i + w\,n + \varepsilon_n,
          \qquad \varepsilon_n \sim N(0, s_n^2), \quad s_n = \frac{u_n / k}{y_n}

with ``w`` the rise per part in ``ln y``. Two successive readings of one edge (ages
``n' > n``) observe

.. math:: d = \ln y_{n'} - \ln y_n - \sum_i e_i (\ln x'_i - \ln x_i) = w (n' - n) + \eta,
          \qquad \mathrm{Var}\,\eta = s_n^2 + s_{n'}^2 + \sum_i (s_e\, e_i\, \Delta\ln x_i)^2

where the last term is what an exponent wrong by its prior spread ``s_e`` (relative, the
``exponent_sd`` setting) makes of a change of setpoint. ``ln K`` cancels, so each edge may
start from its own value. The belief on ``w`` is normal, ``N(0, (s_w / n_max)^2)`` before any
reading (``s_w`` the ``edge_sd`` setting: the rise over an edge's life as one standard
deviation, ``n_max = parts_per_edge − 1``), and each difference updates it as a scalar Kalman
filter (a conjugate normal update, Gelman et al. §2.5):

.. math:: g = \frac{P\,\Delta n}{P\,\Delta n^2 + \mathrm{Var}\,\eta}, \qquad
          \hat w' = \hat w + g (d - \hat w\,\Delta n), \qquad P' = (1 - g\,\Delta n) P

Treating successive differences as independent overstates their noise (they share a reading),
so the belief is wider than the data alone would give: conservative. A reading at age ``n`` is
projected to the edge's last part with the upper bound of the rise,

.. math:: y^{\uparrow} = y\, \exp\!\big(\max(\hat w + k\sqrt{P},\, 0)\,(n_{max} - n)\big)

(``k`` the ``coverage_k`` setting, 2: a one-sided 97.7 % bound). The projection only ever
lowers a margin: it never raises a flag or grows a band by itself, since it is a forecast, not
a reading (a reading past the band still does both). A report without ``edge_parts``, or an
operation without a ``parts_per_edge`` limit, is not projected (the paper's law as it stands),
and breaks the chain of differences.

References
----------
.. [1] Ivester & Heigel (NIST), Smart Machining Systems: Eq. 8 (tool life to the allowable
   flank wear) and "Adaptive Control Optimization" (the margin law).
.. [2] Gelman et al., Bayesian Data Analysis, 3rd ed., §2.5 (normal mean, known variance).
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import dataclass, replace
from typing import Any

from supervisor.inputs.part_report import Measurement


@dataclass(frozen=True)
class Reading:
    """The last reading of the current edge: its age, ``ln y``, ``s`` and ``ln x``."""

    age: int
    ln_y: float
    noise: float
    ln_x: Mapping[str, float]


@dataclass(frozen=True)
class WearRise:
    """Belief ``N(mean, var)`` on ``w``, the rise of ``ln y`` per part an edge makes.

    Parameters
    ----------
    mean, var : float
        ``ŵ`` and ``P`` [1/part, 1/part²].
    edge_max : int
        ``n_max``, the age of an edge's last part (``parts_per_edge − 1``).
    differences : int
        The differences learned from so far.
    last : Reading or None
        The current edge's last reading; None before the first or after one of unknown age.
    """

    mean: float
    var: float
    edge_max: int
    differences: int = 0
    last: Reading | None = None

    def upper(self, coverage_k: float) -> float:
        """``max(ŵ + k √P, 0)``: the rise per part the projection assumes."""
        return max(self.mean + coverage_k * math.sqrt(max(self.var, 0.0)), 0.0)

    def factor(self, age: int | None, coverage_k: float) -> float:
        """``y↑ / y`` for a reading at ``age`` (1 when the age is not known)."""
        if age is None:
            return 1.0
        return math.exp(self.upper(coverage_k) * max(self.edge_max - age, 0))

    def to_json(self) -> dict[str, Any]:
        """A JSON-ready mapping (:func:`from_json` reads it back)."""
        last = None
        if self.last is not None:
            last = {
                "age": self.last.age,
                "ln_y": self.last.ln_y,
                "noise": self.last.noise,
                "ln_x": dict(self.last.ln_x),
            }
        return {
            "mean": self.mean,
            "var": self.var,
            "edge_max": self.edge_max,
            "differences": self.differences,
            "last": last,
        }


def from_json(data: Mapping[str, Any]) -> WearRise:
    """The :class:`WearRise` of :meth:`WearRise.to_json`."""
    last = data.get("last")
    reading = None
    if last is not None:
        ln_x = {str(k): float(v) for k, v in last["ln_x"].items()}
        reading = Reading(int(last["age"]), float(last["ln_y"]), float(last["noise"]), ln_x)
    return WearRise(
        float(data["mean"]),
        float(data["var"]),
        int(data["edge_max"]),
        int(data.get("differences", 0)),
        reading,
    )


def setpoint_shift(
    before: Mapping[str, float],
    after: Mapping[str, float],
    exponents: Mapping[str, float],
    exponent_sd: float,
) -> tuple[float, float]:
    """``Σ e_i Δln x_i`` from ``before`` to ``after`` (``ln x`` by name), and its variance.

    The variance is what exponents wrong by their prior spread ``s_e`` (relative) make of the
    change, ``Σ (s_e e_i Δln x_i)²`` (module docstring); names of ``after`` missing from
    ``before``, or without an exponent, do not move.
    """
    moved = {n: after[n] - before[n] for n in after if n in before}
    shift = sum(exponents.get(n, 0.0) * dx for n, dx in moved.items())
    misfit = sum((exponent_sd * exponents.get(n, 0.0) * dx) ** 2 for n, dx in moved.items())
    return shift, misfit


def prior(edge_max: int, edge_sd: float) -> WearRise:
    """``N(0, (s_w / n_max)²)``: a rise of ``s_w`` over an edge's life as one σ."""
    return WearRise(0.0, (edge_sd / max(edge_max, 1)) ** 2, edge_max)


def observe(
    belief: WearRise,
    age: int | None,
    measurement: Measurement,
    point: Mapping[str, float],
    exponents: Mapping[str, float],
    coverage_k: float,
    exponent_sd: float,
) -> WearRise:
    """The belief after a reading at ``age`` and ``point`` (module docstring).

    ``exponents`` are the model's, by input name; an input of ``point`` without an exponent
    does not enter ``d``. A reading of unknown age, or not above 0, breaks the chain.
    """
    y, u = measurement.value, measurement.uncertainty
    if age is None or not (y > 0 and math.isfinite(y)):
        return replace(belief, last=None)
    noise = (u / coverage_k) / y
    ln_x = {name: math.log(value) for name, value in point.items() if value > 0}
    reading = Reading(age, math.log(y), noise, ln_x)
    last = belief.last
    if last is None or age <= last.age or set(last.ln_x) != set(ln_x):
        return replace(belief, last=reading)  # a new edge (or the first reading)
    steps = age - last.age
    shift, misfit = setpoint_shift(last.ln_x, ln_x, exponents, exponent_sd)
    d = reading.ln_y - last.ln_y - shift
    eta_var = noise**2 + last.noise**2 + misfit
    gain = belief.var * steps / (belief.var * steps**2 + eta_var)
    mean = belief.mean + gain * (d - belief.mean * steps)
    var = (1.0 - gain * steps) * belief.var
    return WearRise(mean, var, belief.edge_max, belief.differences + 1, reading)
