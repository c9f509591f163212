"""Interfaces and the use cases they call (the top layer: api -> db -> supervisor -> models).

``rest/`` (the FastAPI service the MES calls), ``services/`` (the use cases both interfaces
call, one transaction each), ``cli/`` (the Typer CLI ``rcb``), ``report/`` (the HTML report,
its plots and the web view), and ``settings`` (the one reader of the environment).
"""
