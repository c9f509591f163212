r"""Cutting force of two-flute end milling in full immersion (Kim & Jeon Eq. 1), or a power law.

Kim & Jeon (Precision Engineering 2011, §3) adapt Zheng et al.'s model of the x and y forces
of a helical two-flute end mill in full immersion (180° engagement):

.. math::
    F_x &= \frac{K_s K_{rt} f_t d}{2} + \frac{K_s f_t h}{4\pi}\sin\frac{2\pi d}{h}
           \sqrt{1 + K_{rt}^2}\,\sin\left(2\theta - \frac{2\pi d}{h} + \psi\right) \\
    F_y &= \frac{K_s f_t d}{2} - \frac{K_s f_t h}{4\pi}\sin\frac{2\pi d}{h}
           \sqrt{1 + K_{rt}^2}\,\sin\left(2\theta - \frac{2\pi d}{h} + \psi\right)

with ``tan ψ = 1/K_rt``, the feed per tooth ``f_t = f/(N_s M)`` and the power laws of the
mean chip thickness ``t̄_c = 2 f_t/π`` fitted on Al6061-T6 (§3):
``K_s = 800 t̄_c^-0.197`` N/mm² and ``K_rt = 0.163 t̄_c^-0.353``.

Reading of ``h``. The paper calls ``h`` "the length of cut"; in the model ``2πd/h`` is the
angle by which a helical flute lags across the depth ``d`` (Zheng et al.), so ``h`` is read
as the helix lead ``π D / tan β``. Kim & Jeon give no helix angle; β = 30° is assumed (a
common general-purpose end mill), giving h = 54.4 mm for D = 10 mm. The choice matters
little: ``sin(2πd/h)·h/(2πd)`` is 0.980 at d = 3 mm.

The controlled quantity is the maximum of the resultant ``sqrt(F_x² + F_y²)`` per spindle
revolution (Kim & Jeon §4.1). Over a revolution ``sin(2θ − 2πd/h + ψ)`` takes every value in
``[−1, 1]`` and ``|F|²`` is convex in it, so the maximum is at ``±1``:

.. math:: F_\max = \max_{s = \pm 1}\sqrt{(a + A s)^2 + (b - A s)^2}, \qquad
          a = \tfrac12 K_s K_{rt} f_t d,\; b = \tfrac12 K_s f_t d,\;
          A = \tfrac{K_s f_t h}{4\pi}\sin\tfrac{2\pi d}{h}\sqrt{1 + K_{rt}^2}

Check against the paper (§5.1, N_s = 1500 rpm, D = 10 mm, F_d = 160 N): the model holds
160 N at 194 mm/min for d = 1.5 mm (paper: 190 mpm) and at 80 mm/min for d = 3.0 mm
(paper: 70 mpm). Kim & Jeon's "mpm" is mm/min (60 mpm at 1500 rpm on two flutes is a feed
of 0.02 mm/tooth; in m/min the forces would be a thousand times the 160 N reported).
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Protocol

from models import fields
from models.errors import InputError
from models.powerlaw import PowerLawModel


class ForceModel(Protocol):
    """A cutting-force model of the virtual mill."""

    def force_N(self, feed_rate_mm_min: float, depth_mm: float, spindle_rpm: float) -> float:
        """Controlled cutting force [N] at a feed rate [mm/min], depth [mm], speed [rpm]."""
        ...


@dataclass(frozen=True)
class KimJeonForceModel:
    """Kim & Jeon Eq. 1 with its Al6061-T6 power laws and the tool of their §5.1 simulation.

    Parameters
    ----------
    ks_coefficient_N_mm2, ks_exponent : float
        ``K_s = c · t̄_c^p`` [N/mm²] (Kim & Jeon §3: 800, −0.197).
    krt_coefficient, krt_exponent : float
        ``K_rt = c · t̄_c^p`` [-] (Kim & Jeon §3: 0.163, −0.353).
    tool_diameter_mm : float
        End-mill diameter [mm] (Kim & Jeon §5.1: 10 mm).
    flute_count : int
        Number of flutes ``M`` (Kim & Jeon §2.1: two-flute end mills).
    helix_angle_deg : float
        Helix angle β [°], giving the lead ``h = π D / tan β`` (assumed 30°, see the module).
    """

    ks_coefficient_N_mm2: float = 800.0
    ks_exponent: float = -0.197
    krt_coefficient: float = 0.163
    krt_exponent: float = -0.353
    tool_diameter_mm: float = 10.0
    flute_count: int = 2
    helix_angle_deg: float = 30.0

    def __post_init__(self) -> None:
        fields.check_fields(
            self,
            positives=(
                "ks_coefficient_N_mm2",
                "krt_coefficient",
                "tool_diameter_mm",
                "helix_angle_deg",
            ),
        )
        for name in ("ks_exponent", "krt_exponent"):
            value = getattr(self, name)
            if isinstance(value, bool) or not isinstance(value, int | float):
                raise InputError(name, value, "must be a number")
            if not -1.0 < value <= 0.0:
                raise InputError(name, value, "must lie in (-1, 0]: force must rise with feed")
        if isinstance(self.flute_count, bool) or not isinstance(self.flute_count, int):
            raise InputError("flute_count", self.flute_count, "must be a whole number")
        if self.flute_count < 1:
            raise InputError("flute_count", self.flute_count, "must be at least 1")
        if self.helix_angle_deg >= 90.0:
            raise InputError("helix_angle_deg", self.helix_angle_deg, "must be below 90")

    @property
    def helix_lead_mm(self) -> float:
        """Helix lead ``h = π D / tan β`` [mm], read as Eq. 1's ``h``."""
        return math.pi * self.tool_diameter_mm / math.tan(math.radians(self.helix_angle_deg))

    def force_N(self, feed_rate_mm_min: float, depth_mm: float, spindle_rpm: float) -> float:
        """Maximum resultant force per revolution [N] (:func:`kim_jeon_max_force_N`)."""
        return kim_jeon_max_force_N(self, feed_rate_mm_min, depth_mm, spindle_rpm)


