"""The robust optimiser: one log-linear program per operation, solved by HiGHS or Clarabel.

``program`` (the program's data: rows, cone terms, bounds), ``formulation`` (building it over
the registry :data:`models.quantities.QUANTITIES`), ``highs_lp``, ``socp`` and
``productivity`` (the solvers: HiGHS, Clarabel, cvxpy's DGP for Borangiu's cost), ``learned``
(what a learned model's cone must offer), ``solve`` (an optimum, its re-check, binding rows,
the infeasibility diagnosis), ``grid`` (the optimum moved onto the machine's resolution grid),
``optimizer`` (operations and plans, the ``learn`` cones, Borangiu's (w, n) problem),
``result`` (frozen results), ``extras`` (what a setpoint carries beyond its parameters).
"""
