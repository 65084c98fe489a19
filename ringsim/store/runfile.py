"""The run file (HDF5): time series, snapshots, checkpoint and the scenario that made it.

Layout (docs/interface.md "Run file"; every dataset in docs/run_file.md):

* ``/`` attributes ``ringsim_version``, ``rebound_version``, ``scenario_yaml``, ``units`` =
  "SI", ``seed``, ``created_utc``, plus ``status`` ("running", "finished", "stopped"),
  ``wall_time_s`` (wall-clock time of the run up to its last checkpoint, all sessions) and
  the box geometry of the sheet (``Lx``, ``Ly``, ``Omega``, ...).
* ``/timeseries/NAME`` resizable 1-D datasets (2-D ``(n, n_bins)`` for per-size-bin
  arrays), each with a ``units`` attribute.
* ``/snapshots/NNNNNN/`` groups (attribute ``t``) with ``x y z vx vy vz radius mass``.
* ``/checkpoint``: the REBOUND binary of the last checkpoint as bytes; its attributes hold
  what the run loop needs to resume (the time-series row count, the snapshot count, the
  next output times, ``rand_seed``).
* ``/guards``: what the run's guards did (time-step changes, box enlargements, overlap
  counts) as a resizable event table.

Like emcee's HDF5 backend, every write opens the file with ``with h5py.File(...)`` and
closes it again, so a run killed at any moment leaves a readable file whose last
checkpoint is complete.
"""

from __future__ import annotations

import datetime as _dt
from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from pathlib import Path

import h5py
import numpy as np

SNAPSHOT_FIELDS = ("x", "y", "z", "vx", "vy", "vz", "radius", "mass")
SNAPSHOT_UNITS = {"x": "m", "y": "m", "z": "m", "vx": "m/s", "vy": "m/s", "vz": "m/s",
                  "radius": "m", "mass": "kg"}

#: Units of the time-series quantities (per-bin arrays share the units of their scalar).
TIMESERIES_UNITS = {
    "t": "s",
    "orbits": "orbits",
    "dt": "s",
    "velocity_dispersion": "m/s",
    "velocity_dispersion_mass_weighted": "m/s",
    "sigma_xx": "m^2/s^2",
    "sigma_yy": "m^2/s^2",
    "sigma_zz": "m^2/s^2",
    "sigma_xy": "m^2/s^2",
    "thickness": "m",
    "thickness_mass_weighted": "m",
    "filling_factor": "dimensionless",
    "optical_depth": "dimensionless",
    "collisions": "count",
    "collisions_log_n": "count",
    "collisions_plog": "kg m^2/s",
    "mean_epsilon": "dimensionless",
    "mean_impact_speed": "m/s",
    "translational_viscosity": "m^2/s",
    "max_vertical_amplitude": "m",
    "z_half_period": "m",
    "overlapping_pairs": "count",
    "multi_encounters": "count",
    "size_bin_velocity_dispersion": "m/s",
    "size_bin_thickness": "m",
    "size_bin_n": "count",
    "one_minus_epsilon_histogram": "count",
    "impact_speed_histogram": "count",
}

#: Bin edges stored beside the histogram time series: name -> (edges dataset, units).
HISTOGRAM_EDGES = {
    "one_minus_epsilon_histogram": ("one_minus_epsilon_bin_edges", "dimensionless"),
    "impact_speed_histogram": ("impact_speed_bin_edges", "m/s"),
}


def units_of(name: str) -> str:
    """The unit string of a time-series quantity; KeyError for an undeclared one."""
    return TIMESERIES_UNITS[name]


def _utc_now() -> str:
    return _dt.datetime.now(_dt.timezone.utc).isoformat(timespec="seconds")


