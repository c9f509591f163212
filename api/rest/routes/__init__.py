"""The REST routes, one ``APIRouter`` per resource; :func:`api.rest.app.create_app` mounts them.

``health`` (liveness), ``plans`` (create, replan, list, read), ``parts`` (what the MES calls:
setpoints in force, part reports, the parts), ``review`` (setpoint history and model
versions), ``tools`` (the catalogue and the stored tools); ``common`` holds the parameters
and the write answers they share.
"""
