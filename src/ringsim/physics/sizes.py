"""Size distributions of ring particles: moments, sampling and the radius bins of diagnostics."""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any, ClassVar

import numpy as np


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
        u = rng.random(n)
        if self.r_min == self.r_max:
            return np.full(n, self.r_min)
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


