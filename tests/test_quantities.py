"""The one table of quantities (``ringsim.quantities``) against what ringsim writes.

Checked: every time series a run writes (with friction, self-gravity and a size
distribution, so that every optional row is there) is declared, with the unit its
``units`` attribute carries, and every declared time series is written; every number of
the equilibrium JSON (``analyze --json``) and of a comparison (``compare --json``) carries
the unit of its declaration; the table of time series in docs/run_file.md is the generated
one; the sweep summary's units agree with the declarations.
"""

from __future__ import annotations

from pathlib import Path

import h5py
import pytest

import ringsim
from ringsim import quantities
from ringsim.analysis.compare import comparison
from ringsim.config.scenario import scenario_from_dict
from ringsim.quantities import QUANTITY, Quantity, markdown_table, unit
from ringsim.store import summary

DOCS = Path(__file__).resolve().parent.parent / "docs" / "run_file.md"
BEGIN = "<!-- generated from ringsim.quantities by timeseries_markdown()"
END = "<!-- end of generated table -->"
#: Keys of a JSON number.
NUMBER = {"mean", "stderr", "units"}


@pytest.fixture(scope="module")
def full_run(tmp_path_factory):
    """A run that writes every optional row: a size distribution, friction, self-gravity,
    a collision log (120 particles, 0.3 orbit, a few seconds)."""
    sc = scenario_from_dict({
        "name": "every-row", "seed": 5,
        "planet": {"GM": 3.7931e16, "a": 1.0e8},
        "particles": {"density": 900.0, "size_distribution": {
            "kind": "powerlaw", "q": 3.0, "r_min": 0.5, "r_max": 1.5}},
        "sheet": {"optical_depth": 0.3, "n_particles": 120, "gravity": True},
        "restitution": {"model": "dilley"},
        "friction": {"model": "coulomb", "mu": 0.5},
        "integration": {"orbits": 0.3},
        "output": {"path": "runs/every-row.h5", "timeseries_every": 0.02,
                   "snapshot_every": 0.1, "log_collisions": 100},
    }, source="<test>")
    return ringsim.run(sc, output=tmp_path_factory.mktemp("q") / "every-row.h5",
                       progress=False)


def declared_name(parent: str, key: str) -> str:
    """The declaration of an entry ``key`` of the JSON object ``parent``: ``parent.key``
    where that is declared, else ``key`` (module docstring of ``ringsim.quantities``)."""
    return f"{parent}.{key}" if f"{parent}.{key}" in QUANTITY else key


def json_units(obj, parent: str = ""):
    """(object, key, unit) of every JSON number and every entry of a ``units`` mapping."""
    if isinstance(obj, list):
        for item in obj:
            yield from json_units(item, parent)
    elif isinstance(obj, dict):
        for key, value in obj.items():
            if key == "units" and isinstance(value, dict):
                yield from ((parent, k, u) for k, u in value.items())
            elif isinstance(value, dict) and NUMBER <= value.keys():
                yield parent, key, value["units"]
            else:
                yield from json_units(value, key)


def test_every_time_series_of_a_run_is_declared_with_its_unit(full_run):
    with h5py.File(full_run, "r") as f:
        written = {name: str(ds.attrs["units"]) for name, ds in f["timeseries"].items()}
        guards = {name: str(f["guards"][name].attrs["units"]) for name in ("t", "orbits")}
    assert set(written) == set(quantities.TIMESERIES + quantities.TIMESERIES_EDGES), (
        "the datasets a run writes and the declared time series differ")
    wrong = {name: (u, unit(name)) for name, u in written.items() if u != unit(name)}
    assert not wrong, f"units attribute != declaration: {wrong}"
    assert guards == {"t": unit("t"), "orbits": unit("orbits")}


