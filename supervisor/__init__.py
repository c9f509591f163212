"""Decisions as pure functions on frozen objects, one folder per idea.

- ``inputs/``: process plans, part reports and raw spindle signals, read and checked;
- ``optimize/``: the robust optimiser, each operation's log-linear program (built over the
  registry of constrained quantities, :mod:`models.quantities`) solved by HiGHS or Clarabel;
- ``rcb/``: Recursive Constraint Bounding: state, band law, strategies registry, update, replan;
- ``borangiu/``: Borangiu et al.'s milling domain and productivity cost;
- ``virtual/``: virtual machines (true processes, parts, sensors), the demo, the certificate,
  and the virtual mill;
- ``constant_load/``: Tai et al.'s constant-load milling setup and tool-change rule;
- ``gcode/``: rewriting a lathe program's F and S words with the setpoints;
- ``errors``: the exceptions every folder raises.
"""
