"""Interfaces: the Typer CLI ``rcb`` (and, with the database issue, the REST service)."""
