"""Conveniences: a run started from a file's particles, and a snapshot exported to CSV and
to a REBOUND simulation that continues in plain REBOUND exactly as ringsim continues it."""

import json
import textwrap
import warnings

import numpy as np
import pytest
import rebound

import ringsim
from ringsim.analysis import tiling
from ringsim.analysis.equilibrium import stationary_window
from ringsim.analysis.tiling import copy_correlation
from ringsim.cli import main
from ringsim.config.scenario import scenario_from_dict, scenario_from_text
from ringsim.config.schema import ScenarioError
from ringsim.engine import box, export, sheet
from ringsim.engine.initial_file import (
    CSV_COLUMNS,
    CSV_SPIN_COLUMNS,
    shear_period,
    tile_sheet,
)
from ringsim.errors import InputError
from ringsim.physics import restitution as rs
from ringsim.physics.constants import SHEAR

BASE = {
    "name": "src", "seed": 3, "planet": {"Omega": 2.0e-4},
    "particles": {"size_distribution": {"kind": "powerlaw", "q": 3.0, "r_min": 0.5,
                                        "r_max": 1.5}},
    "sheet": {"n_particles": 80, "optical_depth": 0.25},
    "restitution": {"model": "dilley", "kappa": 0.1},
    "integration": {"orbits": 0.37, "collision_detection": "line"},
    "output": {"timeseries_every": 0.05, "snapshot_every": 0.1},
}


@pytest.fixture(scope="module")
def source_run(tmp_path_factory):
    out = tmp_path_factory.mktemp("src") / "src.h5"
    return ringsim.open_run(ringsim.run(scenario_from_dict(BASE), output=out,
                                        progress=False))


#: Walton's Coulomb friction (Luding et al. 1998's example): spins of order Omega in 0.3 orbit
#: (measured: rms 2.0 Omega at the last snapshot).
ROUGH = {"model": "coulomb", "mu": 0.5}
OMEGA = BASE["planet"]["Omega"]


@pytest.fixture(scope="module")
def rough_source_run(tmp_path_factory):
    out = tmp_path_factory.mktemp("rough") / "rough.h5"
    return ringsim.open_run(ringsim.run(scenario_from_dict({**BASE, "friction": ROUGH}),
                                        output=out, progress=False))


def _from_file(initial_state: dict, source: str = "<test>", friction=None, **sheet_keys):
    d = {k: v for k, v in BASE.items() if k != "sheet"}
    d["name"] = "cont"
    d["sheet"] = {"initial_state": initial_state, **sheet_keys}
    if friction is not None:
        d["friction"] = friction
    return scenario_from_dict(d, source=source)


def test_run_starts_from_a_snapshot(source_run):
    sc = _from_file({"file": str(source_run.path), "snapshot": 2})
    built = sheet.build_sheet(sc)
    snap = source_run.snapshot(2)
    arrays = sheet.particle_arrays(built.sim)
    for field in ("x", "y", "z", "vx", "vy", "vz", "radius", "mass"):
        np.testing.assert_array_equal(arrays[field], snap[field], err_msg=field)
    g, attrs = built.geometry, source_run.attrs
    assert (g.root_size, g.n_root_x, g.n_root_y) == (attrs["root_size"], 1, 1)
    period = shear_period(g.Lx, g.Ly, 2.0e-4)
    assert 0.0 <= built.sim.t < period
    # the same shear phase: the images across the radial boundary are where they were
    assert (1.5 * 2e-4 * g.Lx * built.sim.t - 1.5 * 2e-4 * g.Lx * snap["t"]) / g.Ly \
        == pytest.approx(round((built.sim.t - snap["t"]) / period), abs=1e-9)


def test_scenario_key_round_trips_and_refuses_replaced_keys():
    sc = _from_file({"file": "other.h5", "snapshot": -1})
    assert scenario_from_text(sc.to_yaml()) == sc
    assert "n_particles" not in sc.to_dict()["sheet"]
    with pytest.raises(ScenarioError) as info:
        _from_file({"file": "other.h5"}, n_particles=10)
    assert info.value.key == "sheet.n_particles" and "initial_state" in str(info.value)
    with pytest.raises(ScenarioError) as info:
        _from_file({"file": "p.csv", "snapshot": 1})
    assert info.value.key == "sheet.initial_state.snapshot"
    with pytest.raises(ScenarioError) as info:
        _from_file({"file": "p.txt"})
    assert info.value.key == "sheet.initial_state.file"


