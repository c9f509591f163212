"""Inputs: process plans, part reports and the TOML files they come in."""
