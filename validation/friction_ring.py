"""A ring patch of rough particles against the ring literature (docs/validation.md, "Rough
particles in a ring patch").

Identical 1 m ice spheres in a non-gravitating shearing sheet at optical depth 0.1 with
Dilley's (1993) speed-dependent eps_n at kappa = 0 (xi0 = 0.16, p = 0.65: a hot, dilute
ring, c of tens of r Omega, that settles where the collision-averaged eps_n balances the
shear heating) and surface friction: constant
beta = 0 and beta = 0.5, and Coulomb mu = 0.5 (beta0 = 0), each run until the equilibrium
finder calls c and H stationary.  Measured over the stationary window: E_rot/E_tr (E_tr
relative to the shear flow), the mean z-spin and the rms spin in units of Omega (rotating
frame), the share of sliding contacts and the energy budget (shear heating against the
normal + tangential dissipation the resolver counts).

Reference: E_rot/E_tr = ``physics.spin_temperature.collisional_spin_ratio(beta)`` = k (1 + beta) /
(2 (1 + k) - (1 + beta)) (0.222 at beta = 0, 0.462 at beta = 0.5 for k = 2/5), the
optically-thin prediction Morishima & Salo (2004, DPS 36, #19.01) found their local
simulations to agree with.  No published mean z-spin or rms spin of identical ring
particles could be read (docs/friction.md, "The ring literature with friction").

    python -m validation friction-ring [--workdir runs/validation]
"""

from __future__ import annotations

import argparse
import json
import time
from pathlib import Path

from ringsim.physics import spin_temperature
from validation.common import MONODISPERSE_1M, run_cached, sheet_scenario

DILLEY_KAPPA0 = {"model": "dilley", "xi0": 0.16, "p": 0.65, "kappa": 0.0}

#: The cases: name -> friction section.
CASES = {
    "beta0": {"model": "constant", "beta": 0.0},
    "beta0.5": {"model": "constant", "beta": 0.5},
    "coulomb0.5": {"model": "coulomb", "mu": 0.5},
}
TAU = 0.1
N_PARTICLES = 400
MAX_ORBITS = 150.0


def ring_scenario(name: str, friction: dict, seed: int = 1, n: int = N_PARTICLES,
                  orbits: float = MAX_ORBITS):
    """The sheet of this case (validated like a user's YAML), run until stationary."""
    from ringsim.config.scenario import with_overrides

    sc = sheet_scenario(f"friction-ring-{name}", size_distribution=MONODISPERSE_1M,
                        restitution=DILLEY_KAPPA0, tau=TAU, n=n, orbits=orbits, seed=seed,
                        collision_detection="line", timeseries_every=0.1,
                        initial_dispersion=30.0)
    return with_overrides(sc, {"friction": friction, "integration.until_equilibrium": True,
                               "output.snapshot_every": 5.0})


def ring_case(name: str, friction: dict, workdir: Path, seed: int = 1) -> dict:
    """Run (or reuse) one case and return its measured numbers and the reference."""
    from ringsim.analysis.equilibrium import equilibrium

    t0 = time.process_time()
    run = run_cached(ring_scenario(name, friction, seed), workdir / f"friction_ring_{name}"
                     f"_seed{seed}.h5")
    eq = equilibrium(run)
    spin, budget = eq["spin"], eq["energy_budget"]
    beta = friction.get("beta", friction.get("beta0", 0.0))
    return {"name": name, "friction": friction, "seed": seed,
            "in_equilibrium": eq["in_equilibrium"], "reason": eq["reason"],
            "orbits": eq["orbits"], "from_orbit": eq["equilibrium_from_orbit"]["mean"],
            "c_rOmega": eq["velocity_dispersion_rOmega"], "mean_epsilon": eq["mean_epsilon"],
            "collision_frequency": eq["collision_frequency"],
            "ratio": spin["rotational_energy_fraction"],
            "ratio_about_mean": spin["rotational_energy_fraction_random"]["mean"],
            "closed_form": spin_temperature.collisional_spin_ratio(beta),
            "closed_form_beta": beta,
            "mean_spin_z": spin["mean_spin_z"], "rms_spin": spin["rms_spin"],
            "sliding_fraction": spin["sliding_fraction"]["mean"],
            "heating_over_dissipation": budget["ratio"],
            "tangential_share": budget["tangential_share"]["mean"],
            "cpu_s": time.process_time() - t0}


def table(rows: list[dict]) -> str:
    """The Markdown table of docs/validation.md."""
    out = ["| case | stationary from orbit | c/(r Omega) | mean eps_n | E_rot/E_tr | "
           "closed form | difference | E_rot about the mean spin / E_tr | difference | "
           "mean w_z/Omega | rms w/Omega | sliding | tangential share of dissipation | "
           "heating/dissipation |",
           "|---|---|---|---|---|---|---|---|---|---|---|---|---|---|"]
    for r in rows:
        d = r["ratio"]["mean"] / r["closed_form"] - 1.0
        d_mean = r["ratio_about_mean"] / r["closed_form"] - 1.0
        out.append(
            f"| {r['name']} ({r['friction']}) | {r['from_orbit']:.3g} of {r['orbits']:.3g}"
            f"{'' if r['in_equilibrium'] else ' (NOT stationary)'} | "
            f"{r['c_rOmega']['mean']:.3g} ± {r['c_rOmega']['stderr']:.2g} | "
            f"{r['mean_epsilon']['mean']:.3f} | "
            f"{r['ratio']['mean']:.4f} ± {r['ratio']['stderr']:.2g} | "
            f"{r['closed_form']:.4f} (beta = {r['closed_form_beta']:g}) | {100 * d:+.1f} % | "
            f"{r['ratio_about_mean']:.4f} | {100 * d_mean:+.1f} % | "
            f"{r['mean_spin_z']['mean']:.3f} ± {r['mean_spin_z']['stderr']:.2g} | "
            f"{r['rms_spin']['mean']:.3g} ± {r['rms_spin']['stderr']:.2g} | "
            f"{100 * r['sliding_fraction']:.1f} % | {100 * r['tangential_share']:.1f} % | "
            f"{r['heating_over_dissipation']['mean']:.4f} ± "
            f"{r['heating_over_dissipation']['stderr']:.2g} |")
    return "\n".join(out)


def main(argv: list[str] | None = None, prog: str | None = None) -> None:
    """``python -m validation friction-ring``: run the cases and print their table."""
    parser = argparse.ArgumentParser(prog=prog, description=__doc__.splitlines()[0])
    parser.add_argument("--workdir", default="runs/validation")
    parser.add_argument("--cases", nargs="+", default=list(CASES), choices=list(CASES))
    parser.add_argument("--json", default=None, help="also write the rows as JSON here")
    args = parser.parse_args(argv)
    workdir = Path(args.workdir)
    workdir.mkdir(parents=True, exist_ok=True)
    rows = [ring_case(name, CASES[name], workdir) for name in args.cases]
    print(table(rows))
    for r in rows:
        print(f"{r['name']}: {r['cpu_s']:.0f} CPU-s")
    if args.json:
        Path(args.json).write_text(json.dumps(rows, indent=1, default=float) + "\n")
