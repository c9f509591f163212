"""Machine signals → part reports, as pure functions (no I/O): what ``rcb collect`` decides.

:mod:`~supervisor.collect.selectors` maps an operation to its blocks (``OP=N100:N200``, the form
``rcb gcode`` takes) or its tool (``OP=T3``); :mod:`~supervisor.collect.segment` cuts a stream of
observations (spindle load or current, speed, feed rate, block, tool, part count, execution) into
passes per operation and parts per part-count increment, and reduces each pass to one reading
(the maximum or a percentile); :mod:`~supervisor.collect.report` writes the part report the REST
service takes, whose raw reading the machine's calibration converts to force
(:mod:`supervisor.inputs.signals`, :func:`models.sensors.to_force`).
"""
