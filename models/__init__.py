"""Pure domain maths: power-law models with uncertainty bands, kinematics, the catalogue.

No I/O except reading this package's own data files; no cvxpy, SQLAlchemy or FastAPI.
"""
