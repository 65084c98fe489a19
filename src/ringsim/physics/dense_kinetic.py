"""Dense-ring kinetic theory of identical smooth spheres with constant eps = 0.5: the
reference steady states of the validation study ``studies/validation-kinetic-theory``.

Latter & Ogilvie (2008, Icarus 195, 725) solve an Enskog-type kinetic theory of identical
inelastic spheres with a triaxial Gaussian velocity distribution in the shearing sheet.
Their steady states for eps = 0.5 and Omega_z = Omega are tabulated in REBOUND's
repository, ``problems/overstability_eq/Kinetic-0.5-1.dat`` (commit 7f8788d7; REBOUND's
``comparison.plt`` beside it plots the columns used here against its own simulations).
Units: the particle radius r and Omega.  Columns used (``comparison.plt`` gives their
meaning):

* ``tau``: dynamical optical depth;
* ``c``: the 1-D velocity dispersion sqrt(trace W / 3) [r Omega];
* ``Pi_xy``: the xy stress [r^2 Omega^2]; the translational (local) kinematic viscosity is
  nu_trans = -2/3 Pi_xy [r^2 Omega];
* ``nu_coll``: the collisional (non-local) viscosity [r^2 Omega], compared there with
  2 plog / (3 Omega M t) from REBOUND's collision log, the definition ringsim uses
  (``analysis.collisions.collisional_viscosity``).

Only a handful of the table's rows are quoted, enough to interpolate over tau = 0.004-1.59.
"""

from __future__ import annotations

import numpy as np

#: Rows of Kinetic-0.5-1.dat: tau, c [r Omega], Pi_xy [r^2 Omega^2], nu_coll [r^2 Omega].
KINETIC_EPS05 = np.array([
    (0.004022738557472502, 2.1245959421256924, -0.011408597597881863, 0.0036649666951325474),
    (0.10462838348880808, 2.1176790725643495, -0.2986519106241994, 0.1042965087524298),
    (0.21148098488624914, 2.0424023882526767, -0.552602999122344, 0.22687357467565789),
    (0.3146027024004444, 1.930796350603784, -0.7101217419338307, 0.35491497442292963),
    (0.4136599769070149, 1.8133143464539345, -0.7885383400206707, 0.4834449715226467),
    (0.5104132232002752, 1.702633134669912, -0.8168212018352982, 0.6131947262900794),
    (0.6068659358159462, 1.6022347283172254, -0.8151644235294215, 0.7467366232163235),
    (0.7049510315352433, 1.5125429744056833, -0.7958083035125861, 0.8869853557487998),
    (0.806544375248054, 1.433166695491742, -0.7662231657453874, 1.0367046432566347),
    (0.9134393198612415, 1.3634565989453038, -0.7310872542107373, 1.1985166179237152),
    (1.0273961090009707, 1.302726511831924, -0.6934999315709168, 1.3750413170279798),
    (1.2832232578205407, 1.2050331202237448, -0.6183103257382382, 1.7836624979072493),
    (1.587636358882744, 1.1333403542179261, -0.5491879543378009, 2.2908386886180576),
])
#: Where the table comes from (reports quote it).
SOURCE = ("kinetic theory of Latter & Ogilvie (2008, Icarus 195, 725) for eps = 0.5, "
          "tabulated in REBOUND's problems/overstability_eq/Kinetic-0.5-1.dat (commit "
          "7f8788d7)")


def kinetic_steady_state(optical_depth: float) -> dict[str, float]:
    """c [r Omega], nu_trans and nu_coll [r^2 Omega] of the kinetic theory at an optical
    depth, linearly interpolated between the tabulated rows (spacing about 0.1 in tau; the
    curves are smooth, so interpolation adds < 0.3 % to c).

    Parameters
    ----------
    optical_depth : float [dimensionless], within the table (0.004 - 1.59)
    """
    t, c, pi_xy, nu_coll = KINETIC_EPS05.T
    if not t[0] <= optical_depth <= t[-1]:
        raise ValueError(f"tau = {optical_depth} outside the table "
                         f"({t[0]:.3g} - {t[-1]:.3g})")
    return {"c": float(np.interp(optical_depth, t, c)),
            "nu_trans": float(np.interp(optical_depth, t, -2.0 / 3.0 * pi_xy)),
            "nu_coll": float(np.interp(optical_depth, t, nu_coll))}
