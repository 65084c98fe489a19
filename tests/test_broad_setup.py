"""Set-up of broad rings: centimetre-to-metre particles placed without overlaps.

Of two particles drawn overlapping, one more than 10 times smaller than the other is drawn
again (``engine.placement``), so the few metre-sized particles of a q = 3 distribution from
2.5 cm to 5 m find room first and the many small ones fill the space around them. A sheet
that truly cannot be placed is bad input (exit status 2, one line), not a failure.
"""

import numpy as np
import pytest

from ringsim import cli
from ringsim.engine import box, sheet

#: To 5 m, q = 3 (Brilliantov et al. 2015); r_min: 2.5 cm, Dilley's smallest measured sphere.
BROAD_RING = {"particles.size_distribution.r_min": 0.025,
              "particles.size_distribution.r_max": 5.0,
              "particles.size_distribution.q": 3.0}


@pytest.mark.parametrize("tau, n, r_min", [(0.3, 3000, 0.025), (0.5, 3000, 0.025),
                                           (0.5, 40000, 0.025), (0.3, 20000, 0.01),
                                           (0.3, 20000, 0.1)])
def test_centimetre_to_metre_ring_places_without_overlaps(broad_scenario, tau, n, r_min):
    sc = broad_scenario(BROAD_RING | {"sheet.optical_depth": tau, "sheet.n_particles": n,
                                      "particles.size_distribution.r_min": r_min})
    sim, geometry, radii, masses, _ = sheet.new_simulation(sc)
    arrays = sheet.particle_arrays(sim)
    assert sim.N == n
    # every pair apart: not even a touching overlap (fraction 0 of the smaller radius)
    assert box.count_overlaps(arrays, geometry, fraction=0.0) == 0
    # the sheet holds the broad distribution it was asked for (the smallest near r_min, the
    # largest of n >= 3000 draws of q = 3 above 40 cm: P(R > 0.4 m) >= 6e-4 per particle)
    assert radii.min() < 1.2 * r_min and radii.max() > 0.4
    optical_depth = np.sum(np.pi * radii**2) / (geometry.Lx * geometry.Ly)
    assert optical_depth == pytest.approx(tau, rel=0.2)


def test_a_sheet_that_cannot_be_placed_is_bad_input(tmp_path, capsys):
    # tau = 3 squeezed into a layer one particle thick: no room for a monolayer (the
    # densest disc packing covers pi / sqrt(12) = 0.91 of the plane)
    path = tmp_path / "crowded.yaml"
    path.write_text("name: crowded\nseed: 1\nplanet: {Omega: 2.0e-4}\n"
                    "particles: {size_distribution: {kind: monodisperse, radius: 1.0}}\n"
                    "sheet: {optical_depth: 3.0, n_particles: 200, z_box: 2.1}\n"
                    "integration: {orbits: 0.1}\n")
    out = tmp_path / "crowded.h5"
    status = cli.main(["run", str(path), "-o", str(out), "--no-progress"])
    err = capsys.readouterr().err
    assert status == 2
    assert err.count("\n") == 1 and "sheet.optical_depth" in err and "Traceback" not in err
    assert "could not be placed without overlaps" in err
    assert not out.exists()
