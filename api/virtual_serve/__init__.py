"""``rcb virtual serve``: the virtual lathe's parts as a real MTConnect agent or OPC UA server.

:mod:`~api.virtual_serve.mtconnect_agent` (an HTTP agent, stdlib) and
:mod:`~api.virtual_serve.opcua_machine` (an asyncua server) play a trace of
:mod:`supervisor.virtual.trace`; :mod:`~api.virtual_serve.run` builds the trace from a plan
file and paces the parts. A network server is an interface, hence ``api``.
"""

#: The most parts one ``rcb virtual serve`` makes (the whole trace is held in memory); here,
#: without imports, so that ``rcb --help`` reads it without loading the optimiser.
MAX_PARTS = 1000
