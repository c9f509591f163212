"""Pydantic models of the REST bodies, one module per resource.

They make the OpenAPI document and check responses. Request bodies are checked again by the
domain readers (:mod:`supervisor.inputs.part_report`, :mod:`supervisor.inputs.plan`), whose
errors name the dotted field; these models describe them, and the lists of names they hold
come from the registries (quantities, strategies, processes). ``common`` holds the shared
types; ``service`` the problem details and liveness; ``plans``, ``replan``, ``setpoints``,
``parts``, ``halts``, ``review`` and ``tools`` their resources.
"""
