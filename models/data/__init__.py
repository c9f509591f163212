"""Packaged data files: the built-in tool catalogue."""
