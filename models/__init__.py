"""Pure domain maths: power-law models with uncertainty bands, fitting, sensors, paper data.

- :mod:`~models.powerlaw`, :mod:`~models.monomial`: the power law ``Y = K · Π x_i^e_i`` with its
  band ``±ΔK`` (Ivester & Heigel Eqs. 5, 6, 8), and monomials of the cutting parameters.
- :mod:`~models.fit`, :mod:`~models.fit_points`, :mod:`~models.fit_band`,
  :mod:`~models.fit_design`: fitting a power law to test data (its points checked and in
  logs), its band, and the checks of the data.
- :mod:`~models.kinematics`, :mod:`~models.quantities`, :mod:`~models.tool`: turning and
  milling kinematics, the constrained quantities, a tool with its models.
- :mod:`~models.milling_force`: Kim & Jeon's milling force (Eq. 1), or a power law.
- :mod:`~models.borangiu_cost`: Borangiu's productivity cost ``J`` (Eq. 1) as a posynomial.
- :mod:`~models.sensors`: spindle load or current → force, current ↔ feed rate and wear.
- :mod:`~models.catalogue` and :mod:`~models.data`: the built-in tools and the paper tables,
  as packaged data files.
- :mod:`~models.fields` and :mod:`~models.errors`: checked numbers and names, and the errors.

No I/O except reading this package's own data files; no cvxpy, SQLAlchemy or FastAPI.
"""
