"""The regimes of a self-gravitating ring against r_h, as measured in
docs/validation.md, "Self-gravity": no wakes at r_h = 0.6, aggregates at r_h = 1.3.

Short runs (slow: about three CPU-minutes together): tau = 0.25, 1 m ice, Bridges law,
r_h set by the orbital radius, dt fixed at 5e-4 orbit.
"""

import pytest

import ringsim
from ringsim.analysis.clumps import clump_statistics
from ringsim.analysis.gravitating import snapshot_wakes
from ringsim.physics import gravity as patch
from ringsim.physics.selfgravity import shear_offset

GM = 3.7931e16           # [m^3/s^2] Saturn


def regime_run(gravitating_scenario, r_h, n, orbits, path, seed=1):
    a = 1.0e8 * r_h / float(patch.hill_parameter(1.0, 1.0, 900.0, GM, 1.0e8))
    sc = gravitating_scenario(name=f"regime-rh{r_h}", seed=seed, **{
        "planet.a": a, "sheet.optical_depth": 0.25, "sheet.n_particles": n,
        "integration.orbits": orbits, "integration.dt": 5e-4, "integration.dt_safety": 0.2,
        "output.path": "runs/r.h5", "output.snapshot_every": 0.25})
    run = ringsim.open_run(ringsim.run(sc, output=path, progress=False))
    Lx, Ly = float(run.attrs["Lx"]), float(run.attrs["Ly"])
    Omega = sc.orbital_frequency
    out = []
    for i in range(1, run.n_snapshots):
        s = run.snapshot(i)
        shift = shear_offset(Omega, Lx, Ly, float(s["t"]))
        out.append({**snapshot_wakes(s, Lx, Ly, Omega),
                    **clump_statistics(s, Lx, Ly, shift, GM, a)})
    return out


@pytest.mark.slow
def test_no_wakes_and_no_aggregates_at_r_h_0_6(tmp_path, gravitating_scenario):
    """Measured: no snapshot's wake significant (p >= 0.03), contrast at the Poisson level,
    no group of 10 touching particles, no group inside its Hill sphere."""
    stats = regime_run(gravitating_scenario, 0.6, 800, 1.0, tmp_path / "a.h5")
    assert not any(s["significant"] for s in stats), [s["p_value"] for s in stats]
    assert all(s["amplitude"] < 1.05 * s["poisson_amplitude"] for s in stats)
    assert all(s["grouped"] == 0.0 and s["hill_groups"] == 0 for s in stats)


@pytest.mark.slow
def test_aggregates_at_r_h_1_3(tmp_path, gravitating_scenario):
    """Aggregates form in every one of three seeds at orbit 0.75.  One run is one draw of a
    chaotic collapse: seeds 1-3 put 42, 31 and 19 % of the mass in groups that fit their
    Hill sphere (largest 199, 122, 73 particles) with the code of b7787d7, and 20, 26 and
    19 % (largest 44, 113, 73) after P3M's layer padding of 2026-11-24 changed the round-off
    (seed 3 nearly the same run in both, seed 1 a new draw; the means differ by 1.4 standard
    errors).  The earlier single-seed bounds, half of seed 1's one draw (20 %, 50
    particles), failed seed 3 of the old code too.  Bounds now about half of the smallest of
    the six runs; in contact groups of >= 10 particles 62-68 %, surface-density contrast
    1.35-1.47 times Poisson.  At r_h = 0.6 (above) there is no group at all."""
    for seed in (1, 2, 3):
        late = regime_run(gravitating_scenario, 1.3, 2000, 0.75, tmp_path / f"b{seed}.h5",
                          seed=seed)[-1]
        assert late["significant"], seed
        assert late["grouped"] > 0.3 and late["in_hill_groups"] > 0.09, (seed, late)
        assert late["largest_hill_group"] >= 20, (seed, late)
        assert late["amplitude"] > 1.2 * late["poisson_amplitude"], seed
