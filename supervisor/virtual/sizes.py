"""The most scenarios and parts per scenario a certificate runs (:mod:`supervisor.virtual.certify`).

Plain constants and no imports: ``rcb certify --help`` states them and reads them from here
without loading NumPy, SciPy and the solvers (README, "Speed").
"""

#: The most scenarios a certificate runs.
MAX_SCENARIOS = 100_000
#: The most parts per scenario.
MAX_PARTS = 1000
