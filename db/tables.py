"""SQLAlchemy 2.0 tables: machines, tools, plans, versions of models and setpoints, parts.

History is append-only: a band change is a new row in ``operation_model_versions``, a new
optimum a new ``setpoint_versions`` row with its ``setpoints``; nothing is updated in place
except the pointers ``plans.current_setpoint_version`` and ``plans.state_token``.
Units live in column names, as in the domain objects.
"""

from __future__ import annotations

from datetime import UTC, datetime
from typing import Any, cast

from sqlalchemy import (
    JSON,
    DateTime,
    ForeignKey,
    Index,
    MetaData,
    String,
    Table,
    Text,
    UniqueConstraint,
)
from sqlalchemy.orm import DeclarativeBase, Mapped, mapped_column

from models.bounds import LARGEST_WHOLE

#: Stable constraint names, so Alembic migrations name them the same on every database.
NAMING_CONVENTION = {
    "ix": "ix_%(column_0_label)s",
    "uq": "uq_%(table_name)s_%(column_0_N_name)s",
    "ck": "ck_%(table_name)s_%(constraint_name)s",
    "fk": "fk_%(table_name)s_%(column_0_name)s_%(referred_table_name)s",
    "pk": "pk_%(table_name)s",
}

#: The largest value an integer column holds (PostgreSQL's ``integer``: 32 bits): every id,
#: version and count the service takes is bounded by it (:data:`models.bounds.LARGEST_WHOLE`).
MAX_INT = LARGEST_WHOLE


def utcnow() -> datetime:
    """Timezone-aware current time (stored as UTC)."""
    return datetime.now(UTC)


class Base(DeclarativeBase):
    """Declarative base with the naming convention."""

    metadata = MetaData(naming_convention=NAMING_CONVENTION)
    type_annotation_map = {
        dict[str, Any]: JSON,
        list[Any]: JSON,
        datetime: DateTime(timezone=True),
    }


def core_table(entity: type[Base]) -> Table:
    """The Core table of a mapped class (for inserts without the ORM's unit of work)."""
    return cast(Table, entity.__table__)


class Machine(Base):
    """A machine tool and its limits."""

    __tablename__ = "machines"
    id: Mapped[int] = mapped_column(primary_key=True)
    name: Mapped[str] = mapped_column(String(200), unique=True)
    #: The limits keyed by quantity (``{"power_kW": 22.0}``; a quantity absent: no limit), as
    #: :attr:`supervisor.inputs.plan.Machine.limit_of` holds them (alembic 0012).
    limits: Mapped[dict[str, Any]] = mapped_column(server_default="{}")
    created_at: Mapped[datetime] = mapped_column(default=utcnow)


class Tool(Base):
    """A cutting tool (catalogue or added by an engineer)."""

    __tablename__ = "tools"
    id: Mapped[int] = mapped_column(primary_key=True)
    #: compared in code-point order, as Python sorts the catalogue: GET /tools pages by it
    #: (SQLite's text order already; PostgreSQL's collation "C", migration 0008)
    name: Mapped[str] = mapped_column(
        String(200).with_variant(String(200, collation="C"), "postgresql"), unique=True
    )
    process: Mapped[str] = mapped_column(String(20))
    description: Mapped[str] = mapped_column(Text, default="")
    material: Mapped[str] = mapped_column(Text, default="")
    source: Mapped[str] = mapped_column(Text, default="")
    created_at: Mapped[datetime] = mapped_column(default=utcnow)


class ToolModel(Base):
    """A tool's baseline model of one quantity, with provenance."""

    __tablename__ = "tool_models"
    __table_args__ = (UniqueConstraint("tool_id", "quantity"),)
    id: Mapped[int] = mapped_column(primary_key=True)
    tool_id: Mapped[int] = mapped_column(ForeignKey("tools.id"))
    quantity: Mapped[str] = mapped_column(String(50))
    K: Mapped[float]
    dK: Mapped[float]
    exponents: Mapped[dict[str, Any]]
    source: Mapped[str] = mapped_column(Text, default="")
    reference: Mapped[str] = mapped_column(Text, default="")


