"""Issue 13, item 4(c): a ring patch of rough particles against the collisional balance.

The base scenario of ``studies/validation-friction-ring``: identical 1 m ice spheres,
tau = 0.1, Dilley eps_n at kappa = 0, constant beta = 0, line detection, run until
stationary (slow: about a CPU-minute).  The study states E_rot/E_tr; the energy budget,
which its summaries do not hold, is asserted here from the run itself.
E_rot/E_tr over the stationary window is asserted against
``physics.spin_temperature.collisional_spin_ratio(0) = 2/9`` (Morishima & Salo 2004's optically
thin prediction) within TOLERANCE, and the energy budget against 1.
"""

from __future__ import annotations

from pathlib import Path

import pytest

import ringsim
from ringsim.analysis.equilibrium import equilibrium
from ringsim.config.scenario import load_scenario, with_overrides
from ringsim.physics import spin_temperature
from ringsim.store.runfile import open_run

SCENARIO = Path(__file__).resolve().parent.parent / "studies" / "validation-friction-ring" \
    / "scenario.yaml"

#: |E_rot/E_tr / closed form - 1| allowed: the offset measured in docs/validation.md
#: ("Rough particles in a ring patch": +7.8 % at beta = 0 and +7.9 % at beta = 0.5, the
#: power-law rings of studies/kappa-friction +5 % to +11 %), rounded up to 10 %, plus 3
#: standard errors.
OFFSET = 0.10


@pytest.mark.slow
def test_ring_patch_rotational_energy_fraction_against_the_closed_form(tmp_path):
    sc = with_overrides(load_scenario(SCENARIO),
                        {"friction": {"model": "constant", "beta": 0.0}})
    path = tmp_path / "beta0.h5"
    ringsim.run(sc, output=path, force=True, progress=False)
    eq = equilibrium(open_run(path))
    assert eq["in_equilibrium"], eq["reason"]
    closed = spin_temperature.collisional_spin_ratio(0.0)
    assert closed == pytest.approx(2.0 / 9.0, rel=1e-15)
    ratio = eq["spin"]["rotational_energy_fraction"]
    assert abs(ratio["mean"] - closed) <= OFFSET * closed + 3.0 * ratio["stderr"], ratio
    budget = eq["energy_budget"]["ratio"]
    assert abs(budget["mean"] - 1.0) <= 3.0 * budget["stderr"] + 0.01, budget