def kim_jeon_feed_per_tooth_mm(
    feed_rate_mm_min: float, spindle_rpm: float, flute_count: int
) -> float:
    """Feed per tooth ``f_t = f / (N_s M)`` [mm] (Kim & Jeon §3, below Eq. 1).

    Parameters
    ----------
    feed_rate_mm_min : float
        Feed rate ``f`` [mm/min] (the paper's "mpm").
    spindle_rpm : float
        Spindle speed ``N_s`` [rpm], ``> 0``.
    flute_count : int
        Number of flutes ``M``.

    Returns
    -------
    float
        ``f_t`` [mm].
    """
    if not spindle_rpm > 0:
        raise InputError("spindle_rpm", spindle_rpm, "must be greater than 0")
    return feed_rate_mm_min / (spindle_rpm * flute_count)


def kim_jeon_coefficients(
    model: KimJeonForceModel, feed_per_tooth_mm: float
) -> tuple[float, float]:
    r"""``K_s`` [N/mm²] and ``K_rt`` [-] at a feed per tooth (Kim & Jeon §3).

    .. math:: \bar t_c = \frac{2 f_t}{\pi}, \quad K_s = 800\,\bar t_c^{-0.197}, \quad
              K_{rt} = 0.163\,\bar t_c^{-0.353}

    Parameters
    ----------
    model : KimJeonForceModel
        Power-law coefficients and exponents.
    feed_per_tooth_mm : float
        ``f_t`` [mm], ``> 0``.

    Returns
    -------
    tuple[float, float]
        ``(K_s, K_rt)``.
    """
    if not feed_per_tooth_mm > 0:
        raise InputError("feed_per_tooth_mm", feed_per_tooth_mm, "must be greater than 0")
    chip_mm = 2.0 * feed_per_tooth_mm / math.pi
    ks = model.ks_coefficient_N_mm2 * chip_mm**model.ks_exponent
    krt = model.krt_coefficient * chip_mm**model.krt_exponent
    return ks, krt


def _terms(
    model: KimJeonForceModel, feed_rate_mm_min: float, depth_mm: float, spindle_rpm: float
) -> tuple[float, float, float, float] | None:
    """``(a, b, A, ψ)`` of Eq. 1, or None when not cutting (no feed or no depth)."""
    ft = kim_jeon_feed_per_tooth_mm(feed_rate_mm_min, spindle_rpm, model.flute_count)
    if ft <= 0.0 or depth_mm <= 0.0:
        return None
    ks, krt = kim_jeon_coefficients(model, ft)
    lead = model.helix_lead_mm
    lag = 2.0 * math.pi * depth_mm / lead
    a = ks * krt * ft * depth_mm / 2.0
    b = ks * ft * depth_mm / 2.0
    amplitude = ks * ft * lead / (4.0 * math.pi) * math.sin(lag) * math.sqrt(1.0 + krt * krt)
    return a, b, amplitude, math.atan2(1.0, krt)


def kim_jeon_forces_N(
    model: KimJeonForceModel,
    feed_rate_mm_min: float,
    depth_mm: float,
    spindle_rpm: float,
    angle_rad: float,
) -> tuple[float, float]:
    """Instantaneous ``(F_x, F_y)`` [N] at flute angle θ (Kim & Jeon Eq. 1).

    Parameters
    ----------
    model : KimJeonForceModel
        Material and tool.
    feed_rate_mm_min : float
        Feed rate [mm/min], ``>= 0``.
    depth_mm : float
        Axial depth of cut ``d`` [mm], ``>= 0``; 0 (or no feed) gives no force.
    spindle_rpm : float
        Spindle speed [rpm].
    angle_rad : float
        Rotation angle of the flute tip θ [rad].

    Returns
    -------
    tuple[float, float]
        ``(F_x, F_y)`` [N].
    """
    terms = _terms(model, feed_rate_mm_min, depth_mm, spindle_rpm)
    if terms is None:
        return 0.0, 0.0
    a, b, amplitude, psi = terms
    lag = 2.0 * math.pi * depth_mm / model.helix_lead_mm
    s = math.sin(2.0 * angle_rad - lag + psi)
    return a + amplitude * s, b - amplitude * s


