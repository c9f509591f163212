"""``rcb fit``: warnings on a fit that should not be trusted as it is (issue 30).

A fit is always printed (exit 0); these are the one-line ``rcb: warning: ...`` notes that come
with it, each naming the quantity and the figure:

- R² on the log scale below :data:`POOR_R2`: the variables explain less than half of the
  scatter of ln Y, so the exponents say little and the band is wide (Montgomery & Runger,
  *Applied Statistics and Probability for Engineers*, §11.8: R² is the fraction of the
  variability the model explains). Not judged when no exponent was fitted (only K: R² is 0
  by construction).
- The lower edge of the band, ``K − ΔK``, at or below zero: the model's prediction with its
  band then spans zero, which no positive quantity can be; a minimum (tool life) has no robust
  value at all there (``ln(K − ΔK)``, Ivester & Heigel Eq. 13).
"""

from __future__ import annotations

from typing import TYPE_CHECKING

if TYPE_CHECKING:
    from models.fit import FitResult

#: R² (log scale) below which ``rcb fit`` warns of a poor fit [-].
POOR_R2 = 0.5


def fit_warnings(result: FitResult, name: str) -> list[str]:
    """The warnings of ``result``, a fit of the quantity ``name`` (without ``rcb: warning:``)."""
    found = []
    if len(result.parameters) > 1 and result.r2 < POOR_R2:
        found.append(
            f"{name}: R² (ln) = {result.r2:.3g} is below {POOR_R2:g}: a poor fit, the variables "
            "explain little of the scatter; check the columns, --where, or add variables"
        )
    lower = result.K - result.dK
    if lower <= 0:
        found.append(
            f"{name}: the band's lower edge K − ΔK = {lower:.4g} is at or below zero "
            f"(K = {result.K:.4g}, ΔK = {result.dK:.4g}): the data scatter too widely for a "
            "band on K; a minimum such as tool life has no robust value"
        )
    return found
