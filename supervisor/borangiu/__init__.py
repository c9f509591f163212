"""Borangiu et al.'s milling domain (Eqs. 2-7) and productivity cost as a geometric program."""
