r"""Reference current and feed-rate limits from constant-feed tests (Tai et al. §II.F).

See :mod:`supervisor.constant_load` for the method, the bands and which end of the wear
interval sets the lower limit. Both :func:`constant_load_setup` (fit, then limits) and
:func:`limits_from_calibration` (limits of a plane already fitted) set

.. math::

    I_\text{ref} = \min\big(\eta\, I_\text{max},\ I_\text{strength}\big), \qquad
    f_\text{upper} = \frac{I_\text{ref} - A}{B}, \qquad
    f_\text{lower} = \frac{I_\text{ref} - A}{B} - \frac{k_1}{B} V_{B,\max} + k\,u_f

(Eq. 15 at ``VB = 0`` and at the worn end of the interval; the band ``k·u_f`` raises the lower
limit). The nominal wear at the lower limit is ``V_B,max − k·u_f·B/k1``.

Both refuse, naming the field and value (:class:`~models.errors.InputError`): too few cuts, no
worn cuts, a current that does not rise with wear, a safety factor outside (0, 1], a reversed
interval, a reference current at or below the idle current, a lower limit at or above the upper
one, a band wider than the interval.
"""

from __future__ import annotations

from collections.abc import Iterable
from dataclasses import dataclass
from typing import Literal

from models.errors import InputError, ModelDomainError
from models.fields import number
from models.sensors import TaiCurrentFeedCalibration, fit_tai_calibration, tai_feed_rate_mm_min
from supervisor.constant_load.strength import COVERAGE_K, ForceLimit, strength_current_A

#: Tai et al. §III.A: the reference current is 0.85 × the largest current withstood.
PAPER_SAFETY_FACTOR = 0.85
#: Tai et al. §II.G: the flank wear at tool change, 180-220 µm [mm].
PAPER_WEAR_INTERVAL_MM = (0.180, 0.220)

Governor = Literal["safety_factor", "strength"]


@dataclass(frozen=True)
class FeedLimit:
    """A feed-rate limit of constant-load milling, with its band and the wear it stands for.

    Parameters
    ----------
    feed_rate_mm_min : float
        The limit [mm/min].
    band_mm_min : float
        Its expanded band ``k·u`` [mm/min] (single cut: fit covariance and scatter ``s``).
    flank_wear_mm : float
        Nominal flank wear at which the feed under constant load equals the limit [mm].
    flank_wear_band_mm : float
        Its band [mm]: ``flank_wear_mm + flank_wear_band_mm`` is the worn end of the interval
        for the lower limit; 0 for the upper limit (a sharp tool).
    """

    feed_rate_mm_min: float
    band_mm_min: float
    flank_wear_mm: float
    flank_wear_band_mm: float


@dataclass(frozen=True)
class ConstantLoadSetup:
    """Reference current and feed-rate limits for constant-load milling (Tai et al. §II.F).

    Parameters
    ----------
    calibration : TaiCurrentFeedCalibration
        The plane ``I = A + B·f + k1·VB`` fitted to the tests (Eq. 14).
    max_current_A : float
        Largest current the tool withstood [A].
    safety_factor : float
        Fraction of it allowed [-].
    reference_current_A : float
        The current the controller holds [A].
    governed_by : {"safety_factor", "strength"}
        Which bound set the reference current.
    strength_current_A : float or None
        Largest current whose upper force band stays within the tool's strength [A]; None
        without a :class:`ForceLimit`.
    upper, lower : FeedLimit
        Upper feed limit (sharp tool) and lower feed limit (tool change).
    wear_interval_mm : tuple[float, float]
        Flank wear interval at tool change [mm].
    coverage_k : float
        Coverage factor of every band [-].
    """

    calibration: TaiCurrentFeedCalibration
    max_current_A: float
    safety_factor: float
    reference_current_A: float
    governed_by: Governor
    strength_current_A: float | None
    upper: FeedLimit
    lower: FeedLimit
    wear_interval_mm: tuple[float, float]
    coverage_k: float


