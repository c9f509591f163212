"""Inputs: process plans, part reports, raw spindle signals, and the TOML files they come in.

``plan`` (machine, tools, operations; limits keyed by the quantity registry), ``resolution``
(the step the machine's control takes each cutting parameter in), ``part_report``
(what the MES sends after a part), ``signals`` (spindle load or current → ``force_N``),
``files`` (reading TOML with errors naming the file).
"""