def test_tile_key_round_trips_and_is_checked():
    sc = _from_file({"file": "other.h5", "tile": [2, 3]})
    assert sc.sheet.initial_state.tile == (2, 3)
    assert scenario_from_text(sc.to_yaml()) == sc
    assert "tile" not in _from_file({"file": "other.h5"}).to_dict()["sheet"]["initial_state"]
    for bad in ([2], [0, 2], [2, 2.5], 2, [True, 2], [17, 1]):
        with pytest.raises(ScenarioError) as info:
            _from_file({"file": "other.h5", "tile": bad})
        assert info.value.key == "sheet.initial_state.tile", bad
    with pytest.raises(ScenarioError) as info:
        _from_file({"file": "p.csv", "tile": [2, 2]}, optical_depth=0.25)
    assert info.value.key == "sheet.initial_state.tile"
    d = _from_file({"file": "other.h5", "tile": [2, 2]}).to_dict()
    d["integration"]["until_equilibrium"] = True
    with pytest.raises(ScenarioError) as info:
        scenario_from_dict(d)
    assert info.value.key == "integration.until_equilibrium"


def _hill_sheet(arrays: dict, Lx: float, Ly: float, n_root_x: int, Omega: float,
                t: float) -> rebound.Simulation:
    """Particles without collisions or gravity in a shearing box (plain REBOUND, SEI)."""
    sim = rebound.Simulation()
    box.configure_box(sim, box.SheetGeometry(Lx / n_root_x, n_root_x,
                                             round(n_root_x * Ly / Lx), 4, Omega))
    sim.dt = 1e-3 * 2 * np.pi / Omega
    sim.t = t
    for k in range(arrays["x"].size):
        sim.add(m=0.0, x=arrays["x"][k], y=arrays["y"][k], z=arrays["z"][k],
                vx=arrays["vx"][k], vy=arrays["vy"][k], vz=arrays["vz"][k])
    return sim


def _state(sim) -> dict:
    out = {f: np.empty(sim.N) for f in ("x", "y", "z", "vx", "vy", "vz")}
    for k, p in enumerate(sim.particles):
        for f in out:
            out[f][k] = getattr(p, f)
    return out


@pytest.mark.parametrize("tile", [(2, 2), (3, 1), (1, 2)])
def test_tiled_sheet_moves_as_the_repeated_sheet(tile):
    """The tiled sheet is the small sheet's own images: free (Hill) motion for half an
    orbit in the large box ends where the small sheet's motion, tiled then, puts every
    copy, boundary crossings included.  A wrong image offset or shear-flow shift moves the
    copies by a fraction of Ly or by 1.5 Omega Lx T: metres, not 1e-6 m."""
    Omega, Lx, Ly, t0 = 2e-4, 40.0, 40.0, 7.3e4      # t0: an offset of 21.9 Ly
    rng = np.random.default_rng(12)
    n = 60
    x = rng.uniform(-0.5 * Lx, 0.5 * Lx, n)
    small = {"x": x, "y": rng.uniform(-0.5 * Ly, 0.5 * Ly, n), "z": rng.normal(0, 1, n),
             "vx": rng.normal(0, 0.5 * Omega * Lx, n),
             "vy": -SHEAR * Omega * x + rng.normal(0, 0.5 * Omega * Lx, n),
             "vz": rng.normal(0, Omega, n)}
    T = np.pi / Omega
    a = _hill_sheet(small, Lx, Ly, 1, Omega, t0)
    a.integrate(t0 + T, exact_finish_time=1)
    ends = _state(a)
    # enough radial boundary crossings to test the offsets: a particle that went round
    # the radial boundary ends more than Lx / 2 from where it started
    assert np.count_nonzero(np.abs(ends["x"] - small["x"]) > 0.5 * Lx) > 5
    n_x, n_y = tile
    b = _hill_sheet(tile_sheet(small, Lx, Ly, Omega, t0, n_x, n_y), n_x * Lx, n_y * Ly, n_x,
                    Omega, t0)
    b.integrate(t0 + T, exact_finish_time=1)
    got = _state(b)
    want = tile_sheet(ends, Lx, Ly, Omega, t0 + T, n_x, n_y)
    # a particle's copy may have crossed into a neighbour copy's place: match each of the
    # large sheet's particles with the nearest copy of the same particle
    copies = n_x * n_y
    for name in ("x", "y", "z", "vx", "vy", "vz"):
        got[name] = got[name].reshape(copies, n)
        want[name] = want[name].reshape(copies, n)
    d = np.hypot(got["x"][:, None, :] - want["x"][None, :, :],
                 got["y"][:, None, :] - want["y"][None, :, :])
    nearest = np.argmin(d, axis=1)
    assert np.max(np.min(d, axis=1)) < 1e-6
    for name in ("z", "vx", "vy", "vz"):
        match = np.take_along_axis(want[name], nearest, axis=0)
        np.testing.assert_allclose(got[name], match, rtol=0, atol=1e-9, err_msg=name)
    # every copy of every particle is found once: the tiling is a permutation
    assert all(sorted(nearest[:, k]) == list(range(copies)) for k in range(n))


