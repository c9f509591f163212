"""SQLAlchemy 2.0 tables: machines, tools, plans, versions of models and setpoints, parts.

History is append-only: a band change is a new row in ``operation_model_versions``, a new
optimum a new ``setpoint_versions`` row with its ``setpoints``; nothing is updated in place
except the pointers ``plans.current_setpoint_version`` and ``plans.state_token``.
Units live in column names, as in the domain objects.
"""

from __future__ import annotations

from datetime import datetime
from typing import Any

from sqlalchemy import (
    JSON,
    ForeignKey,
    Index,
    String,
    Text,
    UniqueConstraint,
    false,
    text,
)
from sqlalchemy.orm import Mapped, mapped_column

from db.access_tables import (
    ApiKey,
    AuditEntry,
    AuthBucket,
    AuthFailureWindow,
    IdempotencyRecord,
    UiSession,
)
from db.fleet_tables import DatabaseIdentity, FleetExclusion, ImportedModel
from db.table_base import MAX_INT, NAMING_CONVENTION, Base, core_table, utcnow

__all__ = [
    "MAX_INT", "NAMING_CONVENTION", "ApiKey", "AuditEntry", "AuthBucket", "AuthFailureWindow",
    "Base", "DatabaseIdentity", "FleetExclusion", "IdempotencyRecord", "ImportedModel",
    "UiSession", "core_table", "utcnow",
]  # fmt: skip


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
    #: Per quantity, the noise prior of the chain that reads it where the fleet's: ``shape``,
    #: ``rate`` and ``provenance`` (db.fleet_noise, alembic 0019); NULL: the default's.
    noise_prior: Mapped[dict[str, Any] | None] = mapped_column(JSON(none_as_null=True))
    #: The changes of its process an engineer accepted putting it back in the fleet (db.fleet).
    fleet_changes_accepted: Mapped[int] = mapped_column(default=0, server_default="0")
    #: The part its monitors counted a change of its process at beyond those accepted: what it
    #: learned before is compared with what it learned since (db.fleet_changes, alembic 0022).
    fleet_change_part: Mapped[int | None]
    #: Whether the readings since ``fleet_change_part`` confirmed its change: the plan waits
    #: for an engineer (db.fleet_changes, alembic 0023); false while none is or it is judged.
    fleet_change_confirmed: Mapped[bool] = mapped_column(default=False, server_default=false())
    #: The conflicts of a halted plan (db.plan_state); NULL while it runs.
    halt: Mapped[dict[str, Any] | None] = mapped_column(JSON(none_as_null=True))
    current_setpoint_version: Mapped[int] = mapped_column(default=1)
    #: The identity of the database the plan was created in where not this one's (alembic
    #: 0021): a copied database's plans keep the original's when the copy takes a new one
    #: (``rcb fleet identity --renew``), so their models travel as learned there. NULL: this
    #: database's (:mod:`db.identity`).
    origin: Mapped[str | None] = mapped_column(String(36))
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
        # the fleet of a tool: its plans by id, each machine's newest first (alembic 0027)
        Index("ix_operations_tool_plan", "tool_id", "plan_id"),  # db.fleet_members
        Index("ix_operations_tool_machine_plan", "tool_id", "machine_id", "plan_id"),  # window
    )
    id: Mapped[int] = mapped_column(primary_key=True)
    plan_id: Mapped[int] = mapped_column(ForeignKey("plans.id"))
    #: The plan's machine (a plan keeps it for life), beside the tool for the fleet's window.
    machine_id: Mapped[int] = mapped_column(ForeignKey("machines.id"))
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
        Index("ix_parts_plan_id", "plan_id", "id"),  # a page of parts, either order (0028)
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


#: The RCB decisions ``ix_rcb_decisions_marked`` holds: flagged, or with a note (alembic
#: 0028), in the words each dialect renders ``or_(flagged, note.is_not(None))`` with: SQLite
#: uses a partial index only where a query's terms are its words (db.read.record).
MARKED = {"postgresql": "flagged OR note IS NOT NULL", "sqlite": "flagged = 1 OR note IS NOT NULL"}


class RcbDecision(Base):
    """What one measurement did to one band (supervisor.rcb.state.Decision).

    Every field of the Decision but its operation (stored as ``operation_id``) and the
    uncertainty and limit it was made from (the part's measurement and the operation hold
    those) has a column of its own name; tests/db/test_decision_columns.py pins this.
    """

    __tablename__ = "rcb_decisions"
    __table_args__ = (
        # the newest decision of an operation's quantity (db.read.record.last_decisions)
        Index("ix_rcb_decisions_operation_quantity_part", "operation_id", "quantity", "part_id"),
        # the flagged or noted decisions alone (db.read.record.decision_totals)
        Index(
            "ix_rcb_decisions_marked",
            *("operation_id", "flagged", "flag", "note"),  # covering: the totals read no row
            postgresql_where=text(MARKED["postgresql"]),
            sqlite_where=text(MARKED["sqlite"]),
        ),
    )
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
    #: the model's prediction at the part's setpoint and the value judged (a spindle-load
    #: reading's converted force), as the part's report answered them; NULL before alembic 0029
    predicted: Mapped[float | None]
    measured: Mapped[float | None]


class BandState(Base):
    """RCB state of one operation and quantity after a part, beyond its model version.

    ``seen``: the most demanding measurement so far as a K-equivalent (supervisor.rcb.update);
    ``sigma``: the posterior σ of ln K (bayes); ``posterior``: the ``learn`` strategy's belief
    (:meth:`supervisor.rcb.posterior.Posterior.to_json`), NULL for other strategies; ``wear``:
    the rise per part an edge makes (:meth:`supervisor.rcb.wear.WearRise.to_json`), NULL for a
    quantity that does not wear; ``monitor``: what RCB watches in the readings (the noise scale,
    the last reading learned from, a quarantined one: :meth:`supervisor.rcb.monitor_state.Monitor.
    to_json`), NULL for rows stored before 0010. Appended per part; the newest row is in force
    (``rcb db prune`` deletes old rows a newer one replaced: :mod:`db.state_retention`).
    """

    __tablename__ = "band_states"
    __table_args__ = (UniqueConstraint("operation_id", "quantity", "part_id"),)
    id: Mapped[int] = mapped_column(primary_key=True)
    operation_id: Mapped[int] = mapped_column(ForeignKey("operations.id"))
    quantity: Mapped[str] = mapped_column(String(50))
    part_id: Mapped[int] = mapped_column(ForeignKey("parts.id"))
    seen: Mapped[float]
    sigma: Mapped[float]
    # None is SQL NULL (alembic 0027), so that ``IS NOT NULL`` finds the states with a belief
    posterior: Mapped[dict[str, Any] | None] = mapped_column(JSON(none_as_null=True))
    wear: Mapped[dict[str, Any] | None] = mapped_column(JSON(none_as_null=True))
    monitor: Mapped[dict[str, Any] | None] = mapped_column(JSON(none_as_null=True))


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
