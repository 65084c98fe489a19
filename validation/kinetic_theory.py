"""Dense-ring kinetic theory for identical smooth spheres with constant eps = 0.5.

Reference steady states of the shearing sheet from the kinetic theory of dense planetary
rings (Latter & Ogilvie 2008, Icarus 195, 725: Enskog-type kinetic theory of identical
inelastic spheres with a triaxial Gaussian velocity distribution), as tabulated for
eps = 0.5 and Omega_z = Omega in REBOUND's repository, ``problems/overstability_eq/
Kinetic-0.5-1.dat`` (commit 7f8788d7; REBOUND's ``comparison.plt`` beside it plots the
columns used here against its own simulations).  Units: the particle radius r and Omega.
Columns used (REBOUND's comparison.plt gives their meaning):

* ``tau``: dynamical optical depth;
* ``c``: the 1-D velocity dispersion sqrt(trace W / 3) [r Omega] (plotted as c^2 against
  the simulations' trace/3);
* ``nu_trans`` = -2/3 Pi_xy: the translational (local) kinematic viscosity [r^2 Omega];
  Pi_xy is the table's xy stress, compared there with minus the simulations' W_xy;
* ``nu_coll``: the collisional (non-local) viscosity [r^2 Omega], compared there with
  2 plog / (3 Omega M t) from REBOUND's collision log, the definition ringsim uses
  (``analysis.collisions.collisional_viscosity``).

Only a handful of the table's rows are quoted (enough to interpolate over tau = 0.1-1.6).
"""

from __future__ import annotations

import argparse

import numpy as np

import ringsim
from ringsim.config.scenario import scenario_from_dict
from ringsim.report import replace_section
from validation.common import DOC, WORKDIR

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
SOURCE = ("kinetic theory of Latter & Ogilvie (2008) for eps = 0.5, tabulated in REBOUND's "
          "problems/overstability_eq/Kinetic-0.5-1.dat (commit 7f8788d7)")


def kinetic_steady_state(tau: float) -> dict[str, float]:
    """c [r Omega], nu_trans and nu_coll [r^2 Omega] of the kinetic theory at optical depth
    ``tau``, linearly interpolated between the tabulated rows (spacing 0.1 in tau; the
    curves are smooth, so interpolation adds < 0.3 % to c).

    Parameters
    ----------
    tau : float [dimensionless], within the table (0.004 - 1.59)
    """
    t, c, pi_xy, nu_coll = KINETIC_EPS05.T
    if not t[0] <= tau <= t[-1]:
        raise ValueError(f"tau = {tau} outside the table ({t[0]:.3g} - {t[-1]:.3g})")
    return {"c": float(np.interp(tau, t, c)),
            "nu_trans": float(np.interp(tau, t, -2.0 / 3.0 * pi_xy)),
            "nu_coll": float(np.interp(tau, t, nu_coll))}


def compare_with_kinetic_theory(eq: dict, Omega: float) -> dict[str, dict[str, float]]:
    """ringsim's equilibrium of an identical-particle, eps = 0.5 run against the theory.

    Parameters
    ----------
    eq : ``ringsim.equilibrium`` of the run (monodisperse, constant eps = 0.5)
    Omega : float [1/s]

    Returns
    -------
    {quantity: {"ringsim", "ringsim_err", "theory", "deviation"}} for c [r Omega],
    nu_trans and nu_coll [r^2 Omega]; deviation = ringsim / theory - 1.
    """
    r = eq["mean_radius"]
    theory = kinetic_steady_state(eq["optical_depth"])
    ours = {"c": (eq["velocity_dispersion_rOmega"]["mean"],
                  eq["velocity_dispersion_rOmega"]["stderr"]),
            "nu_trans": tuple(eq["translational_viscosity"][k] / (r * r * Omega)
                              for k in ("mean", "stderr")),
            "nu_coll": tuple(eq["collisional_viscosity"][k] / (r * r * Omega)
                             for k in ("mean", "stderr"))}
    return {key: {"ringsim": value, "ringsim_err": err, "theory": theory[key],
                  "deviation": value / theory[key] - 1.0}
            for key, (value, err) in ours.items()}


#: Section of docs/validation.md written by `main`.
HEADING = "## Kinetic theory: identical smooth spheres, constant eps = 0.5"
#: Optical depths, particles and orbits of `main` (tree detection, dt: auto).
TAUS = (0.1, 0.25, 0.4, 0.5, 0.8, 1.0, 1.5)
N_PARTICLES = 500
ORBITS = 20.0
OMEGA = 2.0e-4  # [1/s]


def kinetic_scenario(tau: float, n_particles: int = N_PARTICLES, orbits: float = ORBITS):
    """The reference ring: identical 1 m ice spheres, constant eps = 0.5, tree detection.

    Parameters
    ----------
    tau : float [dimensionless]
    n_particles : int
    orbits : float [orbits]
    """
    return scenario_from_dict({
        "name": f"kinetic-tau{tau:g}", "seed": 1, "planet": {"Omega": OMEGA},
        "particles": {"density": 900.0,
                      "size_distribution": {"kind": "monodisperse", "radius": 1.0}},
        "sheet": {"optical_depth": tau, "n_particles": n_particles},
        "restitution": {"model": "constant", "epsilon": 0.5},
        "integration": {"orbits": orbits, "collision_detection": "tree"},
        "output": {"timeseries_every": 0.05, "snapshot_every": orbits}})


def section_markdown(rows: list[tuple[float, dict, bool]]) -> str:
    """The section: one line per (tau, comparison, in_equilibrium)."""
    lines = [HEADING, "",
             f"Written by `python -m validation kinetic-theory`: {N_PARTICLES} "
             f"identical 1 m spheres, constant eps = 0.5, Omega = {OMEGA:g} 1/s, tree "
             f"detection with dt: auto, {ORBITS:g} orbits, seed 1; equilibrium window and "
             f"errors from `ringsim.equilibrium`.  Reference: {SOURCE}.  Tolerance of the "
             "tests (tests/test_kinetic_theory.py): c within 3 %.", "",
             "| tau | c ringsim [r Omega] | c theory | dev. | nu_trans ringsim [r^2 Omega] "
             "| nu_trans theory | dev. | nu_coll ringsim | nu_coll theory | dev. | "
             "in equilibrium |", "|---" * 11 + "|"]
    for tau, comp, in_eq in rows:
        cells = [f"{tau:g}"]
        for key in ("c", "nu_trans", "nu_coll"):
            q = comp[key]
            cells += [f"{q['ringsim']:.4g} ± {q['ringsim_err']:.2g}", f"{q['theory']:.4g}",
                      f"{100 * q['deviation']:+.1f} %"]
        lines.append("| " + " | ".join(cells + [str(in_eq)]) + " |")
    return "\n".join(lines) + "\n"


def main(argv: list[str] | None = None, prog: str | None = None) -> None:
    """``python -m validation kinetic-theory``: run the optical depths of `TAUS` and write
    the section of docs/validation.md."""
    argparse.ArgumentParser(prog=prog, description=__doc__.splitlines()[0]).parse_args(argv)
    rows = []
    for tau in TAUS:
        path = WORKDIR / f"kinetic_tau{tau:g}.h5"
        path.parent.mkdir(parents=True, exist_ok=True)
        ringsim.run(kinetic_scenario(tau), output=path, force=True, progress=False)
        eq = ringsim.equilibrium(ringsim.open_run(path))
        rows.append((tau, compare_with_kinetic_theory(eq, OMEGA), eq["in_equilibrium"]))
    replace_section(DOC, HEADING, section_markdown(rows), "Validation")
