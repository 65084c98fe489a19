"""Dilley (1993) Figs. 1 and 5 in ringsim: the validation ladder's case 6, a comparison
with the paper's equations rather than with a run's statistics, so a test
(docs/validation.md, "Reference cases").

The paper's equations are typed here anew, independently of ``ringsim.physics``: eq.
(5.13) with (5.9) for a sphere of radius R on a brick (Fig. 1b-d), eqs. (5.19)-(5.21) for
two spheres of equal density, 60 g per 2.5 cm sphere, smaller radius R1 and radius ratio
delta = R1/R2 (Fig. 5a, kappa = 0; Fig. 5b, kappa = 0.1), xi0 = 0.16, p = 0.65.  Checked
against them:

* the curves ``ringsim epsilon`` prints and draws (``ringsim.plots.paper_curves``), to
  1e-12 (round-off of the same formula written twice);
* the epsilon the resolver applies: head-on collisions of two spheres in a plain REBOUND
  simulation with ringsim's resolver at 0.01-2 cm/s, separation speed after over approach
  speed before, to 1e-9 (round-off of the velocity difference);
* the epsilon the running resolver logs in a hot sheet of the figures' radii, collision by
  collision, to 1e-12, with at least 20 impacts at the figures' speeds (the slow test runs
  all five sheets of the ladder's case 6).
"""

from __future__ import annotations

import math

import numpy as np
import pytest
import rebound

from ringsim.config.scenario import scenario_from_dict
from ringsim.engine import sheet
from ringsim.engine.resolver import install_resolver
from ringsim.physics import restitution as rs
from ringsim.plots import paper_curves

#: Reference density of the paper's equal-density form: 60 g per sphere of 2.5 cm [kg/m^3].
RHO = 0.060 / (4.0 / 3.0 * math.pi * 0.025**3)
#: The figures' impact speeds [m/s]: 0.01-2 cm/s.
FIG_SPEEDS = (1e-4, 2e-2)


def paper_fig1_epsilon(v, R: float, xi0: float = 0.16, p: float = 0.65):
    """Dilley (1993) eqs. (5.9), (5.13): eps of a sphere of radius R [m] on a brick at
    normal speed v [m/s]."""
    xi = xi0 * (R / 0.025) ** -0.2 * (np.asarray(v) / 0.01) ** p
    with np.errstate(invalid="ignore", divide="ignore"):
        eps = np.exp(-math.pi * xi / np.sqrt(1.0 - xi * xi))
    return np.where(xi < 1.0, eps, 0.0)


def paper_fig5_epsilon(v, R1: float, delta: float, kappa: float, xi0: float = 0.16,
                       p: float = 0.65):
    """Dilley (1993) eqs. (5.19)-(5.21): eps of equal-density spheres, smaller radius R1
    [m], radius ratio delta = R1/R2, at normal speed v [m/s]."""
    f = (1.0 + delta) ** 0.2 * (1.0 + delta**3) ** kappa
    xi = xi0 * f * (R1 / 0.025) ** (-3.0 * kappa - 0.2) * (np.asarray(v) / 0.01) ** p
    with np.errstate(invalid="ignore", divide="ignore"):
        eps = np.exp(-math.pi * xi / np.sqrt(1.0 - xi * xi))
    return np.where(xi < 1.0, eps, 0.0)


def test_the_curves_of_ringsim_epsilon_are_the_papers_equations():
    curves = paper_curves()
    fig1 = [c for c in curves if c.panel == "fig1"]
    assert [c.label for c in fig1] == ["R = 2.5 cm", "R = 5 cm", "R = 10 cm", "R = 20 cm"]
    for curve, R in zip(fig1, (0.025, 0.05, 0.10, 0.20), strict=True):
        assert np.max(np.abs(curve.epsilon - paper_fig1_epsilon(curve.v, R))) <= 1e-12
    checked = 0
    for kappa in (0.0, 0.1):
        panel = [c for c in curves if c.panel == f"fig5_kappa{kappa:g}"]
        assert len(panel) == 8, "four radii, each against a brick and its twin"
        for curve in panel:
            r1 = {"0.25 cm": 0.0025, "2.5 cm": 0.025, "25 cm": 0.25, "2.5 m": 2.5}[
                curve.label.split(", ")[0].removeprefix("R1 = ")]
            delta = 0.0 if "brick" in curve.label else 1.0
            ref = paper_fig5_epsilon(curve.v, r1, delta, kappa)
            assert np.max(np.abs(curve.epsilon - ref)) <= 1e-12, curve.label
            checked += 1
    assert checked == 16
    assert fig1[0].v.min() == pytest.approx(FIG_SPEEDS[0]) and \
        fig1[0].v.max() == pytest.approx(FIG_SPEEDS[1])


def head_on_epsilon(R: float, v: float, kappa: float) -> float:
    """-(separation speed after) / (approach speed before) of one head-on collision of two
    reference-density spheres of radius R [m] approaching at v [m/s], resolved by
    ringsim's resolver in a plain REBOUND simulation."""
    sim = rebound.Simulation()
    sim.integrator = "leapfrog"
    sim.collision = "direct"
    sim.G = 0.0
    m = RHO * 4.0 / 3.0 * math.pi * R**3
    gap = 1e-3 * R
    sim.add(m=m, r=R, x=-(R + 0.5 * gap), vx=0.5 * v)
    sim.add(m=m, r=R, x=R + 0.5 * gap, vx=-0.5 * v)
    sim.dt = 2.0 * gap / v
    handle = install_resolver(sim, {"model": "dilley", "xi0": 0.16, "p": 0.65,
                                    "kappa": kappa})
    sim.steps(1)
    assert handle.stats()["count"] == 1, "the pair collides exactly once"
    return float((sim.particles[1].vx - sim.particles[0].vx) / v)


