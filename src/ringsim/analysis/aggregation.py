"""Whether a run's ring aggregates: bound Hill-sphere groups, contact groups and the overlap
guard's events (``ringsim analyze`` and ``compare``).

A ring whose particles stick into gravitationally bound aggregates is no granular fluid:
its collision counts are those of particles resting on each other, and averaging them as
the collision frequency of a fluid misreads them.  This module finds the aggregates of
each snapshot in the equilibrium window and the verdict ``aggregating``.

* **Hill groups**: the contact groups (``analysis.clumps``: centres closer than 1.05 times
  the sum of the radii, friends of friends, across the shear-periodic boundaries) and,
  in each, the members bound to it.  A member is bound when it lies inside the group's
  Hill sphere, |r - r_cm| + R < r_H = (G M / (3 Omega^2))^(1/3) = a (M / (3 M_p))^(1/3)
  (M the group's mass), and its Jacobi energy in Hill's problem about the group's centre
  of mass lies below that of the Lagrange points L1 and L2, from which it could leave:

      E_J = |dv|^2 / 2 - (3/2) Omega^2 dx^2 + (1/2) Omega^2 dz^2 - G M / max(r, r_g)
            + (9/2) Omega^2 r_H^2 < 0,

  dv its velocity relative to the centre of mass in the rotating frame (shear included),
  dx, dz its radial and vertical offsets, r its distance and r_g the larger of the
  group's mass-weighted rms radius and the member's radius (the point mass's potential is
  capped there, near its value inside a uniform pile).  Below the Lagrange points' level
  the zero-velocity surface about a point mass is closed, so a member cannot leave
  without another collision; here the rest of the group stands for the point mass.  For
  a touching pair of identical spheres at rest the Hill-sphere condition is r_h > 1, the
  energy one r_h > 0.75.  The share of the mass bound in groups of two or more is
  ``bound_fraction``.
* **Contact groups** (``analysis.clumps``): centres closer than 1.05 times the sum of the
  radii; the share of the mass in groups of at least ``clumps.MIN_GROUP`` particles.
* **Overlap-guard events** (the run file's time series): the rows in which pairs overlap
  by more than 10 % of the smaller radius (``overlapping_pairs``) and the share of the
  collisions that were multi-encounters (``multi_encounters``), both signs of particles
  pressed together.

A run is ``aggregating`` when its window's snapshots hold on average at least
`AGGREGATING_FRACTION` of their mass in Hill groups (``bound_fraction_mean``).  The mean,
not the largest share of one snapshot: in a broad size distribution a few boulders hold
half the mass, and a boulder holding a few small particles for one snapshot would
otherwise call a granular ring aggregating, the more surely the more snapshots its window
has.  Runs without self-gravity have no
Hill groups and are never aggregating.  ``withhold_collision_statistics`` then replaces
the collision statistics of the equilibrium with NaN and keeps the fluid averages apart.
"""

from __future__ import annotations

import math

import numpy as np

from ringsim import quantities
from ringsim.analysis import clumps
from ringsim.analysis.window import window_snapshot_indices
from ringsim.physics.constants import G_SI
from ringsim.physics.selfgravity import shear_offset

#: A window whose snapshots hold on average at least this share of their mass in bound
#: Hill groups makes the run aggregating [dimensionless]: above the few per cent of
#: transient bound pairs and triples of a ring that does not aggregate (docs/validation.md,
#: "Where the rings start to aggregate").
AGGREGATING_FRACTION = 0.1
#: The equilibrium's collision statistics, withheld for an aggregating run.
COLLISION_KEYS = ("collision_frequency", "collisional_viscosity", "mean_epsilon")
#: The keys of an aggregation whose units ``quantities`` declares.
AGGREGATION_UNITS = ("rows", "overlap_rows", "max_overlapping_pairs", "multi_encounter_share",
                     "bound_fraction_mean", "bound_fraction_max", "bound_fraction_last",
                     "contact_fraction_last")