def kim_jeon_max_force_N(
    model: KimJeonForceModel, feed_rate_mm_min: float, depth_mm: float, spindle_rpm: float
) -> float:
    """Maximum resultant force per spindle revolution ``F_max`` [N] (Kim & Jeon §4.1, Eq. 1).

    Parameters
    ----------
    model : KimJeonForceModel
        Material and tool.
    feed_rate_mm_min : float
        Feed rate [mm/min], ``>= 0``.
    depth_mm : float
        Axial depth of cut [mm], ``>= 0``.
    spindle_rpm : float
        Spindle speed [rpm].

    Returns
    -------
    float
        ``max_θ sqrt(F_x² + F_y²)`` [N]; 0 when not cutting.
    """
    terms = _terms(model, feed_rate_mm_min, depth_mm, spindle_rpm)
    if terms is None:
        return 0.0
    a, b, amplitude, _ = terms
    return max(math.hypot(a + amplitude, b - amplitude), math.hypot(a - amplitude, b + amplitude))


@dataclass(frozen=True)
class PowerLawForce:
    """A milling force power law ``F = K · Π x_i^e_i`` as the virtual mill's force model.

    The model's inputs may be any of ``axial_depth_mm``, ``radial_depth_mm``,
    ``feed_per_tooth_mm``, ``speed_m_min`` (DESIGN.md, milling decision variables).

    Parameters
    ----------
    model : PowerLawModel
        A ``force_N`` model (Ivester & Heigel Eq. 5 form).
    radial_depth_mm : float
        Radial depth of cut [mm].
    tool_diameter_mm : float
        Tool diameter [mm].
    flute_count : int
        Number of flutes.
    """

    model: PowerLawModel
    radial_depth_mm: float
    tool_diameter_mm: float
    flute_count: int

    def __post_init__(self) -> None:
        if self.model.quantity != "force_N":
            raise InputError("model.quantity", self.model.quantity, "must be force_N")
        fields.check_fields(self, positives=("radial_depth_mm", "tool_diameter_mm"))
        if isinstance(self.flute_count, bool) or not isinstance(self.flute_count, int):
            raise InputError("flute_count", self.flute_count, "must be a whole number")
        if self.flute_count < 1:
            raise InputError("flute_count", self.flute_count, "must be at least 1")

    def force_N(self, feed_rate_mm_min: float, depth_mm: float, spindle_rpm: float) -> float:
        """``K Π x_i^e_i`` [N] at the operating point; 0 when not cutting."""
        ft = kim_jeon_feed_per_tooth_mm(feed_rate_mm_min, spindle_rpm, self.flute_count)
        if ft <= 0.0 or depth_mm <= 0.0:
            return 0.0
        point = {
            "axial_depth_mm": depth_mm,
            "radial_depth_mm": self.radial_depth_mm,
            "feed_per_tooth_mm": ft,
            "speed_m_min": math.pi * self.tool_diameter_mm * spindle_rpm / 1000.0,
        }
        return self.model.monomial.evaluate(point)


def feed_for_force_mm_min(
    model: ForceModel,
    force_N: float,
    depth_mm: float,
    spindle_rpm: float,
    *,
    upper_mm_min: float = 1.0e5,
) -> float:
    """Feed rate at which ``model`` gives ``force_N`` (bisection; force rises with feed).

    Parameters
    ----------
    model : ForceModel
        Force model, increasing in the feed rate.
    force_N : float
        Target force [N], ``> 0``.
    depth_mm : float
        Axial depth of cut [mm], ``> 0``.
    spindle_rpm : float
        Spindle speed [rpm].
    upper_mm_min : float
        Largest feed rate searched [mm/min].

    Returns
    -------
    float
        Feed rate [mm/min], to 1e-9 relative.
    """
    target = fields.positive(force_N, "force_N")
    fields.positive(depth_mm, "depth_mm")
    low, high = 0.0, fields.positive(upper_mm_min, "upper_mm_min")
    if model.force_N(high, depth_mm, spindle_rpm) < target:
        raise InputError("force_N", force_N, f"not reached below {high:g} mm/min")
    while high - low > 1e-9 * high:
        mid = 0.5 * (low + high)
        if model.force_N(mid, depth_mm, spindle_rpm) < target:
            low = mid
        else:
            high = mid
    return 0.5 * (low + high)