def create_run_file(path: str | Path, *, scenario_yaml: str, seed: int,
                    attributes: Mapping[str, object], size_bin_edges: np.ndarray | None,
                    histogram_edges: Mapping[str, np.ndarray]) -> Path:
    """Create a new, empty run file (overwriting ``path``).

    Parameters
    ----------
    path : output file
    scenario_yaml : str
        The full scenario text, embedded so the file documents what made it.
    seed : int
    attributes : mapping
        Further root attributes (the sheet geometry: ``Lx`` [m], ``Ly`` [m], ``Omega`` [1/s],
        ...).  Numbers only or strings.
    size_bin_edges : array [m] or None
        Edges of the radius bins of the per-size-bin time series.
    histogram_edges : mapping
        Bin edges of each histogram time series (keys of :data:`HISTOGRAM_EDGES`).
    """
    import rebound

    from ringsim import __version__

    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    with h5py.File(path, "w") as f:
        f.attrs["ringsim_version"] = __version__
        f.attrs["rebound_version"] = rebound.__version__
        f.attrs["scenario_yaml"] = scenario_yaml
        f.attrs["units"] = "SI"
        f.attrs["seed"] = int(seed)
        f.attrs["created_utc"] = _utc_now()
        f.attrs["status"] = "running"
        for key, value in attributes.items():
            f.attrs[key] = value
        ts = f.create_group("timeseries")
        if size_bin_edges is not None:
            edges = ts.create_dataset("size_bin_edges", data=np.asarray(size_bin_edges, float))
            edges.attrs["units"] = "m"
        for name, edges in histogram_edges.items():
            dataset, units = HISTOGRAM_EDGES[name]
            ts.create_dataset(dataset, data=np.asarray(edges, float)).attrs["units"] = units
        f.create_group("snapshots")
        guards = f.create_group("guards")
        for name, dtype in (("t", "f8"), ("orbits", "f8")):
            ds = guards.create_dataset(name, shape=(0,), maxshape=(None,), dtype=dtype,
                                       chunks=(256,))
            ds.attrs["units"] = "s" if name == "t" else "orbits"
        msg = guards.create_dataset("message", shape=(0,), maxshape=(None,),
                                    dtype=h5py.string_dtype(), chunks=(256,))
        msg.attrs["units"] = "text"
    return path