#: Printed by ``analyze`` and ``compare`` for an aggregating run.
AGGREGATING_WARNING = ("WARNING: {name} aggregates ({share:.0f} % of the mass in bound "
                       "Hill-sphere groups, the mean over the window's snapshots): its "
                       "collision frequency, collisional viscosity and mean epsilon are "
                       "withheld, they are not those of a granular fluid (the fluid averages "
                       "are in the JSON's aggregation.as_fluid)")


def hill_radius(mass_sum, Omega: float, G: float = G_SI):
    """Mutual Hill radius (G M / (3 Omega^2))^(1/3) [m] of a pair of total mass M.

    Parameters
    ----------
    mass_sum : array [kg]
    Omega : float [1/s]
    G : float [m^3 kg^-1 s^-2]
    """
    return np.cbrt(G * np.asarray(mass_sum, dtype=float) / (3.0 * Omega**2))


def jacobi_energy(d, dv, mass, Omega: float, G: float = G_SI, floor=0.0):
    """Jacobi energy per unit mass [J/kg] of relative motion about a point mass in Hill's
    problem, zero at the Lagrange points L1 and L2 (module docstring).

    Parameters
    ----------
    d : array (N, 3) [m]
        Offsets (radial, azimuthal, vertical) from the point mass.
    dv : array (N, 3) [m/s]
        Relative velocities in the rotating frame.
    mass : array (N,) [kg]
        The point mass (for a pair: both masses).
    Omega : float [1/s]
    G : float [m^3 kg^-1 s^-2]
    floor : array (N,) [m]
        The potential is -G mass / max(|d|, floor).
    """
    d, dv = np.atleast_2d(d), np.atleast_2d(dv)
    r = np.maximum(np.linalg.norm(d, axis=1), floor)
    r_hill = hill_radius(mass, Omega, G)
    return (0.5 * np.sum(dv**2, axis=1) - 1.5 * Omega**2 * d[:, 0] ** 2
            + 0.5 * Omega**2 * d[:, 2] ** 2 - G * np.asarray(mass) / r
            + 4.5 * Omega**2 * r_hill**2)


def bound_members(snap: dict, Lx: float, Ly: float, Omega: float,
                  G: float = G_SI) -> tuple[np.ndarray, np.ndarray]:
    """The contact groups of a snapshot and which particles are bound to theirs (module
    docstring).

    Parameters
    ----------
    snap : dict with x, y, z [m], vx, vy, vz [m/s] (rotating frame), radius [m], mass [kg],
        t [s]
    Lx, Ly : float [m]
    Omega : float [1/s]
    G : float [m^3 kg^-1 s^-2]

    Returns
    -------
    (labels, bound): labels (N,) int, the contact group of each particle; bound (N,) bool.
    """
    mass = np.asarray(snap["mass"], dtype=float)
    radius = np.asarray(snap["radius"], dtype=float)
    x = np.asarray(snap["x"], dtype=float)
    shift = shear_offset(Omega, Lx, Ly, float(snap["t"]))
    labels, rel = clumps.contact_groups(x, snap["y"], snap["z"], radius, Lx, Ly, shift)
    v = np.column_stack([snap["vx"], snap["vy"], snap["vz"]]).astype(float)
    # the first member (lowest index) is each group's origin of ``rel``; a member reached
    # across the radial boundary moves 1.5 Omega Lx slower in y per box further out
    root = np.full(labels.max() + 1, mass.size)
    np.minimum.at(root, labels, np.arange(mass.size))
    v[:, 1] -= 1.5 * Omega * (x[root[labels]] + rel[:, 0] - x)
    group_mass = np.bincount(labels, weights=mass)
    members = np.bincount(labels)
    cm = np.column_stack([np.bincount(labels, weights=mass * c) for c in rel.T]
                         ) / group_mass[:, None]
    vcm = np.column_stack([np.bincount(labels, weights=mass * c) for c in v.T]
                          ) / group_mass[:, None]
    d, dv = rel - cm[labels], v - vcm[labels]
    r = np.linalg.norm(d, axis=1)
    r_g = np.sqrt(np.bincount(labels, weights=mass * r**2) / group_mass)
    M = group_mass[labels]
    floor = np.maximum(r_g[labels], radius)
    bound = ((members[labels] >= 2) & (r + radius < hill_radius(M, Omega, G))
             & (jacobi_energy(d, dv, M, Omega, G, floor) < 0.0))
    return labels, bound


