"""Decisions as pure functions on frozen objects: plans, the robust optimiser."""
