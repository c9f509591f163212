"""Errors of the storage layer."""

from __future__ import annotations

from datetime import datetime


class ConflictError(Exception):
    """The request contradicts what is stored (a duplicate serial, a tool redefined).

    ``code``: the REST problem's (409).
    """

    code = "conflict"

    def __init__(self, field: str, value: object, reason: str) -> None:
        self.field, self.value, self.reason = field, value, reason
        super().__init__(f"{field} = {value!r}: {reason}")

    def extensions(self) -> dict[str, object] | None:
        """What the REST problem adds to its ``field`` and ``value`` (None: nothing)."""
        return None


class PlanNameTakenError(ConflictError):
    """A stored plan has this name already (a name names one plan: alembic 0011).

    ``code`` is the REST problem's (``plan_name_taken``); ``plan_id`` the stored plan's id.
    """

    code = "plan_name_taken"

    def __init__(self, name: str, plan_id: int) -> None:
        self.plan_id = plan_id
        super().__init__(
            "name",
            name,
            f"plan {plan_id} has this name; give the new plan another name, or change plan "
            f"{plan_id} with rcb replan {plan_id} (POST /plans/{plan_id}/replan)",
        )

    def extensions(self) -> dict[str, object]:
        """The stored plan's id."""
        return {"plan_id": self.plan_id}


class SerialTakenError(ConflictError):
    """A part of this serial was reported for the plan already.

    ``part_id`` and ``received_at`` are the stored part's: an MES that lost the answer of its
    first report (and sent it again without its Idempotency-Key) finds its part by them.
    """

    def __init__(self, serial: str, part_id: int, received_at: datetime) -> None:
        self.part_id, self.received_at = part_id, received_at
        at = received_at.isoformat(timespec="seconds").replace("+00:00", "Z")
        super().__init__(
            "serial", serial, f"already reported for this plan: part {part_id}, received {at}"
        )

    def extensions(self) -> dict[str, object]:
        """The stored part's id and when it was received."""
        # as the parts page writes it (pydantic: UTC as Z)
        at = self.received_at.isoformat().replace("+00:00", "Z")
        return {"part_id": self.part_id, "received_at": at}


class StoredPlanError(ConflictError):
    """A plan's stored value (a setting, a field of its structure) fails this version's check.

    The check was tightened since the value was stored. ``repair`` says how to set the value
    anew: a replan (``--rcb``, ``--limit``, ``--bound``) where it can change the field, else the
    plan created anew from its file. ``plan_id``: the plan; ``code``: the REST problem's.
    """

    code = "stored_plan_refused"

    def __init__(
        self, plan_id: int, plan: str, field: str, value: object, reason: str, repair: str
    ) -> None:
        self.plan_id = plan_id
        super().__init__(
            field,
            value,
            f"{reason}; plan {plan_id} ({plan}) stored it under an earlier version's check; "
            f"{repair}",
        )


class StoredSettingsError(StoredPlanError):
    """A plan's stored RCB setting fails this version's check.

    The plan cannot learn or be read by the fleet until an engineer sets the value anew:
    ``rcb replan PLAN --rcb NAME=VALUE`` (``POST /plans/{id}/replan``), which checks the stored
    settings with the given ones over them.
    """

    code = "stored_settings_refused"

    def __init__(self, plan_id: int, plan: str, name: str, value: object, reason: str) -> None:
        self.setting, self.check = name, reason
        super().__init__(
            plan_id,
            plan,
            f"settings.{name}",
            value,
            reason,
            f"set it anew: rcb replan {plan_id} --rcb {name}=VALUE "
            f'(POST /plans/{plan_id}/replan {{"rcb": {{"{name}": VALUE}}}})',
        )
