"""What one measurement did to one band: the decision RCB stores and every surface shows."""

from __future__ import annotations

from dataclasses import dataclass
from typing import Literal

Action = Literal["shrink", "hold", "expand"]
#: What made a decision flagged: the limit crossed, or the measurement beyond the band's
#: guarding edge (``above_band`` for a maximum, ``below_band`` for a minimum).
Flag = Literal["breach", "above_band", "below_band"]
#: Information, never a flag: the measurement beyond the band's other edge, past the limit
#: by more than its ±u but within its noise's alarm limit (``past_limit``: the part is out of
#: tolerance by ISO 14253-1's rule; the process is not proven past the limit), far below what
#: the model and its scatter allow (``implausible_low``: a failing sensor, an air cut or a
#: broken insert; quarantined, no speed-up from it until later readings at that setpoint
#: confirm it), or the process changed (``regime_change``: a new batch, another insert
#: supplier; the old evidence is discounted and re-learned).
Note = Literal["below_band", "above_band", "past_limit", "implausible_low", "regime_change"]


@dataclass(frozen=True)
class Decision:
    """What one measurement did to one band.

    ``margin`` is ``limit − (measured + u)`` for a maximum and ``(measured − u) − limit`` for
    a minimum (``margin`` and ``limit`` are ``None`` for a quantity without a limit; for a
    wearing quantity with the edge's age reported, ``measured`` projected to the edge's last
    part, :mod:`supervisor.rcb.wear`);
    ``band_*`` are ``ΔY`` at the setpoint the part was made with. ``flag`` says why a
    decision is flagged (``breach``: the limit crossed; ``above_band``/``below_band``: past
    the band's guarding edge), ``note`` is information only (:data:`Note`: ``below_band`` for
    a maximum: the model is pessimistic there; ``implausible_low``: a reading quarantined as
    too good to be true; ``regime_change``: the process changed and is being re-learned);
    ``flagged`` is ``flag is not None``.
    """

    operation: str
    quantity: str
    action: Action
    margin: float | None
    band_before: float
    band_after: float
    dK_before: float
    dK_after: float
    K_before: float
    K_after: float
    predicted: float
    measured: float
    uncertainty: float
    limit: float | None
    flagged: bool
    reason: str
    flag: Flag | None = None
    note: Note | None = None
