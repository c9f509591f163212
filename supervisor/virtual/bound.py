r"""The one-sided Clopper-Pearson bound a certificate puts on its violation probability.

References
----------
.. [1] Clopper & Pearson (1934), "The use of confidence or fiducial limits illustrated in the
   case of the binomial", Biometrika 26(4), 404-413.
"""

from __future__ import annotations

import math

from scipy.stats import beta

from models.errors import InputError

#: Confidence of the one-sided upper bound on the per-part violation probability.
CONFIDENCE = 0.95


def clopper_pearson_upper(failures: int, trials: int, confidence: float = CONFIDENCE) -> float:
    r"""One-sided Clopper-Pearson upper confidence limit of a binomial probability.

    .. math::

        p_\mathrm{up} = B^{-1}(c;\ x + 1,\ n - x) \quad (x < n), \qquad
        p_\mathrm{up} = 1 \quad (x = n)

    which for ``x = 0`` is ``1 − (1 − c)^{1/n}``.

    Parameters
    ----------
    failures : int
        Trials that failed, ``x`` (``0 <= x <= n``).
    trials : int
        Trials, ``n`` (0 gives 1: nothing is known).
    confidence : float
        One-sided confidence ``c``, ``0 < c < 1`` [-].

    Returns
    -------
    float
        The upper limit of the failure probability [-].

    References
    ----------
    .. [1] Clopper & Pearson (1934), Biometrika 26(4), 404-413.
    """
    if not 0 < confidence < 1:
        raise InputError("confidence", confidence, "must be in (0, 1)")
    if trials < 0 or not 0 <= failures <= max(trials, 0):
        raise InputError("failures", failures, f"must be in 0..trials ({trials})")
    if failures >= trials:
        return 1.0
    if failures == 0:
        return float(-math.expm1(math.log1p(-confidence) / trials))
    return float(beta.ppf(confidence, failures + 1, trials - failures))
