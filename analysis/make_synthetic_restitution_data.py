"""Write analysis/data/hatzes_like.csv: SYNTHETIC coefficients of restitution for `ringsim fit`.

Not measurements.  The rows imitate the layout of the experiments of Hatzes et al. (1988):
ice spheres whose local radius of curvature at the impact point is 2.5, 5, 10 and 20 cm hit
a massive ice brick (R2 = M2 = inf) on a pendulum of one effective mass (60 g here).  The
values are Dilley's (1993) viscous-dissipation law with his fit xi0 = 0.16, p = 0.65
(eq. 5.11), plus seeded Gaussian noise of standard deviation sigma = 0.01 + 0.03 (1 - eps),
clipped to [0, 1].  Because every row has the same reduced mass, `ringsim fit` fixes the mass
exponent kappa at 0 for these data.

    python analysis/make_synthetic_restitution_data.py
    ringsim fit analysis/data/hatzes_like.csv --model all --plot fit.png
"""

from pathlib import Path

import numpy as np

from ringsim.physics import restitution as rs

SEED = 1988
RADII_M = (0.025, 0.05, 0.10, 0.20)      # [m] radius of curvature at the impact point
MASS_KG = 0.060                          # [kg] effective mass of sphere and pendulum
SPEEDS_M_S = np.geomspace(5e-4, 3e-2, 12)  # [m/s] impact speeds, 0.05 to 3 cm/s
REPEATS = 2                              # impacts per speed and radius
XI0, P = rs.DILLEY_XI0, rs.DILLEY_P


def main(path: Path) -> None:
    rng = np.random.default_rng(SEED)
    lines = [
        "# SYNTHETIC data (not measurements) made by analysis/make_synthetic_restitution_data.py",
        f"# Dilley (1993) law xi0 = {XI0}, p = {P}, sphere against a brick (R2 = M2 = inf),",
        f"# effective mass {MASS_KG} kg; noise sigma = 0.01 + 0.03 (1 - eps), seed {SEED}.",
        "v_m_s,R1_m,R2_m,M1_kg,M2_kg,epsilon,sigma",
    ]
    for radius in RADII_M:
        for v in np.repeat(SPEEDS_M_S, REPEATS):
            eps = rs.dilley_epsilon(v, radius, MASS_KG, xi0=XI0, p=P)
            sigma = 0.01 + 0.03 * (1.0 - eps)
            measured = float(np.clip(eps + rng.normal(0.0, sigma), 0.0, 1.0))
            lines.append(f"{v:.6g},{radius:g},inf,{MASS_KG:g},inf,{measured:.5f},{sigma:.5f}")
    path.parent.mkdir(parents=True, exist_ok=True)
    path.write_text("\n".join(lines) + "\n")


if __name__ == "__main__":
    main(Path(__file__).resolve().parent / "data" / "hatzes_like.csv")
