"""A run made in one go against the same run stopped and resumed: the check of bit-exact
restarts that the tests of every solver and integrator repeat."""

from __future__ import annotations

from pathlib import Path

import numpy as np

#: The particle arrays a restart must reproduce bit for bit.
STATE_KEYS = ("x", "y", "z", "vx", "vy", "vz")


def assert_same_datasets(reference, path) -> None:
    """The run file ``path`` holds every dataset of the run file ``reference`` and no other,
    each equal (==, ``twins.run_file_datasets``)."""
    from ringsim.testing.twins import run_file_datasets

    ref, res = run_file_datasets(reference), run_file_datasets(path)
    assert ref.keys() == res.keys()
    for name in ref:
        assert ref[name] == res[name], f"{name} differs from the uninterrupted run"


def assert_resumes_bit_for_bit(scenario, folder: str | Path, stop_orbits: float = 0.1,
                               snapshot: int = -1) -> tuple:
    """Run ``scenario`` in one go, and again stopped after ``stop_orbits`` [orbits] and
    resumed to its end, in ``folder``; assert that snapshot ``snapshot`` of both holds the
    same particle state (==).  Returns the two opened runs (uninterrupted, resumed)."""
    import ringsim
    from ringsim.config.scenario import with_overrides

    folder = Path(folder)
    long = ringsim.run(scenario, output=folder / "long.h5", progress=False)
    short = folder / "short.h5"
    ringsim.run(with_overrides(scenario, {"integration.orbits": stop_orbits}), output=short,
                progress=False)
    ringsim.run(scenario, output=short, resume=True, progress=False)
    a, b = ringsim.open_run(long), ringsim.open_run(short)
    assert a.n_snapshots == b.n_snapshots, (a.n_snapshots, b.n_snapshots)
    for key in STATE_KEYS:
        assert np.array_equal(a.snapshot(snapshot)[key], b.snapshot(snapshot)[key]), key
    return a, b
