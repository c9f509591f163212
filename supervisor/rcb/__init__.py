"""Recursive Constraint Bounding: state, band law, strategies, the update and the replan.

``state`` (settings, decisions, halt, the state between parts), ``law`` (the one-sided band
law for one measurement), ``strategies`` (the registry of strategies, one class each),
``posterior`` (the ``learn`` strategy's Bayesian regression and cone), ``update`` (one part
report: bands, new setpoints or a halt), ``replan`` (an engineer's changes).
"""
