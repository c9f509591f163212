"""Borangiu et al.'s milling domain (Eqs. 2-7), its (w, n) problem, and ``J`` as a GP.

- the constraints of Eqs. 2-7 as monomial limits, in the milling parameters or in Borangiu's
  own ``(w, n)``, are read by a plan: :mod:`models.borangiu_domain` (pure, like the cost).
- :mod:`~supervisor.borangiu.problem`: the ``(w, n)`` problem of one pass, from a domain file.
- :mod:`~supervisor.borangiu.result`: its two optima (largest feed rate, least ``J``) and
  Eq. 10's stationary point.
- the cvxpy DGP that minimises ``J`` is a solver of the optimiser's programs:
  :mod:`supervisor.optimize.productivity`.

The cost ``J`` itself (Eq. 1 with Taylor's tool life and Eq. 7's power) is pure physics, in
:mod:`models.borangiu_cost`.
"""
