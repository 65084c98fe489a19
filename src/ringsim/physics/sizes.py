"""Size distributions of ring particles: moments, sampling and the radius bins of diagnostics."""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any, ClassVar

import numpy as np
from numpy.typing import ArrayLike, NDArray

from ringsim.physics.laws import DIMENSIONLESS, Parameter


class SizeDistribution:
    """Number distribution of particle radii; subclasses give `moment` and `draw_radii`."""

    kind: ClassVar[str] = ""

    def moment(self, k: float) -> float:
        """Number-weighted mean of radius**k [m^k]."""
        raise NotImplementedError

    def draw_radii(self, n: int, rng: np.random.Generator) -> np.ndarray:
        """``n`` radii [m] drawn from the distribution with the generator ``rng``."""
        raise NotImplementedError

    @property
    def smallest_radius(self) -> float:
        """Smallest radius the distribution can produce [m]."""
        raise NotImplementedError

    @property
    def largest_radius(self) -> float:
        """Largest radius the distribution can produce [m]."""
        raise NotImplementedError

    @property
    def mean_radius(self) -> float:
        """Number-weighted mean radius <R> [m]."""
        return self.moment(1.0)

    def to_dict(self) -> dict[str, Any]:
        raise NotImplementedError


@dataclass(frozen=True)
class Monodisperse(SizeDistribution):
    """All particles alike.

    Attributes
    ----------
    radius : float [m]
    """

    radius: float
    kind: ClassVar[str] = "monodisperse"

    def moment(self, k: float) -> float:
        return self.radius**k

    def draw_radii(self, n: int, rng: np.random.Generator) -> np.ndarray:
        return np.full(n, self.radius)

    @property
    def smallest_radius(self) -> float:
        return self.radius

    @property
    def largest_radius(self) -> float:
        return self.radius

    def to_dict(self) -> dict[str, Any]:
        return {"kind": self.kind, "radius": self.radius}


def _integral_of_power(s: float, r_min: float, r_max: float) -> float:
    """Integral of R**s dR from r_min to r_max [m^(s+1)], accurate near s = -1."""
    t = s + 1.0
    log_ratio = math.log(r_max / r_min)
    if t == 0.0:
        return log_ratio
    return r_min**t * math.expm1(t * log_ratio) / t


@dataclass(frozen=True)
class PowerLaw(SizeDistribution):
    """Power law dN/dR proportional to R^-q between r_min and r_max.

    Attributes
    ----------
    q : float [dimensionless]
        Slope; q = 3 is the classic value for Saturn's rings (equal optical depth per
        logarithmic radius interval); any finite real is allowed.
    r_min, r_max : float [m]
        Radius limits, 0 < r_min <= r_max.
    """

    q: float
    r_min: float
    r_max: float
    kind: ClassVar[str] = "powerlaw"

    def moment(self, k: float) -> float:
        if self.r_min == self.r_max:
            return self.r_min**k
        return (_integral_of_power(k - self.q, self.r_min, self.r_max)
                / _integral_of_power(-self.q, self.r_min, self.r_max))

    def draw_radii(self, n: int, rng: np.random.Generator) -> np.ndarray:
        """Inverse-transform sampling of the truncated power law."""
        return self.quantile(rng.random(n))

    def quantile(self, u: np.ndarray) -> np.ndarray:
        """Radii [m] at cumulative number fractions u in [0, 1] (the inverse CDF)."""
        if self.r_min == self.r_max:
            return np.full(np.shape(u), self.r_min)
        t = 1.0 - self.q
        log_ratio = math.log(self.r_max / self.r_min)
        if t == 0.0:
            radii = self.r_min * np.exp(u * log_ratio)
        else:
            radii = self.r_min * (1.0 + u * math.expm1(t * log_ratio)) ** (1.0 / t)
        return np.clip(radii, self.r_min, self.r_max)

    @property
    def smallest_radius(self) -> float:
        return self.r_min

    @property
    def largest_radius(self) -> float:
        return self.r_max

    def to_dict(self) -> dict[str, Any]:
        return {"kind": self.kind, "q": self.q, "r_min": self.r_min, "r_max": self.r_max}