def test_run_starts_from_a_tiled_snapshot(source_run):
    """The tiled sheet of a run file is ``tile_sheet`` of its snapshot at the snapshot's
    time reduced by the small box's shear period, and the large box starts at that time
    (3 x 1: its own shear period is a third of the small box's, and reducing by it would
    move its copies' frames against each other)."""
    sc = _from_file({"file": str(source_run.path), "snapshot": 2, "tile": [3, 1]})
    built = sheet.build_sheet(sc)
    snap = source_run.snapshot(2)
    attrs = source_run.attrs
    g = built.geometry
    assert (g.root_size, g.n_root_x, g.n_root_y) == (attrs["root_size"], 3, 1)
    Lx = attrs["root_size"]
    t = snap["t"] % shear_period(Lx, Lx, 2e-4)
    assert t > shear_period(3 * Lx, Lx, 2e-4)     # this snapshot tests the point above
    want = tile_sheet({f: snap[f] for f in ("x", "y", "z", "vx", "vy", "vz", "radius",
                                            "mass")}, Lx, Lx, 2e-4, t, 3, 1)
    arrays = sheet.particle_arrays(built.sim)
    for field in want:
        np.testing.assert_array_equal(arrays[field], want[field], err_msg=field)
    assert built.sim.t == t


def test_rough_state_moves_the_same_from_the_reduced_start_time(rough_source_run):
    """Why the spins carry over to the start time: Hill's equations and the spins'
    precession in the frame do not depend on the time itself.  The snapshot's state given
    at the reduced start time (the run from the file) and at the snapshot's own time (one
    shear period and more later: another frame angle) moves the same through 200
    collisional steps: velocities relative to the shear flow and spins to 3e-13 of their
    rms (measured; asserted 1e-9).  The spins written at the start time's frame angle
    but with the clock at the snapshot's time, a wrong frame, miss by order 1 (measured
    2.9 and 6.3)."""
    snap = rough_source_run.snapshot(-1)
    want = np.column_stack([snap["wx"], snap["wy"], snap["wz"]])
    reduced, own, wrong = (_built_from(rough_source_run, (1, 1), ROUGH) for _ in range(3))
    assert (snap["t"] - reduced.sim.t) * OMEGA / (2 * np.pi) > 0.1     # another frame angle
    own.sim.t = snap["t"]
    own.resolver.set_spins(want)
    wrong.sim.t = snap["t"]
    for built in (reduced, own, wrong):
        built.sim.steps(200)
    assert reduced.resolver.stats()["count"] > 10

    def state(built):
        s = sheet.particle_arrays(built.sim)
        return np.stack([s["vx"], s["vy"] + SHEAR * OMEGA * s["x"], s["vz"]]), \
            built.resolver.spins()

    (u0, w0), (u1, w1), (u2, w2) = (state(b) for b in (reduced, own, wrong))
    u_rms, w_rms = np.sqrt(np.mean(u0**2)), np.sqrt(np.mean(w0**2))
    assert np.max(np.abs(u1 - u0)) / u_rms < 1e-9 and np.max(np.abs(w1 - w0)) / w_rms < 1e-9
    assert np.max(np.abs(w2 - w0)) / w_rms > 0.1


def _built_from(source_run, tile, friction=None):
    return sheet.build_sheet(_from_file({"file": str(source_run.path), "tile": list(tile)},
                                        friction=friction))


