"""Recursive Constraint Bounding: the state, the update law, its strategies and the replan."""
