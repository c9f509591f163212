"""``rcb collect``: the machine side of a part report, with nothing lost.

:mod:`~api.collect.config` reads ``collector.toml``; :mod:`~api.collect.mtconnect` and
:mod:`~api.collect.opcua` turn an MTConnect agent's streams or an OPC UA server's subscription
into observations for :class:`supervisor.collect.segment.Segmenter`; :mod:`~api.collect.queue` is
the durable local queue (SQLite) of part reports, skipped parts and the read checkpoint;
:mod:`~api.collect.poster` sends the queue in order to the REST service; :mod:`~api.collect.runner`
runs the two together and logs per part.
"""
