"""The collector: observations → segmenter → queue, and the poster, in one asyncio loop.

MTConnect resumes from the queue's checkpoint (the sequence after the last part boundary), so
across restarts no observation is skipped and no part is queued twice; a ``from`` the agent no
longer holds (its buffer wrapped) or a new agent instance is a gap: recorded, logged, and the
parts it touches are skipped with it as the reason. OPC UA has no replay: after a restart the
part in progress is skipped (the collector joined mid-part) unless the machine is not cutting.
"""

from __future__ import annotations

import asyncio
import json
import logging
from collections.abc import AsyncIterator, Callable

import httpx

from api.collect.config import CollectorConfig, MTConnectConfig
from api.collect.mtconnect import Agent, AgentError, Streams
from api.collect.poster import post_loop
from api.collect.queue import Checkpoint, Queue
from api.collect.tls import trusted, unreached
from supervisor.collect.report import idempotency_key, part_report
from supervisor.collect.segment import Gap, Observation, Outcome, PartDone, Segmenter

log = logging.getLogger("rcb.collect")
#: The field that names the CA the agent's certificate needs (api.collect.tls).
_CA_FIELD = "mtconnect.ca_file"


def _why(err: Exception) -> str:
    """An agent's error for the log: its answer, or why it was not reached."""
    return str(err) if isinstance(err, AgentError) else unreached(err, _CA_FIELD)


class Recorder:
    """Turns the segmenter's outcomes into queued reports and skips, logged per part."""

    def __init__(self, config: CollectorConfig, queue: Queue) -> None:
        self.config, self.queue = config, queue

    def outcome(self, outcome: Outcome, checkpoint: Checkpoint | None) -> None:
        """Queue a finished part (or record the parts skipped) with the checkpoint past it."""
        c = self.config
        if isinstance(outcome, PartDone):
            body, left_out = part_report(
                outcome,
                machine=c.machine,
                setpoint_version=c.setpoint_version,
                quantity=c.quantity,
                uncertainty=c.uncertainty,
                calibration=c.calibration,
            )
            if body["operations"]:
                key = idempotency_key(c.plan_id, c.machine, outcome.program, outcome.part_count)
                data = json.dumps(body, sort_keys=True, separators=(",", ":")).encode()
                report = (key, outcome.part_count, outcome.program, data)
                added = self.queue.record(checkpoint, report=report)
                unit = c.quantity.rpartition("_")[2]
                passes = ", ".join(
                    f"{p.operation} {p.value:.4g} {unit} ({p.samples} samples)"
                    for p in outcome.passes
                )
                state = "queued" if added else "queued before"
                log.info("part %d (%s): %s; %s", outcome.part_count, body["serial"], state, passes)
                for why in left_out:
                    log.warning("part %d: left out %s", outcome.part_count, why)
                return
            outcome_skip = ((outcome.part_count,), outcome.program, "; ".join(left_out))
            self.queue.record(checkpoint, skipped=outcome_skip)
            log.warning("part %d: NOT reported: %s", outcome.part_count, "; ".join(left_out))
            return
        counts = ", ".join(str(n) for n in outcome.part_counts)
        self.queue.record(
            checkpoint, skipped=(outcome.part_counts, outcome.program, outcome.reason)
        )
        log.warning("parts %s: NOT reported: %s", counts, outcome.reason)


def required(config: CollectorConfig) -> tuple[str, ...]:
    """The signals no part can be cut into passes without.

    The load, the part count, the execution state, and the block number or the tool number the
    operations are selected by; the others (speed, feed rate, program) may be missing.
    """
    needed = ["spindle_load", "part_count", "execution"]
    if any(s.tool_number is None for s in config.selectors):
        needed.append("block")
    if any(s.tool_number is not None for s in config.selectors):
        needed.append("tool_number")
    return tuple(needed)


