"""Sweep summaries: one row per grid point, ``summary.csv`` and ``summary.h5``."""

from __future__ import annotations

import csv
import datetime as _dt
import math
import os
import re
from collections.abc import Iterable, Sequence
from pathlib import Path
from typing import Any

import numpy as np

from ringsim import quantities
from ringsim.physics.restitution import RESTITUTION
from ringsim.store import guarded

#: Equilibrium quantities of the summary: (key of ``compare.equilibrium``, column stem with
#: the unit in its name, unit: the declared one of ``ringsim.quantities`` with a note where
#: given).  Each gives the columns ``<stem>_mean`` and ``<stem>_stderr``.
EQUILIBRIUM_COLUMNS: tuple[tuple[str, str, str], ...] = tuple(
    (key, stem, quantities.unit(key) + note) for key, stem, note in (
        ("velocity_dispersion", "velocity_dispersion_m_s", ""),
        ("velocity_dispersion_rOmega", "velocity_dispersion_rOmega", ""),
        ("thickness", "thickness_m", ""),
        ("thickness_r", "thickness_r", ""),
        ("filling_factor", "filling_factor", ""),
        ("collision_frequency", "collision_frequency_per_orbit", " (per particle)"),
        ("mean_epsilon", "mean_epsilon", ""),
        ("translational_viscosity", "translational_viscosity_m2_s", ""),
        ("collisional_viscosity", "collisional_viscosity_m2_s", ""),
        ("equilibrium_from_orbit", "equilibrium_from_orbit", "")))

#: Further numbers of each point's equilibrium: (key, column, unit).
_RUN_COLUMNS: tuple[tuple[str, str, str], ...] = tuple(
    (key, column, quantities.unit(key)) for key, column in (
        ("orbits", "orbits"), ("n_particles", "n_particles"), ("mean_radius", "mean_radius_m"),
        ("optical_depth", "optical_depth")))

#: Units of the scenario keys a grid may vary (list indices written as N), for summary.h5.
_PARAMETER_UNITS: dict[str, str] = {
    "name": "text", "seed": "integer", "description": "text",
    "planet.Omega": "1/s", "planet.GM": "m^3/s^2", "planet.a": "m",
    "particles.density": "kg/m^3",
    "particles.size_distribution.kind": "text",
    "particles.size_distribution.radius": "m",
    "particles.size_distribution.q": "dimensionless",
    "particles.size_distribution.r_min": "m",
    "particles.size_distribution.r_max": "m",
    "particles.size_distribution.r_cut": "m",
    "particles.size_distribution.cutoff_exponent": "dimensionless",
    "particles.size_distribution.components.N.radius": "m",
    "particles.size_distribution.components.N.number_fraction": "dimensionless",
    "sheet.optical_depth": "dimensionless", "sheet.n_particles": "count",
    "sheet.aspect": "dimensionless", "sheet.gravity": "boolean", "sheet.gravity_solver": "text",
    "sheet.softening": "m",
    "sheet.opening_angle": "rad", "sheet.initial_dispersion": "mean radius x Omega",
    "sheet.initial_toomre_q": "dimensionless",
    "sheet.z_box": "mean radii",
    "restitution.model": "text",
    # every restitution parameter, with the unit of its declaration
    **{f"restitution.{name}": unit for name, unit in RESTITUTION.units().items()},
    "integration.orbits": "orbits", "integration.dt": "orbits",
    "integration.dt_safety": "dimensionless", "integration.collision_detection": "text",
    "output.path": "text", "output.timeseries_every": "orbits",
    "output.snapshot_every": "orbits", "output.checkpoint_every": "orbits",
    "output.log_collisions": "count",
}


def _parameter_units(key: str) -> str:
    return _PARAMETER_UNITS.get(re.sub(r"\.\d+\.", ".N.", key),
                                "as in the scenario file (docs/scenario.md)")


# --- summary ----------------------------------------------------------------------------------

def _number(value: Any) -> float:
    try:
        return float(value)
    except (TypeError, ValueError):
        return math.nan