def constant_load_setup(
    feed_rates_mm_min: Iterable[float],
    currents_A: Iterable[float],
    flank_wears_mm: Iterable[float],
    *,
    safety_factor: float = PAPER_SAFETY_FACTOR,
    wear_interval_mm: tuple[float, float] = PAPER_WEAR_INTERVAL_MM,
    max_current_A: float | None = None,
    strength: ForceLimit | None = None,
    coverage_k: float = COVERAGE_K,
    source: str = "constant-feed tests",
) -> ConstantLoadSetup:
    """Reference current and feed-rate limits from constant-feed tests (Tai et al. §II.F).

    Fits the plane ``I = A + B·f + k1·VB`` (Eq. 14), then the limits of Eq. 15 as
    :func:`limits_from_calibration`. The equations, and the refusals (an :class:`InputError`
    naming the field and value), are in the module docstring.

    Parameters
    ----------
    feed_rates_mm_min, currents_A, flank_wears_mm : iterable of float
        Per cut: feed rate [mm/min], spindle current [A] and flank wear [mm], sharp tools
        (``VB = 0``) and wear tests at constant feed; at least 4 cuts, some worn.
    safety_factor : float
        ``η`` in (0, 1] [-] (Tai et al. §III.A: 0.85, "a safety factor of 1.17").
    wear_interval_mm : tuple[float, float]
        Flank wear interval at tool change [mm], sharp end first (Tai et al. §II.G).
    max_current_A : float, optional
        Largest current the tool withstood [A] (default: the largest current in the tests).
    strength : ForceLimit, optional
        With it, ``I_strength`` is the largest current whose upper force band (coverage ``k``)
        stays at or under the strength (:func:`strength_current_A`).
    coverage_k : float
        Coverage factor of the bands [-], ``> 0``.
    source : str
        Provenance stored on the fitted calibration.

    Returns
    -------
    ConstantLoadSetup
        The setup.

    References
    ----------
    .. [1] Tai, Tsai & Li, Eqs. 13-15, §II.F and §III.A.
    """
    feeds, currents, wears = list(feed_rates_mm_min), list(currents_A), list(flank_wears_mm)
    eta, k, interval = _options(safety_factor, coverage_k, wear_interval_mm)  # before the fit
    cal = _fit_with_wear(feeds, currents, wears, source)
    return limits_from_calibration(
        cal,
        max_current_A=_withstood_current_A(max_current_A, currents),
        safety_factor=eta,
        wear_interval_mm=interval,
        strength=strength,
        coverage_k=k,
    )


def _withstood_current_A(max_current_A: float | None, currents: list[float]) -> float:
    """The largest current the tool withstood (Tai §III.A): given, else the tests' largest."""
    if max_current_A is None:
        return max(float(c) for c in currents)
    return number(max_current_A, "max_current_A", positive=True)


def _fit_with_wear(
    feeds: list[float], currents: list[float], wears: list[float], source: str
) -> TaiCurrentFeedCalibration:
    """The plane of Tai Eq. 14 fitted to the tests, refused without worn cuts or with ``k1 <= 0``.

    The lower feed limit needs the current to rise with wear, so wear tests must be there.
    """
    checked = [number(w, f"flank_wears_mm[{i}]", minimum=0.0) for i, w in enumerate(wears)]
    if len(feeds) >= 4 and not any(checked):
        raise InputError(
            "flank_wears_mm",
            max(checked),
            "is the largest flank wear: no worn cuts, and the lower feed limit needs wear tests "
            "at constant feed (Tai Fig. 7)",
        )
    cal = fit_tai_calibration(feeds, wears, currents, source=source)
    k1 = cal.wear_coefficient_A_per_mm
    if k1 <= 0:
        raise ModelDomainError(
            "wear_coefficient_A_per_mm",
            k1,
            "k1 fitted to flank_wears_mm and currents_A is not positive: the current must rise "
            "with flank wear to set a lower feed limit (Tai Eq. 14)",
        )
    return cal


def limits_from_calibration(
    cal: TaiCurrentFeedCalibration,
    *,
    max_current_A: float,
    safety_factor: float = PAPER_SAFETY_FACTOR,
    wear_interval_mm: tuple[float, float] = PAPER_WEAR_INTERVAL_MM,
    strength: ForceLimit | None = None,
    coverage_k: float = COVERAGE_K,
) -> ConstantLoadSetup:
    """Reference current and feed limits from a calibration already fitted (Tai et al. §II.F).

    What :func:`constant_load_setup` does after its fit, for a plane ``I = A + B·f + k1·VB``
    kept with the machine (a plan's ``tai_current_feed`` calibration); same equations, bands
    and refusals. ``max_current_A`` is the largest current the tool withstood [A].
    """
    eta, k, (sharp_end, worn_end) = _options(safety_factor, coverage_k, wear_interval_mm)
    i_max = number(max_current_A, "max_current_A", positive=True)
    a, k1 = cal.idle_current_A, cal.wear_coefficient_A_per_mm
    if k1 <= 0:
        raise ModelDomainError(
            "wear_coefficient_A_per_mm",
            k1,
            "is not positive: the current must rise with flank wear to set a lower feed limit "
            "(Tai Eq. 14)",
        )
    i_strength = None if strength is None else strength_current_A(strength, coverage_k=k)
    i_ref, governed_by = _reference_current(a, eta, i_max, i_strength)
    up, u_up = tai_feed_rate_mm_min(cal, i_ref, 0.0, u_current_A=cal.residual_sd_A)
    low, u_worn, wear_band = _lower_limit(cal, i_ref, up, wear_interval_mm, worn_end, k)
    if worn_end - wear_band < sharp_end:
        raise ModelDomainError(
            "wear_interval_mm",
            wear_interval_mm,
            f"the band of the wear at tool change, ±{wear_band * 1000:.1f} µm, is wider than the "
            f"interval: the nominal wear at the lower feed limit would be "
            f"{(worn_end - wear_band) * 1000:.1f} µm; add tests or widen the interval",
        )
    return ConstantLoadSetup(
        calibration=cal,
        max_current_A=i_max,
        safety_factor=eta,
        reference_current_A=i_ref,
        governed_by=governed_by,
        strength_current_A=i_strength,
        upper=FeedLimit(up, k * u_up, 0.0, 0.0),
        lower=FeedLimit(low, k * u_worn, worn_end - wear_band, wear_band),
        wear_interval_mm=(sharp_end, worn_end),
        coverage_k=k,
    )