@pytest.mark.parametrize("tile", [(1, 1), (2, 1), (1, 3)])
def test_run_with_friction_starts_with_the_snapshots_spins(rough_source_run, tile):
    """A rough run's snapshot carries its spins into the new run, every copy of a tiled one
    (to the round-off of turning them from the frame's axes to the stored axes and back:
    the new run starts at the snapshot's time reduced by the shear period, another frame
    angle; measured 1e-16 of the largest, asserted 1e-14); a scenario without friction
    starts without spins."""
    snap = rough_source_run.snapshot(-1)
    want = np.column_stack([snap["wx"], snap["wy"], snap["wz"]])
    assert np.sqrt(np.mean(want**2)) > 0.1 * OMEGA, "the source run's particles spin"
    built = _built_from(rough_source_run, tile, ROUGH)
    got = built.resolver.spins().reshape(tile[0] * tile[1], -1, 3)
    np.testing.assert_allclose(got, np.broadcast_to(want, got.shape), rtol=0,
                               atol=1e-14 * np.max(np.abs(want)))
    smooth = _built_from(rough_source_run, tile)
    assert smooth.resolver.friction is None
    assert not np.any(smooth.resolver.spins())


@pytest.mark.parametrize("tile, rough", [((2, 2), False), ((3, 1), False), ((2, 3), False),
                                         ((1, 2), False), ((2, 2), True)])
def test_tiled_sheet_collides_as_the_small_sheet(source_run, rough_source_run, tile, rough):
    """From the same snapshot, the small sheet and the tiled one run 300 steps (0.3 orbit,
    collisions with ringsim's resolver): every copy of every particle ends where the small
    sheet's particle does, in z and in velocity relative to the shear flow, to round-off
    amplified by chaos (measured 3e-11 to 2e-10 of the rms velocity; a copy shifted by a
    wrong seam, even one the same at every seam, misses by order 1).  With friction, from
    a rough run's snapshot, the spins too (measured 1.8e-10 of their rms)."""
    friction = ROUGH if rough else None
    source = rough_source_run if rough else source_run
    small = _built_from(source, (1, 1), friction)
    large = _built_from(source, tile, friction)
    assert small.sim.dt == large.sim.dt and small.sim.t == large.sim.t
    small.sim.steps(300)
    large.sim.steps(300)
    a, b = sheet.particle_arrays(small.sim), sheet.particle_arrays(large.sim)
    copies = tile[0] * tile[1]

    def peculiar(s):
        return np.stack([s["vx"], s["vy"] + SHEAR * 2e-4 * s["x"], s["vz"]])

    ua, ub = peculiar(a), peculiar(b).reshape(3, copies, -1)
    rms = np.sqrt(np.mean(ua**2, axis=1))[:, None, None]
    assert np.max(np.abs(ub - ua[:, None, :]) / rms) < 1e-6
    np.testing.assert_allclose(b["z"].reshape(copies, -1), np.broadcast_to(a["z"], (copies,
                               a["z"].size)), rtol=0, atol=1e-6 * np.std(a["z"]))
    if rough:
        wa, wb = small.resolver.spins(), large.resolver.spins().reshape(copies, -1, 3)
        assert np.sqrt(np.mean(wa**2)) > 0.1 * OMEGA
        assert np.max(np.abs(wb - wa) / np.sqrt(np.mean(wa**2))) < 1e-6


def _cli_error(tmp_path, capsys, initial_state: dict, **sheet_keys) -> str:
    d = {k: v for k, v in BASE.items() if k != "sheet"}
    d["sheet"] = {"initial_state": initial_state, **sheet_keys}
    path = tmp_path / "cont.yaml"
    path.write_text(scenario_from_dict(d).to_yaml())
    out = tmp_path / "cont.h5"
    assert main(["run", str(path), "-o", str(out), "--no-progress"]) == 2
    assert not out.exists(), "no run file written for bad input"
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and err[0].startswith(f"ringsim: error: {path}: sheet.initial_state")
    return err[0]


