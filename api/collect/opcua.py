"""An OPC UA server's subscription → observations (asyncua, imported only when used).

One subscription with a monitored item per signal (``queuesize`` large, so the server keeps
every change between two publishes). asyncua hands the notifications of one publish to an
async iterator in one go; they are taken as a batch and ordered by their ``SourceTimestamp``
(then execution, program, part count, tool, block, speed, feed rate, load: the state a load
sample is read in comes first), since a server groups a publish's notifications by item.
A local queue overflowing disconnects (asyncua ``OverflowPolicy.DISCONNECT``), never drops;
a connection asyncua's watchdog finds lost, or a server that does not answer a read of its
state after :data:`PROBE_S` s without a notification, ends the iteration (the runner records a
gap and connects again).

A node is a NodeId or a browse path from ``Objects`` (:mod:`api.collect.opcua_paths`: what
cannot be resolved is an input error naming the path and what the server offers there). A
block is a string or, as OPC 40502's ``ActProgramBlock``, an array of strings whose first
element is the block being run. Security is asyncua's security string
(``Basic256Sha256,SignAndEncrypt,cert.der,key.pem``); the password is read from the environment
variable ``password_env`` names and never logged.
"""

from __future__ import annotations

import asyncio
import datetime as dt
import os
import time
from collections.abc import AsyncIterator
from typing import TYPE_CHECKING, Any

from api.collect.config import OpcUaConfig
from api.collect.opcua_paths import resolve
from models.errors import InputError
from supervisor.collect.segment import ACTIVE, Observation
from supervisor.collect.selectors import block_number

if TYPE_CHECKING:
    from asyncua.client.client import Client
    from asyncua.common.subscription import Subscription

#: Order of signals that change at the same instant (see the module docstring).
PRIORITY = (
    "execution",
    "program",
    "part_count",
    "tool_number",
    "block",
    "spindle_speed_rpm",
    "feed_rate_mm_min",
    "spindle_load",
)
_EPOCH = dt.datetime(1970, 1, 1, tzinfo=dt.UTC)
#: Seconds without a notification after which the server is asked for its state (a half-open
#: connection sends nothing and reports nothing); no answer within as long is a lost connection.
PROBE_S = 2.0


def lost() -> tuple[type[BaseException], ...]:
    """The errors that mean the connection is lost or refused (asyncua's, the socket's)."""
    from asyncua.ua.uaerrors import UaError

    return (OSError, TimeoutError, ConnectionError, asyncio.IncompleteReadError, UaError)


def _value(item: str, value: Any, active: tuple[str, ...]) -> float | int | str | None:
    if value is None:
        return None
    if item == "execution":
        return ACTIVE if str(getattr(value, "value", value)) in active else str(value)
    if item == "block":  # OPC 40502 ActProgramBlock: String[], the current block first
        if isinstance(value, list | tuple):
            return block_number(str(value[0])) if value else None
        return block_number(str(value))
    if item in ("part_count", "tool_number"):
        return int(value)
    if item == "program":
        return str(value)
    return float(value)


async def observations(config: OpcUaConfig, stop: asyncio.Event) -> AsyncIterator[Observation]:
    """Connect, subscribe and yield the observations in order until ``stop`` is set."""
    client, lost = await _client(config)
    async with client:
        subscription, items = await _subscribe(client, config)
        iterator = aiter(subscription)
        sequence, heard = 0, time.monotonic()
        while not stop.is_set():
            if lost:
                raise ConnectionError(f"connection lost ({type(lost[0]).__name__})")
            try:
                first = await asyncio.wait_for(anext(iterator), timeout=0.2)
            except TimeoutError:
                if time.monotonic() - heard > PROBE_S:  # quiet: is the server still there?
                    await asyncio.wait_for(client.nodes.server_state.read_value(), PROBE_S)
                    heard = time.monotonic()
                continue
            heard = time.monotonic()
            batch: list[Any] = [first]
            pending = subscription._event_queue  # asyncua's iterator queue: the same publish
            while pending is not None and not pending.empty():
                batch.append(pending.get_nowait())
            for item, value in _changes(batch, items):
                sequence += 1
                yield Observation(sequence, item, _value(item, value, config.active_values))


#: The OPC UA session timeout the collector asks for [ms]: a collector that died leaves its
#: session on the machine's server for at most this long (OPC UA Part 4, CreateSession).
SESSION_TIMEOUT_MS = 60_000


async def _client(config: OpcUaConfig) -> tuple[Client, list[Exception]]:
    """An asyncua client, not yet connected, with its security and user; and its losses.

    The list fills when asyncua's watchdog sees the server go.
    """
    from asyncua.client.client import Client

    client = Client(config.url)
    # asyncua asks for an hour and warns at every server that revises it (asyncua's own caps
    # sessions at 10 min): "Requested session timeout to be 3600000ms, got 600000ms instead"
    # in every collector's log, unexplained (a first-day review)
    client.session_timeout = SESSION_TIMEOUT_MS
    lost: list[Exception] = []

    async def on_lost(error: Exception) -> None:  # asyncua's watchdog saw the server go
        lost.append(error)

    client.connection_lost_callback = on_lost
    if config.security:
        await client.set_security_string(config.security)
    if config.username:
        client.set_user(config.username)
        if config.password_env:
            password = os.environ.get(config.password_env)
            if not password:
                raise InputError("opcua.password_env", config.password_env, "variable unset")
            client.set_password(password)
    return client, lost


async def _subscribe(client: Client, config: OpcUaConfig) -> tuple[Subscription, dict[Any, str]]:
    """One subscription with a monitored item per signal; and each node id's signal.

    A local queue overflowing disconnects rather than drops (module docstring).
    """
    from asyncua import ua
    from asyncua.common.subscription import OverflowPolicy

    nodes = {
        item: await resolve(client, spec, f"opcua.nodes.{item}")
        for item, spec in config.nodes.items()
    }
    items = {node.nodeid: item for item, node in nodes.items()}
    parameters = ua.CreateSubscriptionParameters(
        RequestedPublishingInterval=config.publishing_ms,
        RequestedLifetimeCount=10000,
        RequestedMaxKeepAliveCount=100,
        MaxNotificationsPerPublish=0,
        Priority=0,
    )
    subscription = await client.create_subscription(
        parameters, None, queue_maxsize=100_000, overflow=OverflowPolicy.DISCONNECT
    )
    await subscription.subscribe_data_change(
        list(nodes.values()), queuesize=config.queue_size, sampling_interval=ua.Double(0.0)
    )
    return subscription, items


def _changes(batch: list[Any], items: dict[Any, str]) -> list[tuple[str, Any]]:
    """The data changes of one publish, ordered by source time, then by :data:`PRIORITY`."""
    from asyncua.common.subscription import DataChangeEvent, StatusChangeEvent

    changes = []
    for event in batch:
        if isinstance(event, StatusChangeEvent):  # the server ended the subscription
            raise ConnectionError(f"subscription status {event.notification.Status}")
        if not isinstance(event, DataChangeEvent):
            continue
        item = items.get(event.node.nodeid)
        if item is None:
            continue
        stamp = event.data.monitored_item.Value.SourceTimestamp or _EPOCH
        if stamp.tzinfo is None:
            stamp = stamp.replace(tzinfo=dt.UTC)
        changes.append((stamp, PRIORITY.index(item), item, event.value))
    changes.sort(key=lambda c: (c[0], c[1]))
    return [(item, value) for _, _, item, value in changes]
