"""``rcb virtual serve``: a virtual lathe making parts, as an MTConnect agent or OPC UA server.

A machine to try ``rcb collect`` against (docs/try-a-machine.md): the plan file's parts on the
virtual lathe (:mod:`api.virtual_serve.lathe`), served on 127.0.0.1 until SIGTERM or SIGINT
(:mod:`api.virtual_serve.run`). ``--collector FILE`` writes the ``collector.toml`` that reads it.
"""

from __future__ import annotations

import enum
import logging
import sys
from pathlib import Path
from typing import TYPE_CHECKING, Annotated

import typer

from api.cli.common import DbOption, errors, plan_of, say
from api.virtual_serve import MAX_PARTS
from models.bounds import LARGEST_WHOLE
from models.errors import InputError

if TYPE_CHECKING:
    from api.virtual_serve.lathe import VirtualLathe
    from api.virtual_serve.run import Published

virtual_app = typer.Typer(
    help="A virtual lathe to try rcb collect against: its parts over MTConnect or OPC UA.",
    no_args_is_help=True,
)


class Protocol(enum.StrEnum):
    """The protocols the virtual lathe speaks."""

    mtconnect = "mtconnect"
    opcua = "opcua"


#: The port of each protocol when none is given: cppagent's and OPC UA's (IANA 4840).
DEFAULT_PORTS = {Protocol.mtconnect: 5000, Protocol.opcua: 4840}


_PlanOption = Annotated[
    Path,
    typer.Option(metavar="FILE", help="A plan with a spindle-load calibration table."),
]
_PortOption = Annotated[
    int | None,
    typer.Option(min=1, max=65535, help="TCP port on 127.0.0.1 [default: 5000 or 4840]."),
]
_NoWaitOption = Annotated[
    bool,
    typer.Option(
        "--no-wait-for-reader",
        help="Make the first part at once (by default: once a collector reads the machine).",
    ),
]
_CollectorOption = Annotated[
    Path | None,
    typer.Option(metavar="collector.toml", help="Write the collector's file for this machine."),
]
_ServiceUrlOption = Annotated[
    str,
    typer.Option(
        metavar="URL",
        show_default=False,
        help="The REST service, in --collector's file [default: rcb serve on port 8000].",
    ),
]

_PlanIdOption = Annotated[
    int | None,
    typer.Option(
        min=1,
        max=LARGEST_WHOLE,
        show_default=False,
        help="The stored plan's id, in --collector's file [default: the plan of the file's "
        "name in --db].",
    ),
]


@virtual_app.command("serve")
def serve(
    protocol: Annotated[Protocol, typer.Option(help="mtconnect (an agent) or opcua (a server).")],
    plan: _PlanOption,
    port: _PortOption = None,
    parts: Annotated[int, typer.Option(min=1, max=MAX_PARTS, help="Parts to make.")] = 10,
    seconds_per_part: Annotated[
        float, typer.Option(min=0.01, max=3600.0, help="Time to make one part [s].")
    ] = 1.0,
    seed: Annotated[
        int, typer.Option(min=0, max=LARGEST_WHOLE, help="Seed of the virtual machine and noise.")
    ] = 7,
    no_wait_for_reader: _NoWaitOption = False,
    collector: _CollectorOption = None,
    machine: Annotated[
        str, typer.Option(help="The machine's name in --collector's file (in each serial).")
    ] = "virtual-lathe",
    service_url: _ServiceUrlOption = "http://127.0.0.1:8000/api/v1",
    plan_id: _PlanIdOption = None,
    db: DbOption = None,
) -> None:
    """Serve a virtual lathe making the plan's parts at its version-1 setpoints, until stopped."""
    from api.virtual_serve import run
    from api.virtual_serve.lathe import build

    _logging()
    chosen = port or DEFAULT_PORTS[protocol]
    with errors():
        _check(service_url, machine)
        try:
            lathe = build(plan, parts, seed)
        except KeyboardInterrupt:  # Ctrl-C while the plan is optimised: nothing served yet
            say("rcb virtual: interrupted before serving")
            raise typer.Exit(130) from None
        if collector is not None and plan_id is None:
            plan_id = _stored_plan(db, lathe.plan.name, plan)
        published = _publish(lathe, protocol, chosen)
    try:
        with errors():
            if collector is not None:
                assert plan_id is not None
                service = (service_url, plan_id)
                _write_collector(collector, lathe, protocol, published, service, machine)
    except typer.Exit:
        published.close()
        raise
    name = "MTConnect agent" if protocol is Protocol.mtconnect else "OPC UA server"
    say(
        f"rcb virtual: {name} at {published.url}: {parts} parts of {lathe.plan.name!r} at its "
        f"setpoint version 1, one every {seconds_per_part:g} s; operations "
        f"{' '.join(lathe.operation_map())}"
    )
    if collector is not None:
        say(f"rcb virtual: wrote {collector}: rcb collect --config {collector}")
    run.run(lathe, published, seconds_per_part, not no_wait_for_reader)


def _check(service_url: str, machine: str) -> None:
    """Refuse the collector file's options before anything is built."""
    if not service_url.startswith(("http://", "https://")):
        raise InputError("--service-url", service_url, "must start with http:// or https://")
    if not machine.strip() or len(machine) > 200:
        raise InputError("--machine", machine, "must be text of 1 to 200 characters")


def _write_collector(
    path: Path,
    lathe: VirtualLathe,
    protocol: Protocol,
    published: Published,
    service: tuple[str, int],
    machine: str,
) -> None:
    """Write the collector's file that reads this machine (``--collector``)."""
    from api.virtual_serve.collector_file import collector_toml, queue_name, write_collector

    queue = queue_name(path)
    text = collector_toml(lathe, protocol.value, published.url, service, machine, queue)
    write_collector(path, text)


def _stored_plan(db: str | None, name: str, path: Path) -> int:
    """The id of the plan named ``name`` in the database (``--db``), for the collector's file.

    A first-day review: the default was id 1, which in a folder that had stored another plan
    first named that plan, and the collector's every part was refused with a calibration error.
    """
    import shlex

    from api.cli.common import again_db, engine_of

    engine = engine_of(db)
    try:
        return plan_of(engine, name, "--plan")
    except InputError as err:
        store = f"rcb plans create {shlex.quote(str(path))}{again_db(db)}"
        reason = f"{err.reason}; store it first ({store}) or give --plan-id"
        raise InputError("--plan", str(path), reason) from None
    finally:
        engine.dispose()


def _publish(lathe: VirtualLathe, protocol: Protocol, port: int) -> Published:
    from api.virtual_serve import run

    serve_on = run.mtconnect if protocol is Protocol.mtconnect else run.opcua
    try:
        return serve_on(lathe, port)
    except (OSError, RuntimeError) as err:
        raise InputError("--port", port, f"cannot serve on 127.0.0.1 ({err})") from None


def _logging() -> None:
    logging.basicConfig(
        stream=sys.stderr, level=logging.INFO, format="%(asctime)s rcb virtual: %(message)s"
    )
    # asyncua warns that a server without security has no signing policy: this one has none
    logging.getLogger("asyncua").setLevel(logging.ERROR)
