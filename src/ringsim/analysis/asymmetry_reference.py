"""A structure-free reference for the azimuthal asymmetry of tau_n (``ringsim observe
--reference K``).

The amplitude (max - min) / mean of tau_n over the azimuths of one opening angle measures
the anisotropy of the sheet's horizontal structure (wakes), but also the noise of the views:
in a nearly opaque view of a small box the few holes of each snapshot decide T, and the
views of one snapshot share them, so neither the views' errors nor a chi-square over
azimuth say whether an amplitude is structure.  The reference answers it empirically.  Each
copy keeps every snapshot's particles (radii, heights, number) and the box and draws their
horizontal positions anew, uniformly (no horizontal structure, hence no preferred azimuth,
and no hard-sphere exclusion either: the reference is a null for anisotropy, not a model
of the ring's level of tau_n).  The copies are traced with the same views, snapshots and
rays as the run, and the asymmetry's p-value is (1 + the copies whose amplitude is at least
the run's) / (1 + copies): the chance that a sheet without horizontal structure shows an
amplitude as large.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Sequence

import numpy as np

#: Most reference copies ``ringsim observe`` accepts.
MOST_COPIES = 1000


def amplitude(tau_n: Sequence[float]) -> float:
    """(max - min) / mean of tau_n over azimuth [dimensionless]; NaN when a view let no ray
    through (its tau_n is infinite, only a lower bound)."""
    tau = np.asarray(tau_n, dtype=float)
    if tau.size == 0 or not np.all(np.isfinite(tau)):
        return math.nan
    return float((tau.max() - tau.min()) / tau.mean())


def structure_free(snap: dict, Lx: float, Ly: float, rng: np.random.Generator) -> dict:
    """The snapshot with its particles' horizontal positions drawn uniformly in the box
    [m] (radii, heights and everything else kept)."""
    out = dict(snap)
    n = np.asarray(snap["x"]).size
    out["x"] = (rng.random(n) - 0.5) * Lx
    out["y"] = (rng.random(n) - 0.5) * Ly
    return out


def reference_amplitudes(snaps: Sequence[dict], Lx: float, Ly: float, elevation: float,
                         azimuths: Sequence[float], copies: int, rng: np.random.Generator,
                         tau_of_view: Callable[[list[dict], float, float], float]
                         ) -> list[float]:
    """The asymmetry amplitude at one opening angle [deg] of ``copies`` structure-free
    copies of the snapshots; ``tau_of_view(snapshots, elevation, azimuth)`` traces one view
    over the snapshots as the run's views are traced and returns its tau_n."""
    out = []
    for _ in range(copies):
        twins = [structure_free(s, Lx, Ly, rng) for s in snaps]
        out.append(amplitude([tau_of_view(twins, elevation, a) for a in azimuths]))
    return out


def p_value(observed: float, reference: Sequence[float]) -> float | None:
    """(1 + copies at least as asymmetric) / (1 + copies); None without a finite observed
    amplitude or without copies."""
    ref = [r for r in reference if math.isfinite(r)]
    if not ref or not math.isfinite(observed):
        return None
    return (1 + sum(r >= observed for r in ref)) / (1 + len(ref))