def snapshot_aggregation(snap: dict, Lx: float, Ly: float, Omega: float,
                         G: float = G_SI) -> dict:
    """Hill groups and contact groups of one snapshot.

    Parameters
    ----------
    snap : dict with x, y, z [m], vx, vy, vz [m/s], radius [m], mass [kg], t [s]
    Lx, Ly : float [m]
    Omega : float [1/s]
    G : float [m^3 kg^-1 s^-2]

    Returns
    -------
    dict: ``bound_fraction`` (share of the mass bound in groups of two or more),
    ``bound_groups`` (how many groups hold two or more bound members),
    ``largest_bound_group`` (bound members of the largest), ``contact_fraction`` (share of
    the mass in contact groups of at least ``clumps.MIN_GROUP`` particles),
    ``largest_contact_group`` (particles) [mass shares dimensionless].
    """
    mass = np.asarray(snap["mass"], dtype=float)
    labels, bound = bound_members(snap, Lx, Ly, Omega, G)
    per_group = np.bincount(labels[bound], minlength=labels.max() + 1)
    bound &= per_group[labels] >= 2
    per_group[per_group < 2] = 0
    members = np.bincount(labels)
    big = members[labels] >= clumps.MIN_GROUP
    total = float(mass.sum())
    return {"bound_fraction": float(mass[bound].sum() / total),
            "bound_groups": int(np.count_nonzero(per_group)),
            "largest_bound_group": int(per_group.max()),
            "contact_fraction": float(mass[big].sum() / total),
            "largest_contact_group": int(members.max())}


def overlap_events(ts: dict, start: int) -> dict:
    """The overlap guard's events in the rows from ``start``: ``rows`` (how many),
    ``overlap_rows`` (rows with pairs overlapping by more than 10 % of the smaller radius),
    ``max_overlapping_pairs`` [count] and ``multi_encounter_share`` (multi-encounters per
    collision, NaN without collisions or counts)."""
    rows = max(int(np.asarray(ts["t"]).size) - start, 0)
    overlaps = np.asarray(ts.get("overlapping_pairs", np.zeros(0)))[start:]
    multi = np.asarray(ts.get("multi_encounters", np.zeros(0)), dtype=float)[start:]
    hits = float(np.sum(np.asarray(ts["collisions"], dtype=float)[start:]))
    return {"rows": rows, "overlap_rows": int(np.count_nonzero(overlaps)),
            "max_overlapping_pairs": int(overlaps.max()) if overlaps.size else 0,
            "multi_encounter_share": float(multi.sum() / hits) if hits and multi.size
            else math.nan}


