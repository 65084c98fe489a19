"""The spins of a study's runs with surface friction: what a run summary keeps of
``analysis.spins.spin_equilibrium`` and their seed means per case.

A summary of a run with friction holds ``spin``: the window means (with their standard
errors) of E_rot/E_tr (the kinetic energy relative to the shear flow), of the same with
the spins taken about each size bin's mean spin, of the mean z-spin and the rms spin (in
units of Omega, rotating frame) and the share of sliding contacts, and the closed-form
collisional balance of E_rot/E_tr (``physics.spin_temperature.collisional_spin_ratio``;
null for Coulomb friction).  A case's entry in ``report.json`` holds their seed means when
every run of the case has them; references name them ``spin.QUANTITY``.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence

from ringsim.analysis import budget
from ringsim.config.study_references import SPIN_QUANTITIES

#: What the report's rows call the spin references, with the unit of their numbers.
SPIN_LABELS = {"spin.rotational_energy_fraction": "E_rot / E_tr",
               "spin.rotational_energy_fraction_random": "E_rot about the mean spin / E_tr",
               "spin.mean_spin_z": "mean w_z [Omega, rotating frame]",
               "spin.rms_spin": "rms |w| [Omega, rotating frame]",
               "spin.sliding_fraction": "share of sliding contacts"}


def spin_summary(eq: Mapping) -> dict | None:
    """The ``spin`` of a run summary from its equilibrium (``ringsim.equilibrium``), or
    None for a run without friction."""
    spin = eq.get("spin")
    if not spin:
        return None
    out: dict = {key: dict(spin[key]) for key in SPIN_QUANTITIES}
    ratio = spin.get("collisional_spin_ratio")
    out["collisional_spin_ratio"] = None if ratio is None else float(ratio)
    return out


def case_spin(summaries: Sequence[Mapping]) -> dict | None:
    """The seed means of the spin quantities of a case's runs (``budget.replica_mean``),
    or None unless every run has them."""
    if not summaries or not all(s.get("spin") for s in summaries):
        return None
    out: dict = {key: budget.replica_mean([budget.replica_value(s["spin"][key])
                                           for s in summaries])
                 for key in SPIN_QUANTITIES}
    out["collisional_spin_ratio"] = summaries[0]["spin"].get("collisional_spin_ratio")
    return out


def spin_value(case: Mapping, quantity: str) -> dict:
    """The case's seed mean of ``spin.QUANTITY`` (NaN when the case has no spins)."""
    spin = case.get("spin") or {}
    key = quantity.removeprefix("spin.")
    return dict(spin.get(key, {"mean": float("nan"), "stderr": float("nan"),
                               "units": "dimensionless"}))
