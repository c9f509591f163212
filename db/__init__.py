"""Persistence (SQLAlchemy 2.0): tables, engine and repositories arrive with the database issue."""