def test_every_number_of_the_equilibrium_carries_its_declared_unit(full_run):
    eq = ringsim.equilibrium(ringsim.open_run(full_run))
    found = list(json_units(eq))
    undeclared = {(p, k) for p, k, _ in found if declared_name(p, k) not in QUANTITY}
    assert not undeclared, f"numbers without a declaration: {sorted(undeclared)}"
    wrong = {(p, k, u) for p, k, u in found if u != unit(declared_name(p, k))}
    assert not wrong, f"units differ from the declaration: {sorted(wrong)}"
    top = {k for p, k, _ in found if p == ""}
    expected = set(quantities.EQUILIBRIUM + quantities.GRAVITY + quantities.PLAIN)
    assert expected - {"r_low", "r_high", "n"} <= top | set(eq), "every table quantity"
    assert {"energy_budget", "spin", "law_range", "size_ratio", "kinetic_estimate",
            "per_size_bin"} <= {p for p, _, _ in found}, "the nested objects were walked"


def test_every_ratio_of_a_comparison_carries_the_ratio_unit(full_run):
    eq = ringsim.equilibrium(ringsim.open_run(full_run))
    comp = comparison([eq, {**eq, "name": "copy"}])
    assert all(u == unit(declared_name(p, k)) for p, k, u in json_units(comp["runs"]))
    ratios = comp["ratios"][0]
    assert {key: ratios[key]["units"] for key in quantities.EQUILIBRIUM} == {
        key: unit("ratio") for key in quantities.EQUILIBRIUM}


def test_the_docs_table_of_time_series_is_generated_from_the_declarations():
    text = DOCS.read_text()
    start = text.index(BEGIN)
    table = text[text.index("\n", start) + 1:text.index(END)]
    assert table == quantities.timeseries_markdown(), (
        "docs/run_file.md's table of time series differs from ringsim.quantities; paste "
        "ringsim.quantities.timeseries_markdown() between the markers")


def test_every_grouped_name_is_declared_once():
    groups = (quantities.TIMESERIES, quantities.TIMESERIES_EDGES, quantities.SPIN_ROW,
              quantities.EQUILIBRIUM, quantities.PLAIN, quantities.GRAVITY)
    for group in groups:
        assert len(set(group)) == len(group)
        assert not set(group) - set(QUANTITY), set(group) - set(QUANTITY)
    assert set(quantities.SPIN_ROW) <= set(quantities.TIMESERIES)


def test_the_sweep_summary_states_the_declared_units():
    for key, _column, stated in summary.EQUILIBRIUM_COLUMNS + summary._RUN_COLUMNS:
        # the summary may add a note in parentheses ("1/orbit (per particle)")
        assert stated == unit(key) or stated.startswith(unit(key) + " ("), key


def test_a_quantity_shows_its_unit_scaled():
    c = QUANTITY["velocity_dispersion"]
    assert (c.unit, c.shown, c.scale) == ("m/s", "mm/s", 1e3)
    assert c.table_label == "velocity dispersion c [mm/s]"
    assert c.axis_label() == "velocity dispersion c [mm/s]"
    ff = QUANTITY["filling_factor"]
    assert ff.table_label == "midplane filling factor"
    assert ff.axis_label("\n") == "midplane filling factor\n[dimensionless]"
    assert Quantity("a.b_c", "m", "x").label == "b c"
    with pytest.raises(ValueError, match="weighting"):
        Quantity("x", "m", "x", weighting="volume")


def test_the_markdown_table_joins_rows_of_one_meaning_and_escapes_bars():
    table = markdown_table(("sigma_xx", "sigma_yy", "thickness", "filling_factor", "mean_spin_z"))
    lines = table.splitlines()
    assert lines[2].startswith("| `sigma_xx`, `sigma_yy` | m²/s² | ")
    assert lines[3].startswith("| `thickness` | m | rms z about the mean, number-weighted")
    assert "\\|z - <z>\\|" in lines[4] and "| 1 |" in lines[4]
    assert "| Ω |" in lines[5]
