"""Monomials ``c · Π x_i^e_i``: the common form of every model and kinematic relation.

Every quantity the supervisor constrains is a monomial in the cutting parameters, so its
logarithm is linear in their logarithms (Ivester & Heigel, "Robust Optimization": the problem
"is then linearized through a logarithmic transformation").
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import dataclass, field

from models.errors import ModelDomainError


@dataclass(frozen=True)
class Monomial:
    """A positive coefficient times a product of powers of named variables.

    Parameters
    ----------
    coefficient : float
        Positive factor ``c`` [unit of the quantity].
    exponents : Mapping[str, float]
        Exponent ``e_i`` of each named variable.
    """

    coefficient: float
    exponents: Mapping[str, float] = field(default_factory=dict)

    def evaluate(self, point: Mapping[str, float]) -> float:
        """Value at ``point``; every variable must be present and positive."""
        value = self.coefficient
        for name, exponent in self.exponents.items():
            if name not in point:
                raise ModelDomainError(name, None, "value missing")
            x = point[name]
            if not x > 0 or not math.isfinite(x):
                raise ModelDomainError(name, x, "must be a positive finite number")
            try:
                value *= x**exponent
            except OverflowError:
                value = math.inf
        if not (math.isfinite(value) and value > 0):
            raise self._out_of_range(point)
        return value

    def _out_of_range(self, point: Mapping[str, float]) -> ModelDomainError:
        """Name the variable whose power moves the value furthest (in ln) out of float range."""
        terms = {n: abs(e * math.log(point[n])) for n, e in self.exponents.items()}
        if not terms:  # the coefficient alone (a subnormal K times a scale underflows to 0)
            return ModelDomainError("K", self.coefficient, "out of range of a float")
        name = max(terms, key=lambda n: terms[n])
        return ModelDomainError(name, point[name], "out of range: the model's value overflows")

    def fix(self, constants: Mapping[str, float]) -> Monomial:
        """Fold the variables named in ``constants`` into the coefficient."""
        fixed = {name: constants[name] for name in self.exponents if name in constants}
        coefficient = Monomial(self.coefficient, {n: self.exponents[n] for n in fixed}).evaluate(
            fixed
        )
        rest = {n: e for n, e in self.exponents.items() if n not in fixed}
        return Monomial(coefficient, rest)

    def __mul__(self, other: Monomial) -> Monomial:
        exponents = dict(self.exponents)
        for name, exponent in other.exponents.items():
            exponents[name] = exponents.get(name, 0.0) + exponent
        return Monomial(self.coefficient * other.coefficient, exponents)

    def scaled(self, factor: float) -> Monomial:
        """The same monomial with its coefficient multiplied by ``factor``."""
        return Monomial(self.coefficient * factor, self.exponents)
