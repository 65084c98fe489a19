"""Random against coherent motion, weightings and spins about the mean (issue 38).

Synthetic sheets with known parts: the diagnostics must give each part back.
"""

import math

import numpy as np
import pytest

from ringsim import quantities
from ringsim.analysis import motions, spins
from ringsim.analysis.equilibrium import equilibrium_table, stationary_window
from ringsim.physics.p3m_mesh import long_range_fraction


def _sheet(rng, n, L):
    return rng.uniform(-L / 2, L / 2, n), rng.uniform(-L / 2, L / 2, n)


def test_local_dispersion_gives_back_the_random_part_beside_a_coherent_wave():
    """A periodic wave u_x = A cos(k . r) with (4, 0) and then (3, 3) wavelengths across a
    1000 m box (250 m along x; 236 m pitched at 45 deg) plus Gaussian random motion of
    sigma = 1 mm/s per component.  The global rms holds both parts; the local dispersion in
    cells of 31.25 m gives back sigma plus the leak of the wave through the cell means,
    (A^2 / 2) (1 - (sinc(n_x cell / L) sinc(n_y cell / L))^2) / 3 in the 1-D variance (the
    share of the wave's variance inside a cell; 5-6 % here).  Tolerance 2 %: the sampling
    error of sigma^2 from 3 x 20000 numbers is 0.6 %."""
    rng = np.random.default_rng(38)
    n, L, sigma, A = 20000, 1000.0, 1e-3, 3e-3
    x, y = _sheet(rng, n, L)
    cell = L / 32
    for nx, ny in ((4, 0), (3, 3)):
        phase = 2 * np.pi * (nx * x + ny * y) / L
        leak = (A ** 2 / 2) * (1 - (np.sinc(nx * cell / L) * np.sinc(ny * cell / L)) ** 2) / 3
        u = rng.normal(0.0, sigma, (n, 3))
        u[:, 0] += A * np.cos(phase)
        c_global = math.sqrt(np.mean(np.sum(u * u, axis=1)) / 3)
        assert c_global == pytest.approx(math.sqrt(sigma ** 2 + A ** 2 / 6), rel=0.02)
        c_local = motions.local_dispersion(x, y, u, np.ones(n), L, L, cell)
        assert c_local == pytest.approx(math.sqrt(sigma ** 2 + leak), rel=0.02)
        # the coherent part is gone: sqrt(c^2 - c_loc^2) is the wave's sqrt(A^2 / 6),
        # 1.22 mm/s, less the leak
        assert math.sqrt(c_global ** 2 - c_local ** 2) == pytest.approx(
            math.sqrt(A ** 2 / 6 - leak), rel=0.05)


def test_local_dispersion_is_unbiased_for_mixed_sizes_and_by_mass():
    """Light particles (1 kg, sigma 2 mm/s) and heavy ones (1000 kg, sigma 0.2 mm/s) mixed
    in cells of 6 particles on average, no coherent flow: the number-weighted local
    dispersion gives back sqrt(mean sigma^2), the mass-weighted one sqrt(sum m sigma^2 /
    sum m), though each cell's mean is estimated from a few particles.  Tolerance 3 %
    (number) and 6 % (mass, dominated by the 20 % heavy particles): several sampling
    errors of these variances."""
    rng = np.random.default_rng(5)
    n, L = 30000, 1000.0
    x, y = _sheet(rng, n, L)
    heavy = rng.random(n) < 0.2
    s = np.where(heavy, 2e-4, 2e-3)
    m = np.where(heavy, 1000.0, 1.0)
    u = rng.normal(0.0, 1.0, (n, 3)) * s[:, None]
    cell = math.sqrt(6 * L * L / n)
    number = motions.local_dispersion(x, y, u, np.ones(n), L, L, cell)
    mass = motions.local_dispersion(x, y, u, m, L, L, cell)
    assert number == pytest.approx(math.sqrt(np.mean(s ** 2)), rel=0.03)
    assert mass == pytest.approx(math.sqrt(np.sum(m * s ** 2) / np.sum(m)), rel=0.06)


def test_local_cell_is_an_eighth_of_lambda_cr_but_holds_four_particles():
    assert motions.local_cell(1000.0, 1000.0, 100000, 400.0) == pytest.approx(50.0)
    # 1000 particles in 1000 m x 1000 m: four per cell need a side of 63.2 m
    assert motions.local_cell(1000.0, 1000.0, 1000, 400.0) == pytest.approx(
        math.sqrt(4000.0), rel=1e-12)