class Plan(Base):
    """A plan: the structure as given (JSON), its RCB law and the current setpoint version."""

    __tablename__ = "plans"
    #: A name names one plan (alembic 0011): PLAN arguments take it as well as the id.
    __table_args__ = (Index("ix_plans_name", "name", unique=True),)
    id: Mapped[int] = mapped_column(primary_key=True)
    name: Mapped[str] = mapped_column(String(200))
    machine_id: Mapped[int] = mapped_column(ForeignKey("machines.id"))
    body: Mapped[dict[str, Any]]
    #: Every RCB setting of the plan by name (supervisor.rcb.settings.SETTINGS: strategy,
    #: alpha, floors ...; db.plan_state); a key missing (halt_over before it existed): the
    #: default. Strategy and alpha were columns before alembic 0013.
    settings: Mapped[dict[str, Any] | None]
    #: The priors the plan started from where not the catalogue's, per "operation|quantity":
    #: ``posterior`` and ``provenance`` (db.fleet_prior, alembic 0014); NULL: the catalogue.
    prior: Mapped[dict[str, Any] | None] = mapped_column(JSON(none_as_null=True))
    #: The changes of its process an engineer accepted putting it back in the fleet (db.fleet).
    fleet_changes_accepted: Mapped[int] = mapped_column(default=0, server_default="0")
    #: The conflicts of a halted plan (db.plan_state); NULL while it runs.
    halt: Mapped[dict[str, Any] | None] = mapped_column(JSON(none_as_null=True))
    current_setpoint_version: Mapped[int] = mapped_column(default=1)
    #: A new random value with every write to the plan's RCB state (a part, a replan): what
    #: an in-process cache of the loaded state is keyed on (db.state_cache).
    state_token: Mapped[str] = mapped_column(String(32), default="", server_default="")
    created_at: Mapped[datetime] = mapped_column(default=utcnow)


class Operation(Base):
    """One operation of a plan, in plan order."""

    __tablename__ = "operations"
    __table_args__ = (
        UniqueConstraint("plan_id", "name"),
        UniqueConstraint("plan_id", "position"),
        Index("ix_operations_tool", "tool_id"),  # the fleet of a tool (db.fleet, alembic 0014)
    )
    id: Mapped[int] = mapped_column(primary_key=True)
    plan_id: Mapped[int] = mapped_column(ForeignKey("plans.id"))
    position: Mapped[int]
    name: Mapped[str] = mapped_column(String(200))
    process: Mapped[str] = mapped_column(String(20))
    tool_id: Mapped[int] = mapped_column(ForeignKey("tools.id"))
    volume_mm3: Mapped[float]
    limits: Mapped[dict[str, Any]]
    bounds: Mapped[dict[str, Any]]
    context: Mapped[dict[str, Any]]


class OperationModelVersion(Base):
    """The model in force for one operation and quantity, version by version.

    Bands are per operation and quantity (Ivester & Heigel Table 5 treats steps 2 and 3, both
    VCMR331, separately). ``cause`` is ``initial``, ``part`` (with ``part_id``) or ``replan``.
    """

    __tablename__ = "operation_model_versions"
    __table_args__ = (
        UniqueConstraint("operation_id", "quantity", "version"),
        # the model in force at a part's setpoint version, and the part-less ones (db.read.history)
        Index("ix_operation_model_versions_quantity_part", "operation_id", "quantity", "part_id"),
        Index("ix_operation_model_versions_part", "operation_id", "part_id", "quantity"),
    )
    id: Mapped[int] = mapped_column(primary_key=True)
    operation_id: Mapped[int] = mapped_column(ForeignKey("operations.id"))
    quantity: Mapped[str] = mapped_column(String(50))
    version: Mapped[int]
    K: Mapped[float]
    dK: Mapped[float]
    exponents: Mapped[dict[str, Any]]
    cause: Mapped[str] = mapped_column(String(20))
    part_id: Mapped[int | None] = mapped_column(ForeignKey("parts.id"))
    created_at: Mapped[datetime] = mapped_column(default=utcnow)


class SetpointVersion(Base):
    """One version of a plan's setpoints and why it was made."""

    __tablename__ = "setpoint_versions"
    __table_args__ = (UniqueConstraint("plan_id", "version"),)
    id: Mapped[int] = mapped_column(primary_key=True)
    plan_id: Mapped[int] = mapped_column(ForeignKey("plans.id"))
    version: Mapped[int]
    cause: Mapped[str] = mapped_column(String(20))
    part_id: Mapped[int | None] = mapped_column(ForeignKey("parts.id"))
    created_at: Mapped[datetime] = mapped_column(default=utcnow)


class Setpoint(Base):
    """One operation's parameters, predictions with bands and binding limits in a version."""

    __tablename__ = "setpoints"
    __table_args__ = (UniqueConstraint("setpoint_version_id", "operation_id"),)
    id: Mapped[int] = mapped_column(primary_key=True)
    setpoint_version_id: Mapped[int] = mapped_column(ForeignKey("setpoint_versions.id"))
    operation_id: Mapped[int] = mapped_column(ForeignKey("operations.id"))
    parameters: Mapped[dict[str, Any]]
    predicted: Mapped[dict[str, Any]]
    binding: Mapped[list[Any]]
    mrr_cm3_min: Mapped[float]
    time_min: Mapped[float]
    #: objective, cost_per_kg, constant_load (:mod:`supervisor.optimize.extras`); NULL before 0004
    extras: Mapped[dict[str, Any] | None]