@dataclass(frozen=True)
class MixtureComponent:
    """One species of a mixture.

    Attributes
    ----------
    radius : float [m]
    number_fraction : float [dimensionless]
        Fraction of the particles (by number) of this radius, > 0.
    """

    radius: float
    number_fraction: float

    def to_dict(self) -> dict[str, float]:
        return {"radius": self.radius, "number_fraction": self.number_fraction}


@dataclass(frozen=True)
class Mixture(SizeDistribution):
    """A few discrete radii with given number fractions (summing to 1)."""

    components: tuple[MixtureComponent, ...]
    kind: ClassVar[str] = "mixture"

    def moment(self, k: float) -> float:
        radii = np.array([c.radius for c in self.components])
        fractions = np.array([c.number_fraction for c in self.components])
        return float(np.sum(fractions * radii**k) / np.sum(fractions))

    def counts(self, n: int) -> np.ndarray:
        """Particles of each component among ``n``: n * fraction rounded by largest remainder,
        so that they sum to exactly n."""
        fractions = np.array([c.number_fraction for c in self.components])
        exact = n * fractions / fractions.sum()
        counts = np.floor(exact).astype(int)
        short = n - int(counts.sum())
        order = np.argsort(-(exact - counts), kind="stable")
        counts[order[:short]] += 1
        return counts

    def draw_radii(self, n: int, rng: np.random.Generator) -> np.ndarray:
        """Exactly `counts` (n) particles of each radius, in random order."""
        radii = np.repeat([c.radius for c in self.components], self.counts(n))
        return rng.permutation(radii)

    @property
    def smallest_radius(self) -> float:
        return min(c.radius for c in self.components)

    @property
    def largest_radius(self) -> float:
        return max(c.radius for c in self.components)

    def to_dict(self) -> dict[str, Any]:
        return {"kind": self.kind, "components": [c.to_dict() for c in self.components]}


#: Nodes of the quadrature in ln R of a `PowerLawCutoff`'s moments (composite Simpson): the
#: integrand is smooth in ln R, so the relative error is below 1e-10 over 3 decades.
CUTOFF_QUADRATURE_NODES = 4001


@dataclass(frozen=True)
class PowerLawCutoff(SizeDistribution):
    """Power law with an exponential cutoff at large radii,
    dN/dR proportional to R^-q exp(-(R / r_cut)^s) between r_min and r_max.

    The form of an aggregation-fragmentation balance (Brilliantov et al. 2015, PNAS 112,
    9536: a power law with 2.75 <= q <= 3.5 and an exponential cutoff at large sizes); the
    sharp bounds r_min and r_max keep it a distribution a box can hold.  s = 3 makes the
    cutoff exponential in mass (m proportional to R^3), s = 1 in radius.

    Attributes
    ----------
    q : float [dimensionless]
        Slope of the power law below the cutoff.
    r_min, r_max : float [m]
        Radius limits, 0 < r_min <= r_max.
    r_cut : float [m]
        Cutoff radius, > 0.
    cutoff_exponent : float [dimensionless]
        s, > 0.
    """

    q: float
    r_min: float
    r_max: float
    r_cut: float
    cutoff_exponent: float = 3.0
    kind: ClassVar[str] = "powerlaw_cutoff"

    def _weights(self, radii: np.ndarray) -> np.ndarray:
        """exp(-(R / r_cut)^s) of radii [m] (the cutoff factor, in (0, 1])."""
        return np.exp(-(radii / self.r_cut) ** self.cutoff_exponent)

    def moment(self, k: float) -> float:
        """<R^k> [m^k] by Simpson's rule in ln R (`CUTOFF_QUADRATURE_NODES` nodes)."""
        if self.r_min == self.r_max:
            return self.r_min**k
        u = np.linspace(math.log(self.r_min), math.log(self.r_max), CUTOFF_QUADRATURE_NODES)
        radii = np.exp(u)
        base = radii ** (1.0 - self.q) * self._weights(radii)    # dN/d ln R
        simpson = np.ones(u.size)
        simpson[1:-1:2], simpson[2:-1:2] = 4.0, 2.0
        return float(np.sum(simpson * base * radii**k) / np.sum(simpson * base))

    def acceptance(self) -> float:
        """Share of draws of the plain power law that the cutoff keeps (rejection sampling)."""
        plain = PowerLaw(self.q, self.r_min, self.r_max)
        u = np.linspace(0.0, 1.0, CUTOFF_QUADRATURE_NODES)
        radii = plain.quantile(u)
        simpson = np.ones(u.size)
        simpson[1:-1:2], simpson[2:-1:2] = 4.0, 2.0
        return float(np.sum(simpson * self._weights(radii)) / np.sum(simpson))

    def draw_radii(self, n: int, rng: np.random.Generator) -> np.ndarray:
        """Rejection sampling: radii of the plain power law, each kept with probability
        exp(-(R / r_cut)^s); batches until ``n`` are kept, in the order drawn."""
        plain = PowerLaw(self.q, self.r_min, self.r_max)
        keep = max(self.acceptance(), 1e-6)
        out: list[np.ndarray] = []
        found = 0
        while found < n:
            batch = plain.draw_radii(int(1.2 * (n - found) / keep) + 16, rng)
            kept = batch[rng.random(batch.size) < self._weights(batch)]
            out.append(kept)
            found += kept.size
        return np.concatenate(out)[:n] if out else np.zeros(0)

    @property
    def smallest_radius(self) -> float:
        return self.r_min

    @property
    def largest_radius(self) -> float:
        return self.r_max

    def to_dict(self) -> dict[str, Any]:
        return {"kind": self.kind, "q": self.q, "r_min": self.r_min, "r_max": self.r_max,
                "r_cut": self.r_cut, "cutoff_exponent": self.cutoff_exponent}