def test_bad_initial_state_files_are_one_line_errors(source_run, tmp_path, capsys):
    assert "no such file" in _cli_error(tmp_path, capsys, {"file": "missing.h5"})
    assert "no index 99" in _cli_error(tmp_path, capsys, {"file": str(source_run.path),
                                                          "snapshot": 99})
    bad = tmp_path / "bad.csv"
    bad.write_text("x,y,z,vx,vy,vz,r,m\n0,0,0,0,0,0,1,1\n")
    assert "unknown column 'x'" in _cli_error(tmp_path, capsys, {"file": str(bad)})
    outside = tmp_path / "outside.csv"
    outside.write_text(",".join(CSV_COLUMNS) + "\n0,0,0,0,0,0,1,4000\n1e4,0,0,0,0,0,1,4000\n")
    assert "outside the box" in _cli_error(tmp_path, capsys, {"file": str(outside)})
    overlap = tmp_path / "overlap.csv"
    overlap.write_text(",".join(CSV_COLUMNS) + "\n0,0,0,0,0,0,1,4000\n0.5,0,0,0,0,0,1,4000\n")
    assert "overlap" in _cli_error(tmp_path, capsys, {"file": str(overlap)})
    other = dict(BASE, planet={"Omega": 1.0e-4})
    path = tmp_path / "other.yaml"
    other["sheet"] = {"initial_state": {"file": str(source_run.path)}}
    path.write_text(scenario_from_dict(other).to_yaml())
    assert main(["run", str(path), "-o", str(tmp_path / "o.h5"), "--no-progress"]) == 2
    assert "Omega" in capsys.readouterr().err


def test_csv_export_starts_an_identical_sheet(source_run, tmp_path):
    csv = export.export_csv(source_run, 1, tmp_path / "snap.csv")
    scenario = tmp_path / "from_csv.yaml"
    scenario.write_text("name: from_csv\nseed: 3\nplanet: {Omega: 2e-4}\n"
                        "particles: {size_distribution: {kind: powerlaw, q: 3, r_min: 0.5, "
                        "r_max: 1.5}}\n"
                        "sheet: {optical_depth: 0.25, initial_state: {file: snap.csv, "
                        f"t: {source_run.snapshot(1)['t']!r}}}}}\n"
                        "integration: {orbits: 0.1, collision_detection: line}\n")
    sc = ringsim.load_scenario(scenario)  # the CSV is found beside the scenario
    arrays = sheet.particle_arrays(sheet.build_sheet(sc).sim)
    snap = source_run.snapshot(1)
    for field in ("x", "y", "z", "vx", "vy", "vz", "radius", "mass"):
        np.testing.assert_array_equal(arrays[field], snap[field], err_msg=field)
    assert csv.read_text().splitlines()[2] == ",".join(CSV_COLUMNS)
    # without its time the state's radial images would be shifted: refused, not run
    at_zero = scenario.read_text().replace(f"t: {source_run.snapshot(1)['t']!r}", "t: 0")
    with pytest.raises(ringsim.InputError, match="overlap"):
        sheet.build_sheet(scenario_from_text(at_zero, source=str(scenario)))
    path = ringsim.run(sc, output=tmp_path / "c.h5", progress=False)
    assert ringsim.open_run(path).attrs["status"] == "finished"


def test_csv_of_a_rough_run_carries_its_spins(rough_source_run, tmp_path):
    """A rough run's CSV has the spin columns, and a run with friction started from it has
    the snapshot's spins (to the round-off of the frame's turn, as from the run file); the
    spin columns are all three or none."""
    csv = export.export_csv(rough_source_run, -1, tmp_path / "rough.csv")
    assert csv.read_text().splitlines()[2] == ",".join(CSV_COLUMNS + CSV_SPIN_COLUMNS)
    snap = rough_source_run.snapshot(-1)
    built = sheet.build_sheet(_from_file({"file": str(csv), "t": snap["t"]}, friction=ROUGH,
                                         optical_depth=0.25))
    want = np.column_stack([snap["wx"], snap["wy"], snap["wz"]])
    assert np.sqrt(np.mean(want**2)) > 0.1 * OMEGA
    np.testing.assert_allclose(built.resolver.spins(), want, rtol=0,     # as from the run
                               atol=1e-14 * np.max(np.abs(want)))      # file (test above)
    np.testing.assert_array_equal(sheet.particle_arrays(built.sim)["vx"], snap["vx"])
    lines = csv.read_text().splitlines()
    partial = tmp_path / "partial.csv"
    partial.write_text("\n".join([lines[2].rsplit(",", 1)[0]]
                                 + [row.rsplit(",", 1)[0] for row in lines[3:]]) + "\n")
    with pytest.raises(InputError, match="missing column 'wz_rad_s'"):
        sheet.build_sheet(_from_file({"file": str(partial), "t": snap["t"]}, friction=ROUGH,
                                     optical_depth=0.25))


