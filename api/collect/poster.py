"""Send the queue's part reports to the REST service, oldest first, each until it is settled.

``POST {service}/plans/{plan}/parts`` with the report's Idempotency-Key: 201 (first answer or a
replay) settles it as sent; 409 naming ``serial`` (stored before, its key record pruned) as
sent too; 400, 413, 415 and 422 as rejected (the report can never be stored: kept in the queue
with the problem, logged, and the next one goes). A connection error, 5xx, 429, 409 in flight
and 401/403/404 (a key or plan to fix: the reports wait) are retried after a backoff that
doubles up to ``retry_max_s``; nothing behind the head of the queue is sent meanwhile, so the
service receives the parts in the order they were made.
"""

from __future__ import annotations

import asyncio
import logging
from typing import Any

import httpx

from api.collect.config import CollectorConfig
from api.collect.queue import Pending, Queue
from api.collect.tls import trusted, unreached

log = logging.getLogger("rcb.collect")
_REJECTED = (400, 413, 415, 422)


def _summary(answer: httpx.Response) -> dict[str, Any]:
    try:
        body = answer.json()
    except ValueError:
        return {"text": answer.text[:200]}
    if not isinstance(body, dict):
        return {}
    keys = ("part_id", "serial", "setpoint_version", "halted", "code", "field", "detail")
    summary = {k: body[k] for k in keys if k in body}
    summary["replayed"] = answer.headers.get("Idempotent-Replayed") == "true"
    return summary


async def _pause(stop: asyncio.Event, seconds: float) -> None:
    try:
        await asyncio.wait_for(stop.wait(), timeout=seconds)
    except TimeoutError:
        pass


async def post_one(
    http: httpx.AsyncClient, config: CollectorConfig, item: Pending
) -> tuple[str, int, dict[str, Any]]:
    """Send one report: ``sent``, ``rejected`` or ``retry``, the HTTP status, the answer's gist."""
    url = f"{config.service_url}/plans/{config.plan_id}/parts"
    headers = {
        "Authorization": f"Bearer {config.api_key()}",
        "Content-Type": "application/json",
        "Idempotency-Key": item.idempotency_key,
    }
    try:
        answer = await http.post(url, content=item.body, headers=headers)
    except httpx.HTTPError as err:
        why = unreached(err, "service.ca_file")
        log.warning("part %d: service not reached (%s)", item.part_count, why)
        return "retry", 0, {}
    summary = _summary(answer)
    if answer.status_code in (200, 201):
        how = "already stored, replayed" if summary.get("replayed") else "stored"
        log.info(
            "part %d: %s (part id %s, setpoint version now %s%s)",
            item.part_count,
            how,
            summary.get("part_id"),
            summary.get("setpoint_version"),
            ", plan HALTED" if summary.get("halted") else "",
        )
        return "sent", answer.status_code, summary
    if answer.status_code == 409 and summary.get("field") == "serial":
        log.info("part %d: the service had stored it before (serial)", item.part_count)
        return "sent", answer.status_code, summary
    if answer.status_code in _REJECTED:
        log.error(
            "part %d: REJECTED %d %s: %s",
            item.part_count,
            answer.status_code,
            summary.get("field"),
            summary.get("detail"),
        )
        return "rejected", answer.status_code, summary
    log.warning("part %d: service answered %d; will retry", item.part_count, answer.status_code)
    return "retry", answer.status_code, summary


async def post_loop(config: CollectorConfig, queue: Queue, stop: asyncio.Event) -> None:
    """Send the queue in order until ``stop`` is set."""
    delay = 0.05
    async with httpx.AsyncClient(timeout=30.0, verify=trusted(config.service_ca_file)) as http:
        while not stop.is_set():
            item = queue.next_pending()
            if item is None:
                await _pause(stop, 0.05)
                continue
            queue.attempted(item.id)
            outcome, status, summary = await post_one(http, config, item)
            if outcome == "retry":
                await _pause(stop, delay)
                delay = min(2 * delay, config.retry_max_s)
                continue
            delay = 0.05
            queue.settle(item.id, outcome, status, summary)