@pytest.mark.parametrize("kappa", [0.0, 0.1])
@pytest.mark.parametrize("R", [0.0025, 0.025, 0.25, 2.5])
def test_head_on_pairs_rebound_with_the_papers_epsilon(R, kappa):
    """Twins (delta = 1) of Fig. 5 at 0.01, 0.1, 1 and 2 cm/s; for kappa = 0 the twin of
    radius 2R is also Fig. 1's sphere of radius R on a brick (R_bar = R)."""
    for v in (1e-4, 1e-3, 1e-2, 2e-2):
        measured = head_on_epsilon(R, v, kappa)
        assert abs(measured - float(paper_fig5_epsilon(v, R, 1.0, kappa))) <= 1e-9
        if kappa == 0.0:
            assert abs(measured - float(paper_fig1_epsilon(v, R / 2.0))) <= 1e-9


def sheet_log(radii, kappa: float, speed: float, n: int, orbits: float,
              z_period: float) -> np.ndarray:
    """The collision log of a hot sheet of reference-density ice with the given radii [m]
    (number fractions ~ 1/r: every same-radius pair type collides about as often), 1-D
    dispersion ``speed`` [m/s], at Omega = 2e-3 1/s for ``orbits`` orbits."""
    omega = 2.0e-3                          # [1/s]: a thin sheet at these speeds
    w = np.array([1.0 / r for r in radii])
    fractions = w / w.sum()
    fractions[-1] = 1.0 - fractions[:-1].sum()
    r_mean = float(np.dot(fractions, radii))
    sc = scenario_from_dict({
        "name": "dilley-figures", "seed": 1, "planet": {"Omega": omega},
        "particles": {"density": RHO, "size_distribution": {"kind": "mixture", "components": [
            {"radius": float(r), "number_fraction": float(f)}
            for r, f in zip(radii, fractions, strict=True)]}},
        "sheet": {"optical_depth": 0.2, "n_particles": n, "gravity": False,
                  "initial_dispersion": speed / (r_mean * omega), "z_box": z_period / r_mean},
        "restitution": {"model": "dilley", "xi0": 0.16, "p": 0.65, "kappa": kappa},
        "integration": {"orbits": orbits, "dt": 1.0e-3, "collision_detection": "line"},
        "output": {"timeseries_every": 0.1, "snapshot_every": 1000.0,
                   "log_collisions": 500_000}}, source="<test dilley figures>")
    built = sheet.build_sheet(sc)
    built.sim.integrate(orbits * sc.orbital_period, exact_finish_time=0)
    assert sheet.vertical_guard_ok(sheet.particle_arrays(built.sim), built.geometry)
    return built.resolver.stats()["log"]


def check_log(log: np.ndarray, radii, kappa: float, fig1: bool) -> int:
    """Every logged eps against ringsim.restitution and, per pair type, against the
    paper's equations; the number of pair types checked."""
    law = {"model": "dilley", "xi0": 0.16, "p": 0.65, "kappa": kappa}
    expected = rs.epsilon_for_pair(law, log["v_n"], log["R_bar"], log["M_bar"])
    assert np.max(np.abs(log["epsilon"] - expected)) <= 1e-12
    groups = 0
    for i, r1 in enumerate(radii):
        for r2 in radii[i:]:
            if fig1 and r1 != r2:
                continue
            sel = np.isclose(log["R_bar"], r1 * r2 / (r1 + r2), rtol=1e-9)
            v, eps = log["v_n"][sel], log["epsilon"][sel]
            ref = (paper_fig1_epsilon(v, r1 / 2.0) if fig1
                   else paper_fig5_epsilon(v, r1, r1 / r2, kappa))
            assert np.max(np.abs(eps - ref)) <= 1e-12, (r1, r2)
            in_range = (v >= FIG_SPEEDS[0]) & (v <= FIG_SPEEDS[1])
            assert in_range.sum() >= 20, f"too few impacts at 0.01-2 cm/s for {r1}, {r2}"
            groups += 1
    return groups


def test_running_resolver_logs_the_papers_epsilon_for_fig5b():
    """Fig. 5b (kappa = 0.1): 0.25 cm and 2.5 cm spheres (pairs of delta = 1 and 0.1)."""
    radii = (0.0025, 0.025)
    log = sheet_log(radii, 0.1, 3e-3, n=300, orbits=1.0, z_period=240.0)
    assert check_log(log, radii, 0.1, fig1=False) == 3


#: The five sheets of the ladder's case 6: radii [m], kappa, 1-D dispersion [m/s],
#: orbits, vertical period of the box [m], and whether they check Fig. 1.  The nearly
#: elastic 25 cm + 2.5 m sheets heat fast: they start colder, run shorter, in taller boxes.
SHEETS = [((0.05, 0.10, 0.20, 0.40), 0.0, 3e-3, 3.0, 240.0, True),
          ((0.0025, 0.025), 0.0, 3e-3, 3.0, 240.0, False),
          ((0.25, 2.5), 0.0, 1e-3, 1.5, 3000.0, False),
          ((0.0025, 0.025), 0.1, 3e-3, 3.0, 240.0, False),
          ((0.25, 2.5), 0.1, 1e-3, 1.5, 3000.0, False)]


@pytest.mark.slow
@pytest.mark.parametrize("radii, kappa, speed, orbits, z_period, fig1", SHEETS)
def test_running_resolver_logs_the_papers_epsilon_in_every_figure(radii, kappa, speed,
                                                                  orbits, z_period, fig1):
    log = sheet_log(radii, kappa, speed, n=400, orbits=orbits, z_period=z_period)
    assert check_log(log, radii, kappa, fig1) == (len(radii) if fig1 else 3)
