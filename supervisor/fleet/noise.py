r"""A new plan's noise prior from what the fleet's measuring chains showed (issue 32).

``learn`` counts a reading at an upper quantile of its chain's noise scale ``λ``
(:mod:`supervisor.rcb.noise`), which starts at 4.46 (a chain 2.11 x noisier than it claims)
and comes down only as the plan's own readings show the chain is quiet: after three parts of
six operations, 1.62. That, not the machine's offset, is most of what a new plan from the
fleet prior still lacks after its first parts: with ``λ`` known, ``closed_loop.py --fleet 4
--scenarios 200`` reaches 0.970 of the oracle after one part and 0.983 after three, against
0.943 and 0.973 (docs/benchmarks.md).

Every machine has its own instruments, but of the kinds the plant uses: a chain's ``ln λ`` is
drawn from a between-chain spread, learned as the machines' ``ln K`` spread is
(:mod:`.hierarchy`). Machine ``m``'s chain of a quantity gives ``n_m`` readings' worth of
evidence with excess squares ``S_m`` (its plans' monitors: :attr:`supervisor.rcb.monitor_state.
Monitor.chain_noise`, less the default prior); its belief is the default prior updated by them,
``λ_m ~ InvGamma(a_m, b_m)``, ``a_m = a₀ + n_m/2``, ``b_m = b₀ + S_m/2``, so ``y_m = E ln λ_m =
ln b_m − ψ(a_m)`` with ``v_m = Var ln λ_m = ψ′(a_m)`` (the log of an inverse-gamma variate: minus
the log of a gamma one, whose mean is ``ψ(a) − ln b`` and variance ``ψ′(a)``; Johnson, Kotz and
Balakrishnan, *Continuous Univariate Distributions* vol. 1, ch. 17). For many readings that is
``ln(S_m/n_m)`` and ``2/n_m``; but a chain whose every innovation lay within its model's
uncertainty has ``S_m = 0`` (a spindle load whose ``u`` is mostly its calibration's, the same
from part to part), whose ``ln(S_m/n_m)`` is minus infinity, while its belief's is finite. The
default prior is the one every plan's chain starts from (:mod:`supervisor.rcb.noise`, three
half-readings' weight): it leans each machine's ``λ`` a little towards noisier, the safe side.
DerSimonian and Laird's ``τ̂²`` between them is pooled with a default spread
:data:`DEFAULT_CHAIN_SPREAD` held as :data:`~.hierarchy.SPREAD_WEIGHT` machines
(``σ_c² = (ν_0 σ_0² + (M − 1) τ̂²) / (ν_0 + M − 1)``); a new chain's
``ln λ`` is then ``N(μ, σ_c² + var μ)``, ``μ`` the precision-weighted mean, and the prior is the
inverse gamma of that log-normal's mean and coefficient of variation ``c``: shape ``a = 2 +
1/c²`` (the inverse gamma's ``CV² = 1/(a − 2)``), rate ``(a − 1) λ̄``, ``λ̄`` never under 1 (a
chain quieter than it claims is not trusted to be, as :mod:`supervisor.rcb.noise` says).

A chain that is not the fleet's kind reads otherwise from its first part, and
:mod:`supervisor.rcb.noise_check` lets the fleet's noise prior go.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass

from supervisor.fleet.learned import Learned
from supervisor.fleet.spread import pooled_spread
from supervisor.rcb.noise import NoiseScale

#: ``σ_0``: the default between-chain spread of ``ln λ`` [-]: two instruments of one kind differ
#: in their noise variance by 30 % (their noise by 15 %) (``closed_loop.py --fleet``).
DEFAULT_CHAIN_SPREAD = 0.3
#: A chain whose evidence is worth fewer readings than this is not compared (its belief is then
#: mostly the default prior's, counted once for every machine).
MIN_READINGS = 6.0


@dataclass(frozen=True)
class NoisePrior:
    """A quantity's chain prior from the fleet and where it came from."""

    quantity: str
    belief: NoiseScale
    machines: tuple[str, ...]
    readings: int
    spread: float

    @property
    def scale(self) -> float:
        """``√λ̄``: the fleet's chains' noise as a multiple of the reported one."""
        return math.sqrt(self.belief.rate / (self.belief.shape - 1.0))

    def describe(self) -> str:
        """``force_N noise: 1.00 x the reported u from 540 readings' worth on 3 machines, …``.

        Worth: a chain's evidence forgets (:data:`supervisor.rcb.noise.NOISE_MEMORY`).
        """
        machines = "machine" if len(self.machines) == 1 else "machines"
        return (
            f"{self.quantity} noise: {self.scale:.2f} x the reported u from {self.readings} "
            f"readings' worth on {len(self.machines)} {machines}, between-chain spread "
            f"{100 * self.spread:.0f} %"
        )


def noise_priors(
    learned: Sequence[Learned], default_spread: float = DEFAULT_CHAIN_SPREAD
) -> dict[str, NoisePrior]:
    """Per quantity the fleet's chains read, a new chain's prior (module docstring)."""
    terms: dict[str, dict[str, tuple[list[float], list[float]]]] = {}
    for item in learned:
        if item.chain is None:
            continue
        quantity = item.posterior.quantity
        n, s = terms.setdefault(quantity, {}).setdefault(item.machine, ([], []))
        n.append(item.chain.readings)
        s.append(item.chain.excess)
    # fsum: the same prior whatever order the plans come in (a forgetting chain's evidence
    # is not a sum of halves, and an imported model's plans come in another order)
    sums = {
        q: {m: (math.fsum(n), math.fsum(s)) for m, (n, s) in chains.items()}
        for q, chains in terms.items()
    }
    out = {}
    for quantity, chains in sorted(sums.items()):
        kept = {m: ns for m, ns in sorted(chains.items()) if ns[0] >= MIN_READINGS}
        if kept:
            out[quantity] = _prior(quantity, kept, default_spread)
    return out


def _prior(
    quantity: str, chains: dict[str, tuple[float, float]], default_spread: float
) -> NoisePrior:
    # imported here, as supervisor/rcb/noise.py does: scipy takes 0.2-0.5 s to import, which
    # every reader of a plan (rcb plans, rcb history) paid at start through db.fleet
    from scipy import special

    beliefs = [NoiseScale.of_evidence(n, s) for n, s in chains.values()]
    ys = [math.log(b.rate) - float(special.digamma(b.shape)) for b in beliefs]
    vs = [float(special.polygamma(1, b.shape)) for b in beliefs]
    spread2 = pooled_spread(list(zip(ys, vs, strict=True)), default_spread) ** 2
    weights = [1.0 / (v + spread2) for v in vs]
    mu = sum(w * y for w, y in zip(weights, ys, strict=True)) / sum(weights)
    total = spread2 + 1.0 / sum(weights)
    mean = max(math.exp(mu + 0.5 * total), 1.0)
    shape = 2.0 + 1.0 / math.expm1(total)
    readings = int(round(sum(n for n, _ in chains.values())))
    belief = NoiseScale(shape, (shape - 1.0) * mean)
    return NoisePrior(quantity, belief, tuple(sorted(chains)), readings, math.sqrt(spread2))