def summary_rows(keys: Sequence[str], results: Iterable[Any]
                 ) -> tuple[list[str], dict[str, str], list[dict[str, Any]]]:
    """The summary table: (columns, unit of each non-parameter column, rows).

    Rows hold the grid parameters (columns named by their dotted keys), ``run_file``,
    ``status``, ``action``, ``in_equilibrium``, ``reason``, ``<stem>_mean`` and
    ``<stem>_stderr`` of every `EQUILIBRIUM_COLUMNS` quantity, the run's length and size,
    ``wall_time_s`` and ``error``.  Numbers of points that did not finish are NaN.
    """
    units: dict[str, str] = {"run_file": "text", "status": "text", "action": "text",
                             "in_equilibrium": "boolean", "reason": "text"}
    for _key, stem, unit in EQUILIBRIUM_COLUMNS:
        units[f"{stem}_mean"] = unit
        units[f"{stem}_stderr"] = unit
    for _key, column, unit in _RUN_COLUMNS:
        units[column] = unit
    units["wall_time_s"] = "s"
    units["error"] = "text"
    columns = list(keys) + list(units)
    rows = []
    for result in results:
        eq = result.equilibrium or {}
        row: dict[str, Any] = dict(result.params)
        row.update(run_file=result.file, status=result.status, action=result.action,
                   in_equilibrium=bool(eq.get("in_equilibrium", False)),
                   reason=str(eq.get("reason", "")))
        for key, stem, _unit in EQUILIBRIUM_COLUMNS:
            value = eq.get(key, {})
            row[f"{stem}_mean"] = _number(value.get("mean"))
            row[f"{stem}_stderr"] = _number(value.get("stderr"))
        for key, column, _unit in _RUN_COLUMNS:
            value = eq.get(key)
            row[column] = value if isinstance(value, int) else _number(value)
        row["wall_time_s"] = float(result.wall_time)
        row["error"] = result.error
        rows.append(row)
    return columns, units, rows


def _csv_cell(value: Any) -> str:
    if isinstance(value, bool):
        return "true" if value else "false"
    if isinstance(value, float):
        return repr(value)
    return str(value)


def _column_array(values: list[Any]):
    """A numpy array for an HDF5 dataset: bool, int64, float64 or variable-length text."""
    import h5py

    if all(isinstance(v, (bool, np.bool_)) for v in values):
        return np.array(values, dtype=bool)
    if all(isinstance(v, int) and not isinstance(v, bool) for v in values):
        return np.array(values, dtype=np.int64)
    if all(isinstance(v, (int, float)) and not isinstance(v, bool) for v in values):
        return np.array(values, dtype=np.float64)
    return np.array([v if isinstance(v, str) else repr(v) for v in values],
                    dtype=h5py.string_dtype())


def write_summary(out_dir: str | os.PathLike, sweep, results: Sequence[Any]
                  ) -> tuple[Path, Path]:
    """Write ``summary.csv`` and ``summary.h5`` into ``out_dir``; returns their paths.

    ``summary.h5``: root attributes ``sweep_yaml`` (the sweep file's text), ``sweep_file``,
    ``base_scenario_yaml``, ``grid_keys``, ``ringsim_version``, ``units`` = "SI",
    ``created_utc``; datasets ``/parameters/<dotted key>`` and one dataset per other column
    of `summary_rows`, each with a ``units`` attribute.  Both files are written under a
    temporary name and renamed.
    """
    import h5py

    from ringsim import __version__

    out_dir = Path(out_dir)
    columns, units, rows = summary_rows(sweep.keys, results)
    csv_path, h5_path = out_dir / "summary.csv", out_dir / "summary.h5"

    tmp_csv = csv_path.with_name(".summary.csv.tmp")
    tmp_h5 = h5_path.with_name(".summary.h5.tmp")
    try:
        with open(tmp_csv, "w", newline="", encoding="utf-8") as f:
            writer = csv.writer(f)
            writer.writerow(columns)
            for row in rows:
                writer.writerow([_csv_cell(row[c]) for c in columns])
        os.replace(tmp_csv, csv_path)

        with guarded.h5_file(tmp_h5, "w") as f:   # a full disk: an OSError, not a crash
            f.attrs["sweep_yaml"] = sweep.source_text or ""
            f.attrs["sweep_file"] = str(sweep.source)
            f.attrs["base_scenario_yaml"] = sweep.base.yaml_text
            f.attrs["grid_keys"] = np.array(list(sweep.keys), dtype=h5py.string_dtype())
            f.attrs["ringsim_version"] = __version__
            f.attrs["units"] = "SI"
            f.attrs["created_utc"] = _dt.datetime.now(_dt.timezone.utc).isoformat(
                timespec="seconds")
            f.attrs["n_points"] = len(rows)
            f.attrs["n_failed"] = sum(row["status"] != "finished" for row in rows)
            params = f.create_group("parameters")
            for key in sweep.keys:
                ds = params.create_dataset(key, data=_column_array([row[key] for row in rows]))
                ds.attrs["units"] = _parameter_units(key)
            for column, unit in units.items():
                ds = f.create_dataset(column, data=_column_array([row[column] for row in rows]))
                ds.attrs["units"] = unit
        os.replace(tmp_h5, h5_path)
    except OSError:   # a full disk: no partial temporary file is left behind
        tmp_csv.unlink(missing_ok=True)
        tmp_h5.unlink(missing_ok=True)
        raise
    return csv_path, h5_path