#: The keys of ``kind: powerlaw_cutoff`` (scenario validation and docs/scenario.md).
CUTOFF_PARAMETERS: tuple[Parameter, ...] = (
    Parameter("q", DIMENSIONLESS, "slope below the cutoff: dN/dR ∝ R^−q exp(−(R/r_cut)^s)",
              "Brilliantov et al. 2015, PNAS 112, 9536: 2.75 ≤ q ≤ 3.5", example=3.0),
    Parameter("r_min", "m", "smallest radius", "radio occultations reach ~1 cm (Marouf et "
              "al. 1983; Zebker et al. 1985)", lower=0.0, example=0.01),
    Parameter("r_max", "m", "largest radius (≥ r_min)", "a bound the box can hold",
              lower=0.0, example=10.0),
    Parameter("r_cut", "m", "cutoff radius", "Brilliantov et al. 2015 (set by the ratio of "
              "aggregating to disruptive collisions)", lower=0.0, example=5.0),
    Parameter("cutoff_exponent", DIMENSIONLESS, "s: 3 exponential in mass, 1 in radius",
              "m ∝ R^3", default=3.0, lower=0.0),
)
#: A cutoff that keeps fewer than this share of the plain power law's draws is refused
#: (rejection sampling would draw more than 1000 radii per particle).
MIN_CUTOFF_ACCEPTANCE = 1e-3


# --- size bins ------------------------------------------------------------------------------

def size_bin_edges(size_distribution, n_bins: int = 6) -> np.ndarray | None:
    """Radius bin edges [m] for per-size diagnostics; None for a single radius.

    Fixed by the scenario (not by the radii drawn), so runs with different seeds share
    their bins: log-spaced over [r_min, r_max] for a power law (the top edge nudged up so
    that r_max falls inside), one bin per component for a mixture.
    """
    lo, hi = size_distribution.smallest_radius, size_distribution.largest_radius
    if hi <= lo * (1 + 1e-12):
        return None
    if size_distribution.kind == "mixture":
        distinct = np.unique([c.radius for c in size_distribution.components])
        mids = np.sqrt(distinct[1:] * distinct[:-1])
        return np.concatenate([[lo * 0.999], mids, [hi * 1.001]])
    return np.geomspace(lo, hi * (1 + 1e-9), n_bins + 1)




def size_bin_index(radius: ArrayLike, edges: ArrayLike) -> NDArray[np.intp]:
    """Bin of each radius [m] among ``edges`` [m] (np.histogram's convention: each bin
    includes its lower edge, the last also its upper); -1 outside the edges."""
    r = np.asarray(radius, dtype=float)
    e = np.asarray(edges, dtype=float)
    n_bins = e.size - 1
    idx = np.searchsorted(e, r, side="right") - 1
    idx[r == e[-1]] = n_bins - 1
    idx[(r < e[0]) | (r > e[-1])] = -1
    return idx
