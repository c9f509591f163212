"""A plan's record for people: the HTML report with its plots, tidy tables, the web view.

``html`` (the HTML report: one self-contained page of a plan's record), ``series`` (the
record as arrays per operation), ``plots`` (the charts and their labels), ``chart`` (what a
chart shows, as data), ``svg`` and ``svg_marks`` (a chart drawn as SVG text, directly),
``html_parts`` (the HTML helpers the report and the web view share), ``marks``
(how a decision or a halt reads, in the CLI too), ``export`` (tidy pandas tables) and ``ui``
(the read-only web view under ``/ui/``, installed by the REST app).
"""
