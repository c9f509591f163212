"""The REST service the MES calls, under ``/api/v1``.

``app`` (the app factory), ``routes/`` (one router per resource), ``deps`` (the engine and the
roles as dependencies; :mod:`api.services.auth` checks the keys), ``problems`` (errors as
problem+json), ``limits`` (a body over 1 MiB is 413 before it is read), ``schemas/`` (the
bodies, one module per resource) and ``serving`` (uvicorn).
"""
