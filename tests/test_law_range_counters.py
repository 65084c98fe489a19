"""The C resolver's counters of the law's measured range, below and above, and of the
critically damped impacts (xi >= 1, eps = 0), from constructed head-on impacts.

Dilley's law was measured at 1e-4 to 5e-2 m/s, reduced radii 2.5-20 cm and reduced masses
60-600 g (``physics.restitution``'s declaration).  Each impact below is resolved by the C
resolver in a plain REBOUND simulation; the counters must tally exactly (they are integer
counts of the impacts constructed).
"""

import ctypes
import math

import rebound
from rebound.simulation import CollisionS
from rebound.vectors import Vec6d

from ringsim.engine.resolver import install_resolver
from ringsim.engine.statistics import UNCOUNTED, checked
from ringsim.physics import restitution as rs

GB = Vec6d(0.0, 0.0, 0.0, 0.0, 0.0, 0.0)


def impacts(law: dict, pairs: list[tuple[float, float, float, float, float]]) -> dict:
    """The resolver's statistics after one head-on impact per pair (R1, R2 [m], M1, M2 [kg],
    v [m/s]), each in a fresh two-particle simulation sharing one resolver's counts."""
    totals: dict = {}
    for R1, R2, M1, M2, v in pairs:
        sim = rebound.Simulation()
        sim.add(m=M1, r=R1, x=0.999 * (R1 + R2), vx=-v * M2 / (M1 + M2))
        sim.add(m=M2, r=R2, x=0.0, vx=v * M1 / (M1 + M2))
        handle = install_resolver(sim, law)
        sim._collision_resolve(ctypes.byref(sim), CollisionS(p1=0, p2=1, gb=GB, ri=0))
        stats = handle.stats()
        assert stats["count"] == 1
        for key, value in stats.items():
            if isinstance(value, int):
                totals[key] = totals.get(key, 0) + value
    return totals


def sphere(radius: float, density: float = 900.0) -> float:
    return density * 4.0 / 3.0 * math.pi * radius**3


DILLEY = {"model": "dilley", "xi0": 0.16, "p": 0.65, "kappa": 0.0}


def test_below_and_above_each_measured_range_are_counted_apart():
    # (R1, R2, M1, M2, v): radii give R_bar = R/2; masses are set apart from the radii so
    # that each dimension is tested on its own
    inside = (0.1, 0.1, 0.4, 0.4, 0.01)          # R_bar 5 cm, M_bar 200 g, 1 cm/s
    slow = (0.1, 0.1, 0.4, 0.4, 1e-5)            # below the speeds
    fast = (0.1, 0.1, 0.4, 0.4, 0.2)             # above the speeds
    small = (0.02, 0.02, 0.4, 0.4, 0.01)         # R_bar 1 cm: below the sizes
    large = (1.0, 1.0, 0.4, 0.4, 0.01)           # R_bar 50 cm: above the sizes
    light = (0.1, 0.1, 0.02, 0.02, 0.01)         # M_bar 10 g: below the masses
    heavy = (0.1, 0.1, 10.0, 10.0, 0.01)         # M_bar 5 kg: above the masses
    s = impacts(DILLEY, [inside, slow, fast, fast, small, large, large, large, light,
                         heavy, heavy])
    assert (s["speeds_below"], s["speeds_above"]) == (1, 2)
    assert (s["sizes_below"], s["sizes_above"]) == (1, 3)
    assert (s["masses_below"], s["masses_above"]) == (1, 2)
    assert s["outside_speeds"] == 3 and s["outside_sizes"] == 4
    assert s["critically_damped"] == 0
    assert s["inside_all"] == 1


def test_inside_all_needs_every_dimension_inside_at_once():
    inside = (0.1, 0.1, 0.4, 0.4, 0.01)          # R_bar 5 cm, M_bar 200 g, 1 cm/s
    # just inside every lower and every upper edge (0.1 % in, against the round-off of
    # the reduced quantities and of the impact speed the resolver recomputes)
    edges = [(0.05005, 0.05005, 0.1202, 0.1202, 1.001e-4),
             (0.3996, 0.3996, 1.198, 1.198, 0.04995)]
    # slow and light at once: one impact outside two ranges is not inside
    slow_light = (0.1, 0.1, 0.02, 0.02, 1e-5)
    s = impacts(DILLEY, [inside, *edges, slow_light])
    assert s["inside_all"] == 3
    assert s["speeds_below"] == 1 and s["masses_below"] == 1


def test_a_law_without_a_stated_range_counts_nothing_outside():
    s = impacts({"model": "constant", "epsilon": 0.5},
                [(1.0, 1.0, sphere(1.0), sphere(1.0), 10.0), (1e-3, 1e-3, 1e-6, 1e-6, 1e-6)])
    assert all(s[k] == 0 for k in ("speeds_below", "speeds_above", "sizes_below",
                                   "sizes_above", "masses_below", "masses_above",
                                   "critically_damped"))
    # no range stated: every impact lies inside the (0, inf) bounds the resolver is given,
    # and analyze reports the share as NaN (law_range._inside_all)
    assert s["inside_all"] == 2


def test_critically_damped_impacts_are_counted():
    # xi = xi0 (v / 1 cm/s)^p at the reference pair (R_bar 2.5 cm, M_bar 60 g): xi >= 1
    # from v = 0.01 (1/0.16)^(1/0.65) = 0.167 m/s; 1 m/s gives xi = 0.71 x 0.16^-1 > 1
    R, M = 0.05, 0.120
    xi_fast = 0.16 * (1.0 / 0.01) ** 0.65
    assert xi_fast > 1.0 and rs.dilley_epsilon(1.0, R / 2, M / 2) == 0.0
    s = impacts(DILLEY, [(R, R, M, M, 1.0), (R, R, M, M, 0.5), (R, R, M, M, 0.01)])
    assert s["critically_damped"] == 2
    # a tiny eps that is not zero (xi just below 1) is not critically damped
    v_below = 0.01 * (0.999 / 0.16) ** (1 / 0.65)
    assert 0.0 < rs.dilley_epsilon(v_below, R / 2, M / 2)
    assert impacts(DILLEY, [(R, R, M, M, v_below)])["critically_damped"] == 0


def test_an_old_checkpoint_without_the_new_counters_restores_them_as_zero():
    sim = rebound.Simulation()
    sim.add(m=1.0, r=0.1)
    handle = install_resolver(sim, DILLEY)
    state = handle.stats_state()
    for key in ("speeds_below", "masses_above", "critically_damped", "inside_all"):
        del state[key]
    values = checked(handle._open().stats, state)
    assert values["critically_damped"] == 0 and values["masses_above"] == 0
    # the joint count of the open interval is unknown: negative whatever it adds, so its
    # row is left out of the share (analysis.law_range)
    assert values["inside_all"] == UNCOUNTED < -1e18
    handle.set_stats(state)
    assert handle.stats()["speeds_below"] == 0