def test_thickness_by_cross_section_weights_the_large_particles():
    """Small particles (r = 1 m) at z = +-4 m, large ones (r = 3 m) at z = +-1 m, equal
    numbers: rms z is sqrt(8.5) by number and sqrt((16 + 9) / 10) by pi r^2 (exact)."""
    z = np.array([4.0, -4.0, 1.0, -1.0])
    r = np.array([1.0, 1.0, 3.0, 3.0])
    assert motions.weighted_thickness(z, np.ones(4)) == pytest.approx(math.sqrt(8.5))
    assert motions.weighted_thickness(z, np.pi * r ** 2) == pytest.approx(math.sqrt(2.5))


def test_spins_drawn_as_a_known_mean_plus_a_known_random_part_come_back_per_bin():
    """Two size bins, each with its own mean spin and random spread: the energy about the
    bin's mean is 1/2 sum I 3 s^2 and the mean part 1/2 sum I |<w>|^2 (rotating frame) and
    1/2 sum I |<w> + Omega z|^2 (inertial).  Tolerances: 3 % on the random part (sampling
    error of 3 x 20000 squares, 0.6 %); 0.06 Omega on the mean spin, four times the
    standard error s / sqrt(n) of a component of the sample mean (0.014 Omega at s = 2
    Omega)."""
    rng = np.random.default_rng(11)
    Omega, k, n = 2e-4, 0.4, 20000
    radius = np.r_[np.full(n, 1.0), np.full(n, 3.0)]
    mass = 900.0 * 4 / 3 * np.pi * radius ** 3
    index = np.r_[np.zeros(n, int), np.ones(n, int)]
    means = np.array([[0.0, 0.0, -0.75 * Omega], [0.1 * Omega, 0.0, -1.0 * Omega]])
    spread = np.array([2.0 * Omega, 0.5 * Omega])
    w = means[index] + rng.normal(0.0, 1.0, (2 * n, 3)) * spread[index][:, None]
    parts = spins.spin_energy_parts(mass, radius, w, k, Omega, index, 2)
    inertia = k * mass * radius ** 2
    for b in range(2):
        total_inertia = inertia[index == b].sum()
        assert parts["random"][b] == pytest.approx(0.5 * total_inertia * 3 * spread[b] ** 2,
                                                   rel=0.03)
        mean = np.sqrt(2 * parts["mean_rotating"][b] / total_inertia)
        assert mean == pytest.approx(np.linalg.norm(means[b]), abs=0.06 * Omega)
        inertial = np.sqrt(2 * parts["mean_inertial"][b] / total_inertia)
        assert inertial == pytest.approx(np.linalg.norm(means[b] + [0, 0, Omega]),
                                         abs=0.06 * Omega)
    assert np.allclose(parts["random"] + parts["mean_rotating"], parts["total"], rtol=1e-12)


def test_the_verdict_judges_the_mass_weighted_series_and_quotes_units():
    """Number-weighted c and H stationary, the mass-weighted c still drifting by 30 %
    over the window: not in equilibrium, the reason names the series and the slope in
    mm/s per orbit."""
    rng = np.random.default_rng(1)
    orbits = np.linspace(0, 100, 1001)
    c = 4e-3 + 1e-5 * rng.normal(size=orbits.size)
    h = 20.0 + 0.05 * rng.normal(size=orbits.size)
    drifting = 2e-3 * (1 + 0.006 * orbits) + 1e-6 * rng.normal(size=orbits.size)
    assert stationary_window(orbits, c, h)["in_equilibrium"]
    verdict = stationary_window(orbits, c, h, mass_weighted=(drifting, h))
    assert not verdict["in_equilibrium"]
    assert "mass-weighted velocity dispersion: still drifting" in verdict["reason"]
    assert "mm/s per orbit" in verdict["reason"]


def _table_eq(in_equilibrium: bool) -> dict:
    value = {"mean": 1.0, "stderr": 0.1, "units": "m"}
    eq = {key: dict(value) for key in quantities.EQUILIBRIUM}
    eq.update(name="x", n_particles=10, orbits=5.0, optical_depth=0.1, status="finished",
              in_equilibrium=in_equilibrium, reason="thickness: still drifting: slope 1 m "
              "per orbit", equilibrium_from_orbit={"mean": 1.0}, per_size_bin=[],
              kinetic_estimate={"status": "none", "reason": "-"}, law_range=None,
              energy_budget=None, spin=None)
    return eq


