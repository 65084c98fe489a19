"""``integration.resolver: rebound_hardsphere``: REBOUND's built-in hard-sphere resolver in a
ringsim run (``engine.hardsphere``), the reference of studies/validation-rebound-example."""

import numpy as np
import pytest
import yaml

import ringsim
from ringsim.cli import main
from ringsim.engine import sheet
from ringsim.engine.hardsphere import ABSENT_TIMESERIES, HardsphereHandle

#: The tiny ring with a law of the impact speed alone and REBOUND's resolver.
HARDSPHERE = {"restitution": {"model": "constant", "epsilon": 0.5},
              "integration.resolver": "rebound_hardsphere"}


def test_first_steps_follow_ringsims_resolver(ring_scenario):
    """From the same seed the two resolvers start from the same sheet and apply the same
    impulses: after 60 steps with collisions the positions differ by round-off only (the
    two compute the normal impulse in different orders: REBOUND rotates into the
    collision frame, ringsim projects; 1e-13 m after 100 steps in REBOUND's example,
    docs/validation.md), far below the 1 m radii that a different impulse would move a
    particle by within a few steps."""
    theirs = sheet.build_sheet(ring_scenario(HARDSPHERE))
    ours = sheet.build_sheet(ring_scenario(HARDSPHERE, {"integration.resolver": "ringsim"}))
    assert isinstance(theirs.resolver, HardsphereHandle)
    for built in (theirs, ours):
        built.sim.steps(60)
    assert theirs.resolver.stats()["count"] > 0
    assert theirs.resolver.stats()["count"] == ours.resolver.stats()["count"]
    a, b = sheet.particle_arrays(theirs.sim), sheet.particle_arrays(ours.sim)
    assert max(float(np.max(np.abs(a[k] - b[k]))) for k in "xyz") < 1e-9


def test_run_file_counts_what_rebound_resolves_and_names_the_rest(tmp_path, ring_scenario):
    """The tallies made in REBOUND's ``coefficient_of_restitution`` are its collisions
    (REBOUND's own ``collisions_log_n`` counts each once) and the constant law's eps; what
    only ringsim's C resolver tallies is absent from the file, and the file says so."""
    run = ringsim.open_run(ringsim.run(ring_scenario(HARDSPHERE), output=tmp_path / "r.h5",
                                       progress=False))
    ts = run.timeseries
    assert np.array_equal(np.diff(ts["collisions_log_n"]), ts["collisions"][1:])
    assert int(ts["collisions"].sum()) > 100
    hit = ts["collisions"] > 0
    assert np.array_equal(ts["mean_epsilon"][hit], np.full(int(hit.sum()), 0.5))
    assert np.all(ts["mean_impact_speed"][hit] > 0)
    for name in ABSENT_TIMESERIES:
        assert name not in ts, name
    assert run.attrs["absent_statistics"] == ", ".join(ABSENT_TIMESERIES)
    assert "multi_encounters" in ringsim.open_run(ringsim.run(
        ring_scenario({"integration.orbits": 0.06}), output=tmp_path / "own.h5",
        progress=False)).timeseries


def test_extending_a_run_equals_a_longer_run(tmp_path, ring_scenario):
    """The tallies are checkpointed and the resolver put back on resuming: a run extended
    from 0.12 to 0.24 orbit is bit-identical to one made 0.24 orbit long."""
    short = ring_scenario(HARDSPHERE, {"integration.orbits": 0.12})
    long = ring_scenario(HARDSPHERE, {"integration.orbits": 0.24})
    direct = ringsim.open_run(ringsim.run(long, output=tmp_path / "d.h5", progress=False))
    path = ringsim.run(short, output=tmp_path / "e.h5", progress=False)
    extended = ringsim.open_run(ringsim.run(long, output=path, resume=True, progress=False))
    for name, series in direct.timeseries.items():
        assert np.array_equal(series, extended.timeseries[name], equal_nan=True), name


def test_exported_snapshot_continues_with_rebounds_resolver(tmp_path, capsys,
                                                             ring_scenario):
    """`ringsim export --rebound` of such a run prints a continuation that puts REBOUND's
    resolver back with the law: ten steps of it in plain REBOUND equal (==) ten steps of
    ringsim's own continuation of the snapshot, collisions among them."""
    import textwrap
    import warnings

    from ringsim.engine import export

    path = ringsim.run(ring_scenario(HARDSPHERE, {"integration.orbits": 0.1,
                                                  "output.snapshot_every": 0.1}),
                       output=tmp_path / "r.h5", progress=False)
    out = tmp_path / "r.bin"
    assert main(["export", str(path), "--snapshot", "-1", "--rebound", str(out)]) == 0
    code = textwrap.dedent(capsys.readouterr().out.split("continue it with\n", 1)[1])
    assert "HardsphereHandle" in code and "install_resolver" not in code
    namespace: dict = {}
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")  # REBOUND's reminder about function pointers
        exec(code, namespace)  # noqa: S102 (the printed code, run as a user would)
    own = sheet.build_sheet(export.continuation_scenario(ringsim.open_run(path), -1))
    for sim in (namespace["sim"], own.sim):
        sim.steps(10)
    a, b = sheet.particle_arrays(namespace["sim"]), sheet.particle_arrays(own.sim)
    for field in a:
        assert np.array_equal(a[field], b[field]), field
    assert own.resolver.stats()["count"] > 0
    assert namespace["handle"].stats()["count"] == own.resolver.stats()["count"]


@pytest.mark.parametrize("overrides, problem", [
    ({"integration.collision_detection": "line"}, "collision_detection: line"),
    ({"restitution": {"model": "dilley", "kappa": 0.0}}, "dilley law"),
    ({"friction": {"model": "constant", "beta": 0.0}}, "friction"),
], ids=["line", "dilley", "friction"])
def test_what_rebound_cannot_resolve_is_bad_input(tmp_path, capsys, scenario_dict,
                                                  overrides, problem):
    """Exit status 2 with one line naming the key and the reason, no file written."""
    bad = tmp_path / "bad.yaml"
    bad.write_text(yaml.safe_dump(scenario_dict("ring", HARDSPHERE, overrides)))
    out = tmp_path / "never.h5"
    assert main(["run", str(bad), "-o", str(out), "--no-progress"]) == 2
    lines = capsys.readouterr().err.strip().splitlines()
    assert len(lines) == 1 and "integration.resolver" in lines[0] and problem in lines[0]
    assert not out.exists()
