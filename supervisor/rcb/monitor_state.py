"""What a monitor keeps between reports and what it judges a reading against.

The state of :mod:`supervisor.rcb.monitor` (its docstring says how :func:`~supervisor.rcb.
monitor.watch` uses it): the expectation a strategy hands it, the readings it keeps and, per
operation and quantity, the :class:`Monitor` stored with the band state
(``band_states.monitor``), with its JSON form.
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass
from typing import Any

from supervisor.rcb.noise import NOISE_PRIOR, NOISE_RATE, NoiseScale


@dataclass(frozen=True)
class Expected:
    """What a strategy expects of a reading: ``ln y ~ mean ± sd`` (without the reading's noise).

    ``noise``: a part of the spread that is readings' noise (the chain's last reading), in
    ``ln`` at the reported scale: it is counted at the measured scale ``ŝ``. ``shift``: how far
    the exponents moved the chain's reading to this setpoint (``ln``); a difference whose
    shift is larger than the pair's noise says more about the exponents than about the noise,
    and the noise scale does not learn from it (successive differences at nearly one setpoint).
    """

    mean: float
    sd: float
    noise: float = 0.0
    shift: float = 0.0
    #: ``sd`` with the readings behind it counted at the noise scale as estimated (``learn``,
    #: whose ``sd`` counts them at a prudent upper quantile): what the noise update takes out
    #: of an innovation (None: ``sd``).
    estimate_sd: float | None = None


@dataclass(frozen=True)
class Reading:
    """A reading kept by the monitor: ``ln y``, its reported noise ``s`` in ``ln``, ``ln x``."""

    ln_y: float
    noise: float
    ln_x: Mapping[str, float]
    age: int | None = None

    def to_json(self) -> dict[str, Any]:
        """A JSON-ready mapping."""
        return {"ln_y": self.ln_y, "noise": self.noise, "ln_x": dict(self.ln_x), "age": self.age}


def _reading(data: Mapping[str, Any] | None) -> Reading | None:
    if data is None:
        return None
    ln_x = {str(k): float(v) for k, v in data["ln_x"].items()}
    age = data.get("age")
    return Reading(
        float(data["ln_y"]), float(data["noise"]), ln_x, None if age is None else int(age)
    )


@dataclass(frozen=True)
class Monitor:
    """Per operation and quantity: the noise scale's belief, the last and the held reading.

    Parameters
    ----------
    shape, rate : float
        ``a`` and ``b`` of the inverse-gamma belief on the noise variance's scale ``λ`` from the
        prior and this operation's readings, none taken while a drift is in progress
        (``monitor.DRIFTING``): the operation's own ``ŝ``, which the band law and the alarm read.
    chain_shape, chain_rate : float
        The same belief with the readings of a drift in progress counted too: this
        operation's share of its measuring chain's noise (:func:`supervisor.rcb.noise.pooled`
        adds the other operations'), which ``learn``'s likelihood reads. The gate protects
        the alarm from a drift counted as noise; a likelihood that leaves out the largest
        innovations learns a noise too low (all five faults, 30 scenarios: a chain 3x
        noisier than it claims was estimated at 2.59, p10 2.29, after 14 parts with the
        gate, 2.98, p10 2.73, without), and a drift counted as noise only widens the cone.
    last : Reading or None
        The last reading learned from (the reference of the next successive difference).
    held : Reading or None
        A quarantined reading waiting for the next one to confirm or drop it.
    quarantined, changes : int
        Readings quarantined and changes detected so far.
    cusum, drift_sum, drift_n : float, float, int
        The upper CUSUM of the high side's ``r`` (``monitor.CUSUM_K``, ``CUSUM_H``), and the
        sum and count of the innovations ``e`` since it last stood at 0 (their mean is the
        shift a CUSUM alarm discounts).
    noise_llr, chain_alarm : float
        This part's reading's log-likelihood ratio of a chain noisier than its evidence says,
        and the chain's CUSUM of them, the same in each of its operations' monitors
        (:mod:`supervisor.rcb.noise_watch`).
    """

    shape: float = NOISE_PRIOR
    rate: float = NOISE_RATE
    last: Reading | None = None
    held: Reading | None = None
    quarantined: int = 0
    changes: int = 0
    cusum: float = 0.0
    drift_sum: float = 0.0
    drift_n: int = 0
    chain_shape: float = NOISE_PRIOR
    chain_rate: float = NOISE_RATE
    noise_llr: float = 0.0
    chain_alarm: float = 0.0

    @property
    def noise(self) -> NoiseScale:
        """The monitor's own belief on the noise scale, gated by ``monitor.DRIFTING``."""
        return NoiseScale(self.shape, self.rate)

    def chain_kept(self, keep: float) -> tuple[float, float]:
        """``(a, b)`` of the chain's evidence with ``keep`` of it kept over the prior's.

        Variance discounting (West & Harrison §10.8): each reading's memory
        (``monitor.NOISE_KEEP``) and an alarm's cut (``noise_watch.INTERVENTION``).
        """
        return (
            NOISE_PRIOR + keep * (self.chain_shape - NOISE_PRIOR),
            NOISE_RATE + keep * (self.chain_rate - NOISE_RATE),
        )

    @property
    def chain_noise(self) -> NoiseScale:
        """The operation's evidence on its chain's noise (the chain's: :func:`~.noise.pooled`)."""
        return NoiseScale(self.chain_shape, self.chain_rate)

    @property
    def scale(self) -> float:
        """``ŝ`` of this monitor's own belief (:attr:`NoiseScale.scale`)."""
        return self.noise.scale

    def to_json(self) -> dict[str, Any]:
        """A JSON-ready mapping (:func:`from_json` reads it back)."""
        return {
            "shape": self.shape,
            "rate": self.rate,
            "last": None if self.last is None else self.last.to_json(),
            "held": None if self.held is None else self.held.to_json(),
            "quarantined": self.quarantined,
            "changes": self.changes,
            "cusum": self.cusum,
            "drift_sum": self.drift_sum,
            "drift_n": self.drift_n,
            "chain_shape": self.chain_shape,
            "chain_rate": self.chain_rate,
            "noise_llr": self.noise_llr,
            "chain_alarm": self.chain_alarm,
        }


def from_json(data: Mapping[str, Any]) -> Monitor:
    """The :class:`Monitor` of :meth:`Monitor.to_json`.

    A monitor stored before the chain belief had keys of its own reads its gated one there.
    """
    shape, rate = float(data["shape"]), float(data["rate"])
    return Monitor(
        shape,
        rate,
        _reading(data.get("last")),
        _reading(data.get("held")),
        int(data.get("quarantined", 0)),
        int(data.get("changes", 0)),
        float(data.get("cusum", 0.0)),
        float(data.get("drift_sum", 0.0)),
        int(data.get("drift_n", 0)),
        float(data.get("chain_shape", shape)),
        float(data.get("chain_rate", rate)),
        float(data.get("noise_llr", 0.0)),
        float(data.get("chain_alarm", 0.0)),
    )
