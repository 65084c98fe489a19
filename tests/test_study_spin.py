"""The spins of a study with friction (``ringsim.study.spin``): what a run summary keeps of
the equilibrium's ``spin``, their seed means per case, and references on them
(``spin.QUANTITY``; docs/studies.md, "Reference values")."""

from __future__ import annotations

import math

import pytest

from ringsim.config.schema import ScenarioError, Section
from ringsim.config.study_references import SPIN_QUANTITIES, read_references
from ringsim.study.references import reference_entry
from ringsim.study.spin import case_spin, spin_summary


def value(mean: float, stderr: float, units: str = "dimensionless") -> dict:
    return {"mean": mean, "stderr": stderr, "units": units}


def equilibrium_with_spin(fraction: float) -> dict:
    spin = {key: value(1.0, 0.1) for key in SPIN_QUANTITIES}
    spin["rotational_energy_fraction"] = value(fraction, 0.01)
    spin.update(collisional_spin_ratio=2.0 / 9.0, per_size_bin=[{"n": 3}], friction={})
    return {"spin": spin}


def test_a_summary_keeps_the_window_means_and_the_closed_form_only():
    summary = spin_summary(equilibrium_with_spin(0.25))
    assert set(summary) == {*SPIN_QUANTITIES, "collisional_spin_ratio"}
    assert summary["rotational_energy_fraction"] == value(0.25, 0.01)
    assert summary["collisional_spin_ratio"] == pytest.approx(2.0 / 9.0)
    assert spin_summary({"spin": None}) is None and spin_summary({}) is None


def test_a_case_holds_the_seed_mean_only_when_every_run_has_spins():
    """Two seeds at 0.24 and 0.26 (stderr 0.01 each): mean 0.25, error the larger of the
    propagated 0.01/sqrt(2) and the seed-to-seed standard error of the mean, 0.01."""
    runs = [{"spin": spin_summary(equilibrium_with_spin(f))} for f in (0.24, 0.26)]
    spin = case_spin(runs)
    assert spin["rotational_energy_fraction"]["mean"] == pytest.approx(0.25)
    assert spin["rotational_energy_fraction"]["stderr"] == pytest.approx(0.01)
    assert case_spin([*runs, {"equilibrium": {}}]) is None


def test_a_reference_on_a_spin_quantity_reads_the_case_spin():
    top = Section("<test>", "", {"references": {"c": {"spin.rotational_energy_fraction": {
        "value": 0.2222, "tolerance": 0.0222, "source": "closed form"}}}})
    (ref,) = read_references(top, ["c"], quantities=["velocity_dispersion"])
    case = {"spin": case_spin([{"spin": spin_summary(equilibrium_with_spin(0.30))}])}
    entry = reference_entry(ref, {"c": case})
    assert entry["mean"] == pytest.approx(0.30)
    assert entry["distance"] == pytest.approx((0.30 - 0.2444) / 0.01) and not entry["agrees"]
    assert reference_entry(ref, {"c": {"equilibrium": {}}})["agrees"] is False
    assert math.isnan(reference_entry(ref, {"c": {"equilibrium": {}}})["mean"])
    bad = Section("<test>", "", {"references": {"c": {"spin.bogus": {
        "value": 1.0, "tolerance": 0.1, "source": "s"}}}})
    with pytest.raises(ScenarioError, match="spin.bogus"):
        read_references(bad, ["c"], quantities=["velocity_dispersion"])