async def mtconnect_loop(
    config: CollectorConfig, source: MTConnectConfig, queue: Queue, stop: asyncio.Event
) -> None:
    """Read the agent from the checkpoint on, until ``stop`` is set."""
    recorder = Recorder(config, queue)
    async with httpx.AsyncClient(timeout=30.0, verify=trusted(source.ca_file)) as http:
        agent = Agent(
            http, source.url, source.items, spindle=source.spindle, required=required(config)
        )
        if not await _bind(agent, source, stop):
            return
        saved = queue.checkpoint()
        segmenter = Segmenter(
            config.selectors,
            percentile=config.percentile,
            state=None if saved is None else saved.state,
        )
        current = await _current(agent, source, stop)
        if current is None:
            return
        instance, start = _resume(queue, source, segmenter, saved, current)
        while not stop.is_set():
            try:
                streams = await agent.sample(start, source.count)
            except AgentError as err:
                first = await _first_sequence(agent) if err.code == "OUT_OF_RANGE" else None
                if first is None or first <= start:
                    log.warning("agent answered %s; retrying", err)
                    await _pause(stop, max(1.0, source.poll_s))
                    continue
                gap = Gap(start, first - 1, "the agent's buffer wrapped")
                segmenter.gap(gap)
                _gap(queue, gap, instance, first, segmenter)
                start = first
                continue
            except httpx.HTTPError as err:
                log.warning("agent not reached (%s); retrying", unreached(err, _CA_FIELD))
                await _pause(stop, source.poll_s * 5)
                continue
            if streams.instance_id != instance:
                gap = Gap(
                    start, None, f"agent restarted: instance {instance} → {streams.instance_id}"
                )
                segmenter.gap(gap)
                current = await agent.current()
                instance, start = current.instance_id, current.next_sequence
                _gap(queue, gap, instance, start, segmenter)
                continue
            _feed(streams, instance, start, queue, segmenter, recorder)
            advanced = streams.next_sequence > start
            start = max(start, streams.next_sequence)
            if not advanced or not streams.observations:
                await _pause(stop, source.poll_s)


async def _bind(agent: Agent, source: MTConnectConfig, stop: asyncio.Event) -> bool:
    """Read the agent's device model, waiting for an agent down at start (False: stopped)."""
    while not agent.binding:
        if stop.is_set():
            return False
        try:
            for signal, bound in (await agent.bind()).items():
                log.info("%s: data item %s, scale %g", signal, bound.item.describe(), bound.scale)
        except (httpx.HTTPError, AgentError) as err:
            log.warning("agent's device model not read (%s); retrying", _why(err))
            await _pause(stop, max(1.0, source.poll_s))
    return True


async def _current(agent: Agent, source: MTConnectConfig, stop: asyncio.Event) -> Streams | None:
    """The agent's current state, waiting for an agent down at start (None: stopped)."""
    current = None
    while current is None:
        if stop.is_set():
            return None
        try:
            current = await agent.current()
        except (httpx.HTTPError, AgentError) as err:
            log.warning("agent not read (%s); retrying", _why(err))
            await _pause(stop, max(1.0, source.poll_s))
    return current


def _resume(
    queue: Queue,
    source: MTConnectConfig,
    segmenter: Segmenter,
    saved: Checkpoint | None,
    current: Streams,
) -> tuple[str, int]:
    """Instance and sequence to read from: the checkpoint's, unless there is none.

    A checkpoint of another agent instance is a gap (the agent restarted): recorded, and the
    reading starts as without a checkpoint (:func:`_first_start`), that start recorded.
    """
    instance, start = (saved.instance, saved.next_sequence) if saved else ("", 0)
    if saved is not None and current.instance_id != instance:
        gap = Gap(start, None, f"agent restarted: instance {instance} → {current.instance_id}")
        segmenter.gap(gap)
        _gap(queue, gap, current.instance_id, current.next_sequence, segmenter)
        saved = None
    if saved is None:
        instance, start = _first_start(source, current, segmenter)
        queue.record(Checkpoint("mtconnect", instance, start, segmenter.snapshot()))
    else:
        log.info(
            "resuming at sequence %d, after the last part queued (agent instance %s)",
            start,
            instance,
        )
    return instance, start


def _feed(
    streams: Streams,
    instance: str,
    start: int,
    queue: Queue,
    segmenter: Segmenter,
    recorder: Recorder,
) -> None:
    """One sample's observations from ``start`` on into the segmenter; a wrapped buffer a gap.

    Each part's outcome is recorded with the checkpoint just after its last observation.
    """
    if streams.first_sequence > start:
        gap = Gap(start, streams.first_sequence - 1, "the agent's buffer wrapped")
        segmenter.gap(gap)
        _gap(queue, gap, instance, streams.first_sequence, segmenter)
    for observation in streams.observations:
        if observation.sequence < start:
            continue  # never read twice
        for outcome in segmenter.feed(observation):
            point = Checkpoint(
                "mtconnect", instance, observation.sequence + 1, segmenter.snapshot()
            )
            recorder.outcome(outcome, point)


