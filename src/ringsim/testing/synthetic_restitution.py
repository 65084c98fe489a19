"""SYNTHETIC coefficients of restitution for `ringsim fit`: the bundled example CSV.

Not measurements.  The rows imitate the layout of the experiments of Hatzes et al. (1988):
ice spheres whose local radius of curvature at the impact point is 2.5, 5, 10 and 20 cm hit
a massive ice brick (R2 = M2 = inf) on a pendulum of one effective mass (60 g here).  The
values are Dilley's (1993) viscous-dissipation law with his fit xi0 = 0.16, p = 0.65
(eq. 5.11), plus seeded Gaussian noise of standard deviation sigma = 0.01 + 0.03 (1 - eps),
clipped to [0, 1].  Because every row has the same reduced mass, `ringsim fit` fixes the mass
exponent kappa at 0 for these data.

The file is ``docs/data/hatzes_like.csv`` of the repository (docs/fit.md); it is written by

    python -m ringsim.testing.synthetic_restitution docs/data/hatzes_like.csv

and ``tests/test_fit.py`` checks that this gives the committed file byte for byte.
"""

from __future__ import annotations

import sys
from pathlib import Path

import numpy as np

from ringsim.physics import restitution as rs

__all__ = ["hatzes_like_csv", "write_hatzes_like"]

#: Seed of the noise.
SEED = 1988
#: [m] radius of curvature at the impact point.
RADII_M = (0.025, 0.05, 0.10, 0.20)
#: [kg] effective mass of sphere and pendulum.
MASS_KG = 0.060
#: [m/s] impact speeds, 0.05 to 3 cm/s.
SPEEDS_M_S = np.geomspace(5e-4, 3e-2, 12)
#: Impacts per speed and radius.
REPEATS = 2


def hatzes_like_csv() -> str:
    """The text of the synthetic CSV (header comments, column names with units, one row per
    impact): Dilley's law at his fit plus seeded noise, the same text on every machine."""
    xi0, p = rs.DILLEY_XI0, rs.DILLEY_P
    rng = np.random.default_rng(SEED)
    lines = [
        "# SYNTHETIC data (not measurements) made by "
        "python -m ringsim.testing.synthetic_restitution",
        f"# Dilley (1993) law xi0 = {xi0}, p = {p}, sphere against a brick (R2 = M2 = inf),",
        f"# effective mass {MASS_KG} kg; noise sigma = 0.01 + 0.03 (1 - eps), seed {SEED}.",
        "v_m_s,R1_m,R2_m,M1_kg,M2_kg,epsilon,sigma",
    ]
    for radius in RADII_M:
        for v in np.repeat(SPEEDS_M_S, REPEATS):
            eps = rs.dilley_epsilon(v, radius, MASS_KG, xi0=xi0, p=p)
            sigma = 0.01 + 0.03 * (1.0 - eps)
            measured = float(np.clip(eps + rng.normal(0.0, sigma), 0.0, 1.0))
            lines.append(f"{v:.6g},{radius:g},inf,{MASS_KG:g},inf,{measured:.5f},{sigma:.5f}")
    return "\n".join(lines) + "\n"


def write_hatzes_like(path: str | Path) -> Path:
    """Write `hatzes_like_csv` to ``path`` (its folder made if missing); returns the path."""
    out = Path(path)
    out.parent.mkdir(parents=True, exist_ok=True)
    out.write_text(hatzes_like_csv())
    return out


if __name__ == "__main__":
    if len(sys.argv) != 2:
        sys.exit("usage: python -m ringsim.testing.synthetic_restitution OUT.csv")
    write_hatzes_like(sys.argv[1])
