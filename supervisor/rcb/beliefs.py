"""What a strategy reads of an RCB state: a protocol that :class:`~.state.RcbState` meets.

The strategies (:mod:`supervisor.rcb.strategies`) are named by the state's settings, so they
read the state through this view instead of importing it (no import cycle).
"""

from __future__ import annotations

from collections.abc import Mapping
from typing import TYPE_CHECKING, Protocol

if TYPE_CHECKING:
    from models.tool import Tool
    from supervisor.inputs.plan import Plan
    from supervisor.rcb.posterior import Posterior
    from supervisor.rcb.wear import WearRise


class Settings(Protocol):
    """The settings a strategy reads (:class:`supervisor.rcb.state.RcbSettings`)."""

    @property
    def coverage_k(self) -> float: ...  # noqa: D102
    @property
    def exponent_sd(self) -> float: ...  # noqa: D102
    @property
    def edge_sd(self) -> float: ...  # noqa: D102
    @property
    def z(self) -> float: ...  # noqa: D102
    @property
    def tau(self) -> float: ...  # noqa: D102


class Beliefs(Protocol):
    """The state a strategy reads (:class:`supervisor.rcb.state.RcbState`)."""

    @property
    def plan(self) -> Plan: ...  # noqa: D102
    @property
    def tools(self) -> Mapping[str, Tool]: ...  # noqa: D102
    @property
    def settings(self) -> Settings: ...  # noqa: D102
    @property
    def posterior(self) -> Mapping[tuple[str, str], Posterior]: ...  # noqa: D102
    @property
    def priors(self) -> Mapping[tuple[str, str], Posterior]: ...  # noqa: D102
    @property
    def wear(self) -> Mapping[tuple[str, str], WearRise]: ...  # noqa: D102
