"""Virtual machines for demos, benchmarks and tests.

``machine`` (true processes compiled per operation, instrument uncertainties), ``sampling``
(drawing the truth inside the model bands; the oracle), ``simulate`` (making a part: true
values, measurements, wear, violations), ``sensing`` (a virtual spindle sensor), ``demo`` (the
paper's demonstration end to end), ``certify`` (a Monte Carlo certificate of a plan; its
largest size in ``sizes``, which imports nothing), ``mill/`` (the virtual milling machine and
its inner-loop controllers), and the fault catalogue of the closed loop: ``fault_spec`` (the
kinds and ``KIND:ARGS``), ``faults`` (what they do to a part), ``fault_oracle`` (the oracle of a
faulted truth), ``fault_log`` (what they did in a scenario).
"""