def _first_start(
    source: MTConnectConfig, current: Streams, segmenter: Segmenter
) -> tuple[str, int]:
    """Where a collector without a checkpoint reads from (``[mtconnect] start``), logged."""
    held = max(0, current.next_sequence - current.first_sequence)
    if source.start == "buffer":
        log.info(
            "reading from sequence %d, the oldest the agent holds (%d observations): the parts "
            "in its buffer are collected",
            current.first_sequence,
            held,
        )
        return current.instance_id, current.first_sequence
    for observation in current.observations:
        segmenter.feed(observation)  # latest values; a part in progress stays tainted
    log.info(
        "reading from sequence %d, the agent's next: the %d observations in its buffer (what "
        "the machine did before now) are not read; waiting for new parts ([mtconnect] start = "
        '"buffer" reads them)',
        current.next_sequence,
        held,
    )
    return current.instance_id, current.next_sequence


async def _first_sequence(agent: Agent) -> int | None:
    """The oldest sequence the agent holds (None: not read now)."""
    try:
        return (await agent.current()).first_sequence
    except (httpx.HTTPError, AgentError):
        return None


def _gap(queue: Queue, gap: Gap, instance: str, resume: int, segmenter: Segmenter) -> None:
    log.error("GAP: %s", gap.describe())
    point = Checkpoint("mtconnect", instance, resume, segmenter.snapshot())
    queue.record(point, gap=(gap.first_lost, gap.last_lost, gap.reason))


async def observation_loop(
    config: CollectorConfig,
    queue: Queue,
    connect: Callable[[], AsyncIterator[Observation]],
    lost: tuple[type[BaseException], ...],
    stop: asyncio.Event,
) -> None:
    """Segment a subscription's observations (OPC UA) into the queue, reconnecting.

    ``connect()`` opens the subscription and yields its observations; an exception of ``lost``
    is a lost connection: a gap (the part in progress is skipped), then a new connection.
    """
    recorder = Recorder(config, queue)
    segmenter = Segmenter(config.selectors, percentile=config.percentile)
    where = config.opcua.url if config.opcua is not None else ""
    outage = False  # one gap per outage, however many tries it takes to connect again
    while not stop.is_set():
        connected = False
        try:
            async for observation in connect():
                if not connected:  # --status shows where from (there is nothing to resume)
                    queue.record(Checkpoint("opcua", where, 0, {}))
                    log.info(
                        "subscribed to %s: values from now on (OPC UA has no replay: parts "
                        "made before are not read); waiting for new parts",
                        where,
                    )
                    connected, outage = True, False
                for outcome in segmenter.feed(observation):
                    recorder.outcome(outcome, None)
                if stop.is_set():
                    return
        except lost as err:
            if not outage:
                why = f"OPC UA connection lost or refused ({type(err).__name__}): no replay"
                gap = Gap(None, None, why)
                log.error("GAP: %s; reconnecting", gap.reason)
                segmenter.gap(gap)
                queue.record(None, gap=(gap.first_lost, gap.last_lost, gap.reason))
                outage = True
            await _pause(stop, 1.0)


async def _pause(stop: asyncio.Event, seconds: float) -> None:
    try:
        await asyncio.wait_for(stop.wait(), timeout=seconds)
    except TimeoutError:
        pass


async def run(config: CollectorConfig, queue: Queue, stop: asyncio.Event) -> None:
    """Collect and post until ``stop`` is set (or a task fails: then both stop)."""
    log.info(
        "starting: machine %s, plan %d at %s, setpoint version %d, reading %s",
        config.machine,
        config.plan_id,
        config.service_url,
        config.setpoint_version,
        f"MTConnect agent {config.mtconnect.url}"
        if config.mtconnect is not None
        else f"OPC UA server {config.opcua.url if config.opcua else ''}",
    )
    if config.mtconnect is not None:
        reader = mtconnect_loop(config, config.mtconnect, queue, stop)
    else:
        from api.collect import opcua

        assert config.opcua is not None
        source = config.opcua
        reader = observation_loop(
            config, queue, lambda: opcua.observations(source, stop), opcua.lost(), stop
        )
    tasks = [asyncio.create_task(reader), asyncio.create_task(post_loop(config, queue, stop))]
    done, _ = await asyncio.wait(tasks, return_when=asyncio.FIRST_EXCEPTION)
    stop.set()
    for task in tasks:
        if task.done() and task.exception() is not None:
            for other in tasks:
                other.cancel()
            raise task.exception()  # type: ignore[misc]
    await asyncio.gather(*tasks, return_exceptions=True)