def _printed_continuation(capsys, run_path, out) -> str:
    """The Python `ringsim export --rebound` prints for continuing ``out``."""
    assert main(["export", str(run_path), "--snapshot", "-1", "--rebound", str(out)]) == 0
    printed = capsys.readouterr().out
    return textwrap.dedent(printed.split("continue it with\n", 1)[1])


def _assert_continues_bit_for_bit(code: str, run, steps: int = 10):
    """``steps`` steps of the printed continuation in plain REBOUND equal as many steps of
    ringsim's own continuation of the same snapshot (sheet.initial_state), positions,
    velocities and spins (==), with collisions among them."""
    namespace: dict = {}
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")  # REBOUND's reminder about function pointers
        exec(code, namespace)  # noqa: S102 (the code the command prints, run as a user would)
    sim, handle = namespace["sim"], namespace["handle"]
    sim.steps(steps)
    own = sheet.build_sheet(export.continuation_scenario(run, -1))
    own.sim.steps(steps)
    a, b = sheet.particle_arrays(sim), sheet.particle_arrays(own.sim)
    assert sim.t == own.sim.t
    for field in a:
        assert np.array_equal(a[field], b[field]), field
    assert np.array_equal(handle.spins(), own.resolver.spins()), "spins"
    assert own.resolver.stats()["count"] > 0, "collisions were resolved in those steps"
    return sim, own


def test_rebound_export_continues_bit_for_bit(source_run, rough_source_run, tmp_path,
                                              capsys):
    code = _printed_continuation(capsys, source_run.path, tmp_path / "snap.bin")
    assert "ringsim.install_resolver(sim" in code and "set_spins" not in code
    _assert_continues_bit_for_bit(code, source_run)
    # a rough run: the friction law and the spins, which REBOUND's file does not keep
    code = _printed_continuation(capsys, rough_source_run.path, tmp_path / "rough.bin")
    assert "coulomb" in code and "set_spins" in code
    _, own = _assert_continues_bit_for_bit(code, rough_source_run, steps=100)
    assert np.any(own.resolver.spins() != 0.0)


@pytest.mark.parametrize("solver", ["tree", "p3m", "slab"])
def test_rebound_export_of_a_gravitating_run_continues_bit_for_bit(solver, tmp_path, capsys,
                                                                   gravitating_scenario):
    """Self-gravity is a function pointer REBOUND does not save (the tree's ghost field,
    P3M, the slab): the printed code installs the run's solver again.  Without it the
    continuation departs in the first step (checked: the same code without its
    install_gravity line does not match)."""
    sc = gravitating_scenario(name="g", **{"sheet.gravity_solver": solver,
                                           "integration.orbits": 0.11,
                                           "integration.collision_detection": "line"})
    run = ringsim.open_run(ringsim.run(sc, output=tmp_path / "g.h5", progress=False))
    code = _printed_continuation(capsys, run.path, tmp_path / "g.bin")
    assert f"install_gravity(sim, {solver!r}" in code
    _assert_continues_bit_for_bit(code, run)
    without = "\n".join(line for line in code.splitlines() if "install_gravity(" not in line)
    with pytest.raises(AssertionError):
        _assert_continues_bit_for_bit(without, run)