def test_the_table_names_each_weighting_and_prints_a_warning_once():
    text = equilibrium_table(_table_eq(False))
    assert text.count("slope 1 m per orbit") == 1
    assert "velocity dispersion c, number-weighted [mm/s]" in text
    assert "thickness H (rms z), number-weighted [m]" in text
    assert sum(line.startswith("WARNING") for line in text.splitlines()) == 1


def test_the_p3m_cutoff_constant_is_the_computed_one():
    """1 - L(5 r_s) = erfc(2.5) + (5 / sqrt(pi)) exp(-6.25) = 5.85e-3, as the source and
    docs/gravity.md state it."""
    rest = 1.0 - long_range_fraction(5.0, 1.0)
    assert rest == pytest.approx(math.erfc(2.5) + 5 / math.sqrt(math.pi) * math.exp(-6.25),
                                 rel=1e-12)
    assert f"{rest:.3g}" == "0.00585"
    from pathlib import Path
    root = Path(__file__).resolve().parents[1]
    for path in ("src/ringsim/physics/p3m_scales.py", "src/ringsim/csrc/rs_p3m.c",
                 "docs/gravity.md"):
        text = (root / path).read_text()
        assert "5.85e-3" in text and "3.6e-3" not in text, path


def test_a_gravitating_run_prints_one_energy_balance(tmp_path, gravitating_scenario):
    """The tiny self-gravitating sheet (0.2 orbit): its table holds one energy balance, the
    one with nu_grav where that is measured, else the shear-heating budget; never both and
    no rows of "n/a"."""
    import ringsim

    path = ringsim.run(gravitating_scenario(), output=tmp_path / "g.h5", progress=False)
    eq = ringsim.equilibrium(ringsim.open_run(path))
    text = equilibrium_table(eq)
    with_gravity = text.count("heating / (dissipation + d/dt E_kin)")
    without = text.count("heating / dissipation ")
    assert with_gravity + without == 1, text
    assert with_gravity == int(math.isfinite(eq["energy_closure"]["mean"]))
    assert "n/a" not in text
    # the headline numbers by weighting, in the JSON with their declared units
    for key in motions.MOTION_KEYS + ("velocity_dispersion_number_weighted",
                                      "thickness_number_weighted", "local_dispersion_cell"):
        assert eq[key]["units"] == quantities.unit(key) and math.isfinite(eq[key]["mean"])
    assert eq["weightings"]["thickness_cross_section_weighted"] == "cross section"
    assert eq["weightings"]["velocity_dispersion"] == "number"
    assert eq["weightings"]["toomre_Q_mass"] == "mass"
    assert "local velocity dispersion c_loc, number-weighted" in text


@pytest.mark.parametrize("sizes, shown", [({}, False), (
    {"particles.size_distribution": {"kind": "monodisperse", "radius": 1.0}}, True)])
def test_the_closed_form_is_printed_for_identical_spheres_only(tmp_path, rough_scenario,
                                                               sizes, shown):
    """A 0.2-orbit rough ring (beta = 0) of 1-2 m particles, and the same of identical 1 m
    spheres: only the second prints the closed form 2/9 (beside E_rot about the mean
    spin, which is at most E_rot: the mean spin's part is >= 0)."""
    import ringsim

    sc = rough_scenario({"model": "constant", "beta": 0.0},
                        **{"integration.orbits": 0.2, **sizes})
    path = ringsim.run(sc, output=tmp_path / "r.h5", progress=False)
    eq = ringsim.equilibrium(ringsim.open_run(path))
    text = equilibrium_table(eq)
    assert ("closed form" in text) is shown
    assert eq["spin"]["closed_form_applies"] is shown
    assert "E_rot about the mean spin / E_tr" in text
    for b in eq["spin"]["per_size_bin"]:
        assert b["rotational_energy_random"] <= b["rotational_energy"] * (1 + 1e-12)
        assert b["rotational_energy_mean_rotating"] >= 0.0


def test_compare_prints_each_warning_once(tmp_path, ring_scenario, capsys):
    """The tiny ring (0.3 orbit) is not in equilibrium: ``compare`` says so once (in its
    table), not again on stderr; ``analyze`` once as well."""
    import ringsim
    from ringsim.cli import main

    path = ringsim.run(ring_scenario(), output=tmp_path / "r.h5", progress=False)
    assert main(["compare", str(path), str(path)]) == 0
    captured = capsys.readouterr()
    assert (captured.out + captured.err).count("never reached equilibrium") == 2  # two runs
    assert main(["analyze", str(path)]) == 0
    captured = capsys.readouterr()
    assert (captured.out + captured.err).count("never reached equilibrium") == 1