def _append_rows(group: h5py.Group, name: str, values: np.ndarray, units: str) -> None:
    """Append rows (first axis) to a resizable dataset, creating it on first use."""
    values = np.asarray(values)
    row_shape = values.shape[1:]
    if name not in group:
        size = int(np.prod(row_shape)) if row_shape else 1
        ds = group.create_dataset(name, shape=(0,) + row_shape, maxshape=(None,) + row_shape,
                                  dtype=values.dtype if values.dtype.kind in "iu" else "f8",
                                  chunks=(max(1, 4096 // max(1, size)),) + row_shape)
        ds.attrs["units"] = units
    ds = group[name]
    n = ds.shape[0]
    ds.resize(n + values.shape[0], axis=0)
    ds[n:] = values


def append_timeseries(path: str | Path, rows: Sequence[Mapping[str, object]]) -> int:
    """Append time-series rows (all with the same keys); returns the new number of rows.

    Every key must have a unit in :data:`TIMESERIES_UNITS`.  The file is flushed and
    closed before returning.
    """
    with h5py.File(path, "a") as f:
        ts = f["timeseries"]
        if rows:
            for name in rows[0]:
                _append_rows(ts, name, np.array([row[name] for row in rows]), units_of(name))
        n = ts["t"].shape[0] if "t" in ts else 0
        f.flush()
    return n


def append_guard_event(path: str | Path, t: float, orbits: float, message: str) -> None:
    """Record what a guard did (e.g. "dt 1.2e1 s -> 6.0 s: ring heated").

    Parameters
    ----------
    t : float [s]
    orbits : float [orbits]
    message : str
    """
    with h5py.File(path, "a") as f:
        g = f["guards"]
        for name, value in (("t", t), ("orbits", orbits), ("message", message)):
            ds = g[name]
            n = ds.shape[0]
            ds.resize(n + 1, axis=0)
            ds[n] = value


def write_snapshot(path: str | Path, index: int, t: float,
                   arrays: Mapping[str, np.ndarray]) -> None:
    """Write snapshot number ``index`` (group ``/snapshots/NNNNNN``).

    Parameters
    ----------
    index : int
    t : float [s]
    arrays : mapping of SNAPSHOT_FIELDS to 1-D arrays (SI)
    """
    with h5py.File(path, "a") as f:
        snaps = f["snapshots"]
        name = f"{index:06d}"
        if name in snaps:
            del snaps[name]
        g = snaps.create_group(name)
        g.attrs["t"] = float(t)
        g.attrs["units_t"] = "s"
        for field in SNAPSHOT_FIELDS:
            ds = g.create_dataset(field, data=np.asarray(arrays[field], dtype=float))
            ds.attrs["units"] = SNAPSHOT_UNITS[field]
        f.flush()


def write_checkpoint(path: str | Path, binary: bytes, state: Mapping[str, object]) -> None:
    """Replace ``/checkpoint`` with a REBOUND binary and the run-loop state to resume.

    The new checkpoint is written under a temporary name and renamed, so an interrupted
    write leaves the previous checkpoint intact.
    """
    with h5py.File(path, "a") as f:
        if "checkpoint_new" in f:
            del f["checkpoint_new"]
        ds = f.create_dataset("checkpoint_new", data=np.frombuffer(binary, dtype=np.uint8))
        ds.attrs["units"] = "bytes (REBOUND simulation binary)"
        for key, value in state.items():
            ds.attrs[key] = value
        f.flush()
        if "checkpoint" in f:
            del f["checkpoint"]
        f.move("checkpoint_new", "checkpoint")
        f.flush()


@dataclass(frozen=True)
class Checkpoint:
    """The last checkpoint of a run file: REBOUND binary and run-loop state."""

    binary: bytes
    state: dict


def read_checkpoint(path: str | Path) -> Checkpoint | None:
    """The last complete checkpoint, or None if the file has none."""
    with h5py.File(path, "r") as f:
        if "checkpoint" not in f:
            return None
        ds = f["checkpoint"]
        state = {k: (v.item() if isinstance(v, np.generic) else v) for k, v in ds.attrs.items()}
        return Checkpoint(binary=ds[...].tobytes(), state=state)


def truncate_to_checkpoint(path: str | Path, timeseries_rows: int, n_snapshots: int,
                           n_guard_events: int) -> None:
    """Drop time-series rows, snapshots and guard events written after the checkpoint."""
    with h5py.File(path, "a") as f:
        ts = f["timeseries"]
        for ds in ts.values():
            if ds.maxshape[0] is None and ds.shape[0] > timeseries_rows:
                ds.resize(timeseries_rows, axis=0)
        for name in list(f["snapshots"].keys()):
            if int(name) >= n_snapshots:
                del f["snapshots"][name]
        for ds in f["guards"].values():
            if ds.shape[0] > n_guard_events:
                ds.resize(n_guard_events, axis=0)
        f.flush()


def set_attributes(path: str | Path, **attributes: object) -> None:
    """Set root attributes (e.g. ``status``)."""
    with h5py.File(path, "a") as f:
        for key, value in attributes.items():
            f.attrs[key] = value


class Run:
    """Read access to a run file (``ringsim.open_run``).

    Attributes
    ----------
    path : Path
    attrs : dict
        Root attributes.
    scenario : Scenario
        The scenario embedded in the file.
    timeseries : dict of numpy arrays (SI; see ``units``)
    units : dict
        Unit of each time series.
    n_snapshots : int
    """

    def __init__(self, path: str | Path):
        from ringsim.config.scenario import scenario_from_text

        self.path = Path(path)
        with h5py.File(self.path, "r") as f:
            self.attrs = {k: (v.item() if isinstance(v, np.generic) else v)
                          for k, v in f.attrs.items()}
            self.timeseries = {name: ds[...] for name, ds in f["timeseries"].items()}
            self.units = {name: ds.attrs.get("units", "") for name, ds in f["timeseries"].items()}
            self._snapshot_names = sorted(f["snapshots"].keys())
            self.guard_events = [
                (float(t), str(m.decode() if isinstance(m, bytes) else m))
                for t, m in zip(f["guards"]["orbits"][...], f["guards"]["message"][...],
                                strict=True)
            ]
        self.scenario = scenario_from_text(self.attrs["scenario_yaml"], source=str(self.path))

    @property
    def n_snapshots(self) -> int:
        return len(self._snapshot_names)

    def snapshot(self, i: int) -> dict:
        """Snapshot ``i`` (negative counts from the end) as a dict of arrays plus ``t`` [s]."""
        name = self._snapshot_names[i]
        with h5py.File(self.path, "r") as f:
            g = f["snapshots"][name]
            out = {field: g[field][...] for field in SNAPSHOT_FIELDS}
            out["t"] = float(g.attrs["t"])
        return out

    def __repr__(self) -> str:
        n = len(self.timeseries.get("t", ()))
        return f"<ringsim Run {self.path} rows={n} snapshots={self.n_snapshots}>"


def open_run(path: str | Path) -> Run:
    """Open a run file written by ``ringsim run``."""
    return Run(path)
