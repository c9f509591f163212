"""Where a plan's models started from, in words: the report's overview and ``rcb plans show``.

A plan's answer (:func:`api.services.read.plans.get_plan`) carries ``prior`` (``fleet`` or
``catalogue``), ``provenance`` (per operation, a line per quantity, by operation name) and
``noise_provenance`` (a line per measuring chain). Both the report (:func:`prior_line`) and
``rcb plans show`` read them through this module, so they say the same, in the plan's order
of operations, and with the reason a part let a prior go taken from the provenance's own
text: the line REST answers, written once where the part let it go
(:func:`db.let_go_mark.marked`).
"""

from __future__ import annotations

from collections.abc import Iterable, Mapping, Sequence
from typing import Any

from db.let_go_mark import marked
from supervisor.fleet.band_check import BAND_CHECKED_WHY
from supervisor.fleet.left_out import LeftOut

#: What a plan's models start from without a fleet prior.
CATALOGUE = "the tools' catalogue models"


def span(values: Iterable[float]) -> str:
    """Per-cent values at one decimal: ``4.1`` when they all read so, else ``2.9-3.2``."""
    shown = sorted(set(values))
    low, high = f"{shown[0]:.1f}", f"{shown[-1]:.1f}"
    return low if low == high else f"{low}-{high}"


def _counted(count: int, noun: str) -> str:
    return f"{count} {noun}" if count == 1 else f"{count} {noun}s"


def _in_all(provenances: Sequence[Mapping[str, Any]], field: str) -> str:
    """``3 plans``: the plans (or machines) behind all the quantities' priors together.

    Where each lists all its names, the names told apart; where one lists only the first
    (:data:`db.fleet_names.MAX_NAMED`) or none (a key scoped to plans), the most one has:
    ``at least 320 plans``.
    """
    noun = field.removesuffix("s")
    totals = [int(p.get(f"{field}_total", len(p[field] or []))) for p in provenances]
    if all(
        p[field] is not None and len(p[field]) == n
        for p, n in zip(provenances, totals, strict=True)
    ):
        return _counted(len({name for p in provenances for name in p[field]}), noun)
    return "at least " + _counted(max(totals), noun)


def in_plan_order(
    provenance: Mapping[str, Sequence[Mapping[str, Any]]], operations: Sequence[str]
) -> list[tuple[str, Sequence[Mapping[str, Any]]]]:
    """``provenance``'s operations in the plan's order (``operations``: its names)."""
    rank = {name: i for i, name in enumerate(operations)}
    return sorted(provenance.items(), key=lambda item: rank.get(item[0], len(rank)))


def let_go_reason(line: Mapping[str, Any], field: str) -> str | None:
    """Why the part named by ``line[field]`` let the prior go, as its text says (None: kept).

    ``field``: ``widened_by_part`` (a model's prior) or ``let_go_by_part`` (a chain's noise).
    The reason is what follows ``; let go by part SERIAL:`` in ``line["text"]``, the text
    :func:`db.let_go_mark.marked` wrote; a text without it gives ``""``.
    """
    serial = line.get(field)
    if not serial:
        return None
    said = marked({"provenance": {"text": ""}}, field, serial, "")["provenance"]["text"]
    return str(line.get("text", "")).partition(said)[2].strip()


def let_go_groups(
    items: Iterable[tuple[str, Mapping[str, Any]]], field: str
) -> list[tuple[str, str, list[str]]]:
    """``(serial, reason, names)`` per part and reason that let a prior go, in first order.

    ``items``: ``(name, line)`` pairs; a line no part let go is left out.
    """
    groups: dict[tuple[str, str], list[str]] = {}
    for name, line in items:
        reason = let_go_reason(line, field)
        if reason is not None:
            groups.setdefault((str(line[field]), reason), []).append(name)
    return [(serial, reason, names) for (serial, reason), names in groups.items()]


def let_go_text(serial: str, reason: str) -> str:
    """``let go by part c-1: this machine lies …`` (the reason left out when none is stored)."""
    return f"let go by part {serial}: {reason}" if reason else f"let go by part {serial}"


def band_checked(items: Iterable[tuple[str, Mapping[str, Any]]]) -> str | None:
    """Where the band's optimum is checked at some sd of the fleet prior, and why (None: nowhere).

    ``items``: ``(name, line)`` pairs; a line with ``band_checked_at_sd`` names its quantity
    (:func:`db.fleet.provenance_json`): the band's optimum runs there only where it holds at
    that many sd of the fleet prior (:data:`supervisor.fleet.prior.FLEET_VETO_Z`), because
    the machines differ by more than the band or a plan of the tool halted
    (``band_checked_because``; a line stored before it was kept says no reason).
    """
    groups: dict[tuple[float, tuple[str, ...]], list[str]] = {}
    for name, line in items:
        sd = line.get("band_checked_at_sd")  # none in a prior stored before it was kept
        if sd is not None:
            why = tuple(line.get("band_checked_because") or ())
            groups.setdefault((float(sd), why), []).append(name)
    said = [
        f"{', '.join(names)}: {_why_checked(why)}runs only where it holds at {sd:g} sd of the "
        "fleet prior"
        for (sd, why), names in groups.items()
    ]
    return "; ".join(said) or None


