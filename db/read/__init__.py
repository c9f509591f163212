"""What the read use cases read (:mod:`api.services.read`), by resource; nothing here writes.

- :mod:`db.read.plans`: a page of plan summaries; a plan's operations with their tools.
- :mod:`db.read.parts`: a plan's parts a page at a time, with measurements and decisions.
- :mod:`db.read.history`: setpoint versions a page at a time, who replanned, models in force.
- :mod:`db.read.record`: a report's totals and summaries as SQL aggregates.
"""
