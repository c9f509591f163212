"""What one request or command may ask for at most, and what it gets when it does not say.

Plain constants and no imports: the CLI's help states them (``rcb plans --limit``, ``rcb keys
list --limit``, ``rcb report --last``, ``rcb db prune``) and reads them from here without
loading SQLAlchemy, so that ``rcb --help`` starts in a fraction of a second (README, "Speed").
The use cases that enforce them (:mod:`api.services.read.common`, :mod:`api.services.keys`,
:mod:`api.services.read.record`, :mod:`api.services.retention`) take them from here.
"""

#: Most parts (or setpoint versions) one page may hold.
READ_PAGE = 500
#: Largest page of ``rcb keys list``.
KEYS_PAGE = 1000
#: Parts a report plots and lists unless asked otherwise (``rcb report --last``).
REPORT_DEFAULT_LAST = 100
#: Most parts a report may plot (``--last``).
REPORT_MAX_LAST = 1000
#: The default retention of the audit log.
AUDIT_DEFAULT = "365d"
#: The default retention of idempotency records.
IDEMPOTENCY_DEFAULT = "7d"
#: The default retention of band states a newer one replaced (db.state_retention).
STATES_DEFAULT = "30d"
