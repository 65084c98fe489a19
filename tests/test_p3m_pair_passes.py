"""P3M's pair sum in one loop or in two passes (``rs_p3m_pairs``): the same bits either
way, and the choice between them follows the fraction of scanned sources within r_c."""

import numpy as np

from ringsim import testing
from ringsim.gravity import p3m

T_REF = 2345.6    # s: a non-trivial shear offset


def _sheet(sigma):
    """300 random 1 m particles at tau = 0.5 whose heights are rescaled to rms ``sigma`` [m]."""
    s = testing.random_sheet(300, dispersion=sigma * 2.0e-4, seed=6)
    z = s["pos"][:, 2]
    s["pos"][:, 2] = (z - z.mean()) / z.std() * sigma
    return s


def test_one_loop_and_two_passes_give_the_same_bits():
    """The same state summed both ways: the accelerations are identical (==), in a thin
    sheet and in one many cutoffs thick (the two regimes the choice separates)."""
    for sigma in (1.0, 60.0):
        sim = testing.p3m_simulation(_sheet(sigma), t=T_REF)
        params = p3m.installed_solver(sim).params
        results = []
        for two_pass in (0, 1):
            params.two_pass = two_pass
            results.append(testing.accelerations(sim))
        assert np.array_equal(results[0], results[1])
        assert np.all(np.isfinite(results[0])) and np.abs(results[0]).max() > 0.0


def test_the_way_follows_the_fraction_within_the_cutoff():
    """After a force evaluation the next one takes two passes where more than
    RS_P3M_TWO_PASS_FRACTION (0.08) of the scanned sources lay within r_c: a thin sheet
    (rms height 1 m against r_c = 15 m: nearly all of the column within r_c) takes them,
    a ring 60 m rms thick (a few per cent) does not."""
    for sigma, expected in ((1.0, 1), (60.0, 0)):
        sim = testing.p3m_simulation(_sheet(sigma), t=T_REF)
        testing.accelerations(sim)
        assert p3m.installed_solver(sim).params.two_pass == expected, sigma
