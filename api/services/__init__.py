"""The use cases behind the REST service and the CLI, each one transaction.

Writes by resource: ``plans`` (create, replan), ``parts`` (a part report), ``tools`` (add one),
``keys`` (API keys); reads: the package ``read`` (by resource: plans, setpoints, a plan's parts
and models, tools, setpoint history, a report's record). Their machinery apart: ``auth`` (who
is asking: API keys checked, refusals audited), ``transactions`` (the write's transaction,
retries, the audit log), ``idempotency`` (Idempotency-Key records and replays), ``errors``;
``to_json`` shapes domain objects as the JSON they share; ``request_limits`` (pages and
defaults the CLI's help states, without importing SQLAlchemy).
"""