def _why_checked(why: Sequence[str]) -> str:
    """The start of :func:`band_checked`'s sentence, up to "runs", for the reasons ``why``."""
    if list(why) == ["spread"]:
        return "the machines differ by more than the catalogue band, whose setpoint "
    said = [("the " if r == "spread" else "") + BAND_CHECKED_WHY.get(r, r) for r in why]
    band = "the catalogue band's setpoint "
    return f"{' and '.join(said)}, so {band}" if said else band


def left_out_said(
    plan: Mapping[str, Any], items: Iterable[tuple[str, Mapping[str, Any]]]
) -> str | None:
    """Per tool, its plans the fleet left out, in words (None: none left out).

    ``items``: ``(operation, line)`` pairs of ``plan`` (its operations name their tools); a
    line's ``left_out`` (:func:`db.fleet.provenance_json`) is its tool's, the same for each
    quantity of each operation with the tool.
    """
    tools = {op["name"]: op.get("tool", op["name"]) for op in plan.get("operations", [])}
    said: dict[str, str] = {}
    for operation, line in items:
        counts = line.get("left_out")  # none in a prior stored before they were counted
        text = LeftOut(**counts).counted() if counts else ""
        if text:
            said.setdefault(tools.get(operation, operation), text)
    if not said:
        return None
    each = ", ".join(f"{tool} {text}" for tool, text in said.items())
    return f"left out of the fleet: {each} (rcb fleet show TOOL says which and why)"


def from_catalogue(plan: Mapping[str, Any]) -> list[str]:
    """The plan's operations, in its order, whose models all start from the catalogue.

    A fleet prior is per operation and quantity: where the fleet measured none of an
    operation's tool (on its material), the operation starts from the catalogue.
    """
    provenance = plan.get("provenance", {})
    return [op["name"] for op in plan.get("operations", []) if not provenance.get(op["name"])]


def prior_line(plan: Mapping[str, Any]) -> str:
    """The catalogue, or the fleet: how many plans and machines, the spreads, what was let go."""
    order = [op["name"] for op in plan.get("operations", [])]
    by_operation = in_plan_order(plan.get("provenance", {}), order)
    lines = [(f"{op} {p['quantity']}", p) for op, ps in by_operation for p in ps]
    if plan.get("prior") != "fleet" or not lines:
        return CATALOGUE
    provenances = [p for _, p in lines]
    spreads = [100 * p["between_machine_spread"] for _, p in lines]
    ops = [100 * p["operation_spread"] for _, p in lines if p.get("operation_spread") is not None]
    between_ops = f", between a machine's operations {span(ops)} %" if ops else ""
    outside = "".join(
        f"; {', '.join(names)} {let_go_text(serial, reason)}"
        for serial, reason, names in let_go_groups(lines, "widened_by_part")
    )
    checked = band_checked(lines)
    outside += f"; {checked}" if checked else ""
    left = left_out_said(plan, ((op, p) for op, ps in by_operation for p in ps))
    outside += f"; {left}" if left else ""
    rest = from_catalogue(plan)
    outside += f"; {', '.join(rest)} from {CATALOGUE}" if rest else ""
    return (
        f"the fleet: {_in_all(provenances, 'plans')} on {_in_all(provenances, 'machines')}, "
        f"between-machine spread {span(spreads)} %{between_ops} (rcb plans show lists each "
        "quantity's)"
        f"{outside}{noise_line(plan.get('noise_provenance', []))}"
    )


def noise_line(noise: Sequence[Mapping[str, Any]]) -> str:
    """The measuring chains' noise priors from the fleet, and those let go (none: nothing)."""
    if not noise:
        return ""
    chains = ", ".join(f"{p['quantity']} {p['noise_scale']:.2f} x u" for p in noise)
    let_go = "".join(
        f"; {', '.join(names)} noise {let_go_text(serial, reason)}"
        for serial, reason, names in let_go_groups(
            ((p["quantity"], p) for p in noise), "let_go_by_part"
        )
    )
    return f"; measuring chains' noise from the fleet: {chains}{let_go}"


def prior_caption(
    lines: list[tuple[str, Mapping[str, Any]]], answer: Mapping[str, Any] | None = None
) -> str | None:
    """``rcb plans show``'s fleet prior table's caption: let go, band checked, left out.

    ``answer``: the plan's, whose operations name their tools (None: operations named).
    """
    named = [(f"{op} {line['quantity']}", line) for op, line in lines]
    left = left_out_said(answer or {}, lines)
    said = [let_go_caption(lines, "widened_by_part"), band_checked(named), left]
    return "\n".join(s for s in said if s) or None


def let_go_caption(lines: list[tuple[str, Mapping[str, Any]]], field: str) -> str | None:
    """``let go by part c-1: REASON``, a line per part and reason (None: nothing let go)."""
    groups = let_go_groups(lines, field)
    return "\n".join(let_go_text(serial, reason) for serial, reason, _ in groups) or None