class Part(Base):
    """A part reported by the MES; ``setpoint_version`` is the one it was made with."""

    __tablename__ = "parts"
    __table_args__ = (
        UniqueConstraint("plan_id", "serial"),
        Index("ix_parts_plan_received", "plan_id", "received_at"),  # rcb parts --since
    )
    id: Mapped[int] = mapped_column(primary_key=True)
    plan_id: Mapped[int] = mapped_column(ForeignKey("plans.id"))
    serial: Mapped[str] = mapped_column(String(200))
    setpoint_version: Mapped[int]
    received_at: Mapped[datetime] = mapped_column(default=utcnow)


class Measurement(Base):
    """One measured quantity of one operation of a part; ``raw`` keeps an unconverted signal."""

    __tablename__ = "measurements"
    __table_args__ = (UniqueConstraint("part_id", "operation_id", "quantity"),)
    id: Mapped[int] = mapped_column(primary_key=True)
    part_id: Mapped[int] = mapped_column(ForeignKey("parts.id"))
    operation_id: Mapped[int] = mapped_column(ForeignKey("operations.id"))
    quantity: Mapped[str] = mapped_column(String(50))
    value: Mapped[float]
    uncertainty: Mapped[float]
    raw: Mapped[dict[str, Any] | None]


class RcbDecision(Base):
    """What one measurement did to one band (supervisor.rcb.state.Decision).

    Every field of the Decision but its operation (stored as ``operation_id``) and the
    measured, predicted, uncertainty and limit it was made from (the part's measurement, the
    setpoint version and the operation hold those) has a column of its own name;
    tests/db/test_decision_columns.py pins this.
    """

    __tablename__ = "rcb_decisions"
    id: Mapped[int] = mapped_column(primary_key=True)
    part_id: Mapped[int] = mapped_column(ForeignKey("parts.id"), index=True)  # a page's parts
    operation_id: Mapped[int] = mapped_column(ForeignKey("operations.id"))
    quantity: Mapped[str] = mapped_column(String(50))
    action: Mapped[str] = mapped_column(String(10))
    margin: Mapped[float | None]
    band_before: Mapped[float]
    band_after: Mapped[float]
    dK_before: Mapped[float]
    dK_after: Mapped[float]
    K_before: Mapped[float]
    K_after: Mapped[float]
    flagged: Mapped[bool]
    reason: Mapped[str] = mapped_column(Text)
    #: ``breach``, ``above_band`` or ``below_band`` when flagged (NULL before 0005)
    flag: Mapped[str | None] = mapped_column(String(20))
    #: information only (supervisor.rcb.state.Note): ``below_band`` (a maximum) or
    #: ``above_band`` (a minimum), ``past_limit``, ``implausible_low``, ``regime_change``
    note: Mapped[str | None] = mapped_column(String(20))


class ApiKey(Base):
    """An API key, stored only as a hash, with its role."""

    __tablename__ = "api_keys"
    id: Mapped[int] = mapped_column(primary_key=True)
    key_hash: Mapped[str] = mapped_column(String(128), unique=True)
    role: Mapped[str] = mapped_column(String(20))
    label: Mapped[str] = mapped_column(Text, default="")
    created_at: Mapped[datetime] = mapped_column(default=utcnow)
    revoked_at: Mapped[datetime | None]
    #: the plan ids the key may see (NULL: every plan, as before 0006)
    plans: Mapped[list[int] | None] = mapped_column(JSON(none_as_null=True))
    #: the last request the key authenticated, to the minute (NULL: never used)
    last_used_at: Mapped[datetime | None]


class IdempotencyRecord(Base):
    """A POST's Idempotency-Key: its request hash and, once done, the stored response."""

    __tablename__ = "idempotency_records"
    __table_args__ = (UniqueConstraint("api_key_id", "key"),)
    id: Mapped[int] = mapped_column(primary_key=True)
    api_key_id: Mapped[int | None] = mapped_column(ForeignKey("api_keys.id"))
    key: Mapped[str] = mapped_column(String(255))
    request_hash: Mapped[str] = mapped_column(String(64))
    state: Mapped[str] = mapped_column(String(20))
    response_status: Mapped[int | None]
    response_body: Mapped[dict[str, Any] | None]
    created_at: Mapped[datetime] = mapped_column(default=utcnow, index=True)