def test_export_needs_an_output_and_a_valid_snapshot(source_run, tmp_path, capsys):
    assert main(["export", str(source_run.path)]) == 2
    assert main(["export", str(source_run.path), "--snapshot", "50", "--csv",
                 str(tmp_path / "a.csv")]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 2 and "--snapshot" in err[1]
    assert not (tmp_path / "a.csv").exists()


def test_epsilon_of_the_users_law(tmp_path, capsys):
    png, out = tmp_path / "eps.png", tmp_path / "eps.json"
    assert main(["epsilon", "--restitution", "model=dilley,kappa=0.1", "--radius", "0.5",
                 "2", "--density", "500", "--plot", str(png), "--json", str(out)]) == 0
    assert png.read_bytes()[:4] == b"\x89PNG"
    payload = json.loads(out.read_text())
    assert payload["restitution"] == {"model": "dilley", "xi0": 0.16, "p": 0.65, "kappa": 0.1}
    curve = payload["curves"][1]
    v = np.array(curve["v"])
    mass = 500.0 * 4.0 / 3.0 * np.pi * 2.0**3
    np.testing.assert_allclose(curve["epsilon"], rs.dilley_epsilon(v, 1.0, mass / 2.0,
                                                                   kappa=0.1), rtol=1e-14)
    assert "R = 0.5 m" in capsys.readouterr().out


def test_epsilon_law_from_a_scenario_uses_its_sizes(tmp_path, capsys):
    path = tmp_path / "s.yaml"
    path.write_text("name: s\nseed: 1\nplanet: {Omega: 2e-4}\nparticles: {density: 400, "
                    "size_distribution: {kind: powerlaw, q: 3, r_min: 1, r_max: 4}}\n"
                    "restitution: {model: bridges, v_c: 7.7e-5}\n")
    out = tmp_path / "e.json"
    assert main(["epsilon", "--restitution", str(path), "--json", str(out)]) == 0
    payload = json.loads(out.read_text())
    assert payload["density"] == 400.0 and payload["curves"][0]["radius"] == 1.0
    assert payload["curves"][-1]["radius"] == 4.0


@pytest.mark.parametrize("argv, key", [
    (["--restitution", "model=dilley,kapa=0.1", "--radius", "1"], "restitution.kapa"),
    (["--restitution", "model=constant", "--radius", "1"], "restitution.epsilon"),
    (["--restitution", "model=dilley", "--radius", "-1"], "--radius"),
    (["--restitution", "model=dilley"], "--radius"),
    (["--radius", "1"], "--radius"),
    (["--restitution", "kappa"], "--restitution"),
])
def test_epsilon_bad_law_is_one_line_naming_the_key(argv, key, tmp_path, capsys):
    assert main(["epsilon", *argv, "--plot", str(tmp_path / "x.png")]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and f": {key}:" in err[0], err
    assert not (tmp_path / "x.png").exists()


def test_tiled_run_has_no_window_while_its_copies_are_alike(source_run, tmp_path,
                                                           monkeypatch):
    """A collisional run from a 2 x 2 tiled snapshot keeps its copies alike (round-off,
    amplified by chaos about a hundredfold per 0.2 orbit, parts them only after an orbit or
    more: measured 1e-11 to 2e-10 of the rms velocity after 0.3 orbit, and 0.15 after 1.3
    in a tiling of 200 particles):
    `copy_correlation` reads 1 at the start and still above 1 - 1e-6 after 0.3 orbit, so
    the equilibrium finder gives no window: copies alike are not a larger box."""
    d = {k: v for k, v in BASE.items() if k != "sheet"}
    d.update(name="tiled", sheet={"initial_state": {"file": str(source_run.path),
                                                    "tile": [2, 2]}},
             integration={"orbits": 0.4, "collision_detection": "line"},
             output={"timeseries_every": 0.05, "snapshot_every": 0.1})
    run = ringsim.open_run(ringsim.run(scenario_from_dict(d), output=tmp_path / "t.h5",
                                       progress=False))
    assert np.sum(run.timeseries["collisions"]) > 100     # 216: a collisional test
    first, later = run.snapshot(0), run.snapshot(-1)
    assert (later["t"] - first["t"]) * 2e-4 / (2 * np.pi) > 0.3
    box = (float(run.attrs["Lx"]), float(run.attrs["Ly"]))
    start = copy_correlation(first, 2e-4, *box, 2, 2)
    assert start["velocity"] + start["surface_density"] == pytest.approx([1.0] * 6, abs=1e-12)
    after = copy_correlation(later, 2e-4, *box, 2, 2)
    assert min(after["velocity"] + after["surface_density"]) > 1 - 1e-6
    eq = ringsim.equilibrium(run)
    assert eq["tiled_copies_independent_from_orbit"]["mean"] == np.inf
    assert not eq["in_equilibrium"] and "tiled" in eq["reason"]
    # a start from its snapshots, tiled again or not, would hide the copies alike
    for tile in ([1, 1], [2, 1]):
        again = _from_file({"file": str(run.path), "snapshot": -1, "tile": tile})
        with pytest.raises(InputError, match="copies are not independent yet there"):
            sheet.build_sheet(again)
    # the guard asks whether the copies are independent by the chosen snapshot (index
    # resolved from the end): with a verdict of independence from snapshot 2 on
    assert run.n_snapshots > 3
    monkeypatch.setattr(tiling, "independent_from_orbit",
                        lambda r, last=None: 0.2 if last >= 2 else np.inf)
    with pytest.raises(InputError, match="snapshot 1 of"):
        sheet.build_sheet(_from_file({"file": str(run.path), "snapshot": 1}))
    for index in (2, -1):
        sheet.build_sheet(_from_file({"file": str(run.path), "snapshot": index}))
    monkeypatch.undo()
    # an export is the snapshot itself, not a new run: not refused
    assert export.export_rebound(run, -1, tmp_path / "t.bin")[0].stat().st_size > 0
    assert export.export_csv(run, -1, tmp_path / "t.csv").stat().st_size > 0


@pytest.mark.parametrize("tile", [(2, 2), (2, 1), (3, 1)])
def test_copy_correlation_of_independent_copies_and_of_reordered_particles(tile):
    """Copies drawn independently correlate near 0 (below both thresholds); the tiling of
    one sheet gives 1 for every copy, and the radially shifted copies' surface density no
    longer matches if they are mapped at a wrong time (3000 s: 90 m of shear shift; the
    measured correlation falls to about 0.1); particles not in the tiling's order are
    refused, not misread."""
    rng = np.random.default_rng(9)
    n_x, n_y = tile
    copies, n, Omega, L = n_x * n_y, 4000, 2e-4, 100.0
    big = (n_x * L, n_y * L)
    snap = {"x": rng.uniform(-0.5, 0.5, copies * n) * big[0],
            "y": rng.uniform(-0.5, 0.5, copies * n) * big[1],
            "vx": rng.normal(0, 1e-3, copies * n), "vz": rng.normal(0, 1e-3, copies * n),
            "radius": np.tile(rng.uniform(0.5, 2, n), copies), "t": 1.0e5}
    snap["vy"] = -SHEAR * Omega * snap["x"] + rng.normal(0, 1e-3, copies * n)
    snap["mass"] = 900 * 4 / 3 * np.pi * snap["radius"] ** 3
    corr = copy_correlation(snap, Omega, *big, n_x, n_y)
    assert max(corr["velocity"]) < tiling.VELOCITY_INDEPENDENT
    assert max(corr["surface_density"]) < tiling.FIELD_INDEPENDENT
    small = {"x": rng.uniform(-0.5 * L, 0.5 * L, n), "y": rng.uniform(-0.5 * L, 0.5 * L, n),
             **{k: snap[k][:n] for k in ("vx", "vy", "vz", "radius", "mass")}}
    same = {**tile_sheet(small, L, L, Omega, snap["t"], n_x, n_y), "t": snap["t"]}
    corr = copy_correlation(same, Omega, *big, n_x, n_y)
    assert corr["velocity"] == pytest.approx([1.0] * (copies - 1), abs=1e-12)
    assert corr["surface_density"] == pytest.approx([1.0] * (copies - 1), abs=1e-12)
    late = copy_correlation({**same, "t": snap["t"] + 3000.0}, Omega, *big, n_x, n_y)
    radial = [c - 1 for c in range(1, copies) if c // n_y != 0]     # copies with i != 0
    assert max(late["surface_density"][k] for k in radial) < 0.5
    shuffled = {k: (v[rng.permutation(copies * n)] if k != "t" else v)
                for k, v in snap.items()}
    with pytest.raises(ValueError, match="not the tiling's copies"):
        copy_correlation(shuffled, Omega, *big, n_x, n_y)


def test_window_starts_where_the_tiled_copies_are_independent():
    """``stationary_window``'s ``first_orbit``: a stationary series whose first rows are
    left out starts its window no earlier than that orbit."""
    rng = np.random.default_rng(5)
    orbits = np.arange(0, 80.05, 0.1)
    c = 1e-3 * (1 + 0.01 * rng.standard_normal(orbits.size))
    h = 5.0 * (1 + 0.01 * rng.standard_normal(orbits.size))
    free = stationary_window(orbits, c, h)
    assert free["in_equilibrium"] and orbits[free["start"]] < 10.0
    cut = stationary_window(orbits, c, h, first_orbit=10.0)
    assert cut["in_equilibrium"] and orbits[cut["start"]] >= 10.0
    none = stationary_window(orbits, c, h, first_orbit=np.inf)
    assert not none["in_equilibrium"] and "tiled" in none["reason"]
