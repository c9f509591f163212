"""The ``rcb`` command line (Typer): the app, one module per command or group, their output.

``main`` (the app, one-line usage errors, every command registered), ``common`` (the error
contract and exit codes, shared options, JSON output, atomic files), the commands:
``optimize`` (``predict``, ``optimize``), ``demo``, ``certify``, ``fit`` (with ``fit_data``, the
CSV, and ``fit_tool``, the TOML tool it writes), ``gcode``, ``html_report`` (``rcb report``),
``review`` (``plans``, ``history``, ``parts``, ``export``, ``replan``), ``milling`` and
``domain`` (``rcb milling setup|domain``), ``admin`` (``db upgrade``, ``keys``, ``serve``); and
the rich tables they print: ``tables``, ``demo_view``, ``parts_view`` (``rcb parts`` page by
page). A command imports its heavy libraries (solvers, SQLAlchemy, pandas, matplotlib) in its
body, so ``rcb --help`` loads none of them; ``lazy`` is the group class that imports ``rcb
milling``'s commands only when that group runs.
"""