class AuthBucket(Base):
    """A client address's wrong-key allowance, shared by every instance (db.auth_buckets).

    ``tat_s``: the time [s, Unix] at which its bucket is full again plus one period (the
    generic cell rate algorithm's theoretical arrival time).
    """

    __tablename__ = "auth_buckets"
    client: Mapped[str] = mapped_column(String(64), primary_key=True)
    tat_s: Mapped[float]


class AuditEntry(Base):
    """Append-only audit log: who did what, when, with what result."""

    __tablename__ = "audit_log"
    id: Mapped[int] = mapped_column(primary_key=True)
    at: Mapped[datetime] = mapped_column(default=utcnow, index=True)
    actor: Mapped[str] = mapped_column(String(200))
    action: Mapped[str] = mapped_column(String(100))
    target: Mapped[str] = mapped_column(Text, default="")
    result: Mapped[str] = mapped_column(String(50))
    detail: Mapped[dict[str, Any] | None]


class BandState(Base):
    """RCB state of one operation and quantity after a part, beyond its model version.

    ``seen``: the most demanding measurement so far as a K-equivalent (supervisor.rcb.update);
    ``sigma``: the posterior σ of ln K (bayes); ``posterior``: the ``learn`` strategy's belief
    (:meth:`supervisor.rcb.posterior.Posterior.to_json`), NULL for other strategies; ``wear``:
    the rise per part an edge makes (:meth:`supervisor.rcb.wear.WearRise.to_json`), NULL for a
    quantity that does not wear; ``monitor``: what RCB watches in the readings (the noise scale,
    the last reading learned from, a quarantined one: :meth:`supervisor.rcb.monitor_state.Monitor.
    to_json`), NULL for rows stored before 0010. Appended per part; the newest row is in force.
    """

    __tablename__ = "band_states"
    __table_args__ = (UniqueConstraint("operation_id", "quantity", "part_id"),)
    id: Mapped[int] = mapped_column(primary_key=True)
    operation_id: Mapped[int] = mapped_column(ForeignKey("operations.id"))
    quantity: Mapped[str] = mapped_column(String(50))
    part_id: Mapped[int] = mapped_column(ForeignKey("parts.id"))
    seen: Mapped[float]
    sigma: Mapped[float]
    posterior: Mapped[dict[str, Any] | None]
    wear: Mapped[dict[str, Any] | None]
    monitor: Mapped[dict[str, Any] | None]


class ImportedModel(Base):
    """A learned model another database exported (``rcb models import``, :mod:`db.fleet`).

    ``body``: one item of the document (:func:`supervisor.fleet.document.item_json`);
    ``source``: where it came from (the file's name and the exporting plan).
    """

    __tablename__ = "imported_models"
    __table_args__ = (Index("ix_imported_models_tool", "tool"),)
    id: Mapped[int] = mapped_column(primary_key=True)
    tool: Mapped[str] = mapped_column(String(200))
    body: Mapped[dict[str, Any]]
    source: Mapped[str] = mapped_column(Text)
    imported_at: Mapped[datetime] = mapped_column(default=utcnow)


class FleetExclusion(Base):
    """A plan or a machine an engineer took out of the fleet (``rcb fleet exclude``)."""

    __tablename__ = "fleet_exclusions"
    id: Mapped[int] = mapped_column(primary_key=True)
    plan_id: Mapped[int | None] = mapped_column(ForeignKey("plans.id"))
    machine: Mapped[str | None] = mapped_column(String(200))
    reason: Mapped[str] = mapped_column(Text)
    actor: Mapped[str] = mapped_column(String(200))
    created_at: Mapped[datetime] = mapped_column(default=utcnow)


class PlanRevision(Base):
    """An engineer's replan: the plan structure from then on, the changes, who made them.

    ``bands_reset_after_part``: with ``reset_bands``, band states of parts up to this id are
    forgotten (RCB starts again from the baseline bands).
    """

    __tablename__ = "plan_revisions"
    __table_args__ = (UniqueConstraint("plan_id", "setpoint_version"),)
    id: Mapped[int] = mapped_column(primary_key=True)
    plan_id: Mapped[int] = mapped_column(ForeignKey("plans.id"))
    setpoint_version: Mapped[int]
    body: Mapped[dict[str, Any]]
    changes: Mapped[dict[str, Any]]
    reset_bands: Mapped[bool]
    bands_reset_after_part: Mapped[int | None]
    actor: Mapped[str] = mapped_column(String(200))
    created_at: Mapped[datetime] = mapped_column(default=utcnow)