def _reference_current(
    idle_A: float, eta: float, i_max: float, i_strength: float | None
) -> tuple[float, Governor]:
    """``min(η·I_max, I_strength)`` and which bound set it; refused at or below the idle current.

    At or below ``A`` no feed rate draws the reference current (Tai Eq. 13 at ``f = 0``).
    """
    by_factor = eta * i_max
    governed_by: Governor = "safety_factor"
    i_ref = by_factor
    if i_strength is not None and i_strength < by_factor:
        governed_by, i_ref = "strength", i_strength
    if i_ref <= idle_A:
        how = (
            f"the strength limit's current {i_ref:.4g} A"
            if governed_by == "strength"
            else f"safety_factor {eta:g} × max_current_A {i_max:.4g} A"
        )
        raise ModelDomainError(
            "reference_current_A",
            i_ref,
            f"{how} is at or below the idle current A = {idle_A:.4g} A: no feed rate draws it",
        )
    return i_ref, governed_by


def _lower_limit(
    cal: TaiCurrentFeedCalibration,
    i_ref: float,
    up: float,
    wear_interval_mm: object,
    worn_end: float,
    k: float,
) -> tuple[float, float, float]:
    """Eq. 15 at the worn end raised by its band ``k·u``: the limit, ``u`` and the wear band.

    Refused when the worn tool draws the reference current without cutting, or when the limit
    is not below the upper one ``up``.
    """
    a, b, k1 = cal.idle_current_A, cal.slope_A_per_mm_min, cal.wear_coefficient_A_per_mm
    if i_ref - a - k1 * worn_end <= 0:
        raise ModelDomainError(
            "wear_interval_mm",
            wear_interval_mm,
            f"a tool worn to {worn_end * 1000:g} µm draws {a + k1 * worn_end:.4g} A without "
            f"cutting, at or above the reference current {i_ref:.4g} A",
        )
    worn, u_worn = tai_feed_rate_mm_min(cal, i_ref, worn_end, u_current_A=cal.residual_sd_A)
    low = worn + k * u_worn
    wear_band = k * u_worn * b / k1
    if low >= up:
        raise ModelDomainError(
            "wear_interval_mm",
            wear_interval_mm,
            f"the lower feed limit {low:.1f} mm/min is not below the upper one {up:.1f} mm/min",
        )
    return low, u_worn, wear_band


def _options(
    safety_factor: float, coverage_k: float, wear_interval_mm: object
) -> tuple[float, float, tuple[float, float]]:
    """Safety factor in (0, 1], coverage factor > 0 and the interval, checked."""
    eta = number(safety_factor, "safety_factor", positive=True)
    if eta > 1.0:
        raise InputError("safety_factor", safety_factor, "must be in (0, 1]")
    k = number(coverage_k, "coverage_k", positive=True)
    return eta, k, _interval(wear_interval_mm)


def _interval(value: object) -> tuple[float, float]:
    """``(sharp end, worn end)`` in mm, ``0 <= sharp <= worn``, ``worn > 0``."""
    if not isinstance(value, tuple | list) or len(value) != 2:
        raise InputError("wear_interval_mm", value, "must be two flank wears (sharp end, worn end)")
    lo = number(value[0], "wear_interval_mm[0]", minimum=0.0)
    hi = number(value[1], "wear_interval_mm[1]", positive=True)
    if lo > hi:
        raise InputError("wear_interval_mm", value, "reversed: the sharp end must come first")
    return lo, hi
