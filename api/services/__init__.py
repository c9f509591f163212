"""The use cases behind the REST service and the CLI, each one transaction.

Writes by resource: ``plans`` (create, replan), ``parts`` (a part report), ``tools`` (add one),
``keys`` (API keys); reads: ``queries``, ``history`` (setpoint history by page), ``reading``
(what they share). Their machinery apart: ``auth`` (who is asking: API
keys checked, refusals audited), ``transactions`` (the write's transaction, retries, the audit
log), ``idempotency`` (Idempotency-Key records and replays), ``errors``; ``to_json`` shapes
domain objects as the JSON they share; ``sizes`` (pages and defaults the CLI's help states,
without importing SQLAlchemy).
"""