def run_aggregation(run, start: int = 0) -> dict:
    """Aggregation of a run over its equilibrium window (module docstring).

    Parameters
    ----------
    run : ringsim Run
    start : int
        First time-series row of the window.

    Returns
    -------
    dict: `overlap_events` of the window; ``aggregating`` (bool); for a gravitating run
    ``snapshots`` (`snapshot_aggregation` of each window snapshot, with its ``orbit``;
    the last snapshot when none is in the window, ``snapshots_in_window`` False),
    ``bound_fraction_mean`` (the verdict's), ``bound_fraction_max`` and
    ``bound_fraction_last``, ``contact_fraction_last`` [mass shares]; ``units``.
    """
    ts = run.timeseries
    out: dict = overlap_events(ts, start)
    out["aggregating"] = False
    out["units"] = {key: quantities.unit(f"aggregation.{key}") for key in AGGREGATION_UNITS}
    if not run.scenario.sheet.gravity:
        return out
    Lx, Ly = float(run.attrs["Lx"]), float(run.attrs["Ly"])
    Omega = run.scenario.orbital_frequency
    period = run.scenario.orbital_period
    indices, in_window = window_snapshot_indices(run, start)
    snaps = []
    for index in indices:
        snap = run.snapshot(index)
        snaps.append({"orbit": float(snap["t"]) / period,
                      **snapshot_aggregation(snap, Lx, Ly, Omega)})
    shares = [s["bound_fraction"] for s in snaps]
    mean = float(np.mean(shares))
    out.update(snapshots=snaps, bound_fraction_mean=mean, bound_fraction_max=max(shares),
               bound_fraction_last=shares[-1],
               contact_fraction_last=snaps[-1]["contact_fraction"],
               snapshots_in_window=in_window, aggregating=bool(mean >= AGGREGATING_FRACTION))
    return out


def withhold_collision_statistics(eq: dict, agg: dict) -> None:
    """Set ``eq["aggregation"]`` to a run's `run_aggregation` and ``eq["aggregating"]``; for
    an aggregating run move the collision statistics of the equilibrium (`COLLISION_KEYS`)
    to ``eq["aggregation"]["as_fluid"]`` and leave NaN in their place, so that neither the
    table nor a comparison averages them as a fluid's."""
    eq["aggregation"] = agg
    eq["aggregating"] = bool(agg.get("aggregating"))
    if not eq["aggregating"]:
        return
    agg["as_fluid"] = {key: eq[key] for key in COLLISION_KEYS}
    for key in COLLISION_KEYS:
        eq[key] = {"mean": math.nan, "stderr": math.nan, "units": eq[key]["units"]}


def _snapshots(n: int) -> str:
    return "1 snapshot" if n == 1 else f"{n} snapshots"


def aggregation_lines(eq: dict) -> list[str]:
    """Lines of the plain-text equilibrium table: the aggregation numbers, and the warning
    for an aggregating run."""
    agg = eq.get("aggregation")
    if not agg:
        return []
    lines = []
    if "bound_fraction_last" in agg:
        last = agg["snapshots"][-1]
        label = ("aggregation (window snapshots)" if agg.get("snapshots_in_window", True)
                 else "aggregation (last snapshot, before window)")
        lines.append(f"  {label:<42} "
                     f"{100 * agg['bound_fraction_mean']:.1f} % of the mass in bound Hill "
                     f"groups on average over {_snapshots(len(agg['snapshots']))}, at most "
                     f"{100 * agg['bound_fraction_max']:.1f} % in one")
        lines.append(f"  {'aggregation (last snapshot)':<42} "
                     f"{100 * agg['bound_fraction_last']:.1f} % of the mass in bound Hill "
                     f"groups (largest {last['largest_bound_group']} particles), "
                     f"{100 * agg['contact_fraction_last']:.1f} % in contact groups of >= "
                     f"{clumps.MIN_GROUP}")
    share = agg["multi_encounter_share"]
    lines.append(f"  {'overlap guard (window)':<42} {agg['overlap_rows']} of {agg['rows']} "
                 f"rows with pairs overlapping > 10 % (at most {agg['max_overlapping_pairs']}"
                 f"); multi-encounters "
                 + (f"{100 * share:.1f} % of collisions" if math.isfinite(share) else "n/a"))
    if agg["aggregating"]:
        lines.insert(0, AGGREGATING_WARNING.format(name=eq["name"],
                                                   share=100 * agg["bound_fraction_mean"]))
        if eq.get("wake_significant"):
            lines.append(f"  {'':<42} the dominant density mode above is that of the "
                         "aggregates (clumps), not of wakes")
    return lines
