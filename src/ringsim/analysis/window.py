"""The snapshots of an equilibrium window.

Diagnostics that need particles, not the time series (the local velocity dispersion, the
cross-section-weighted thickness, the by-size layers, the synthetic occultations), average
over the snapshots taken at or after the window's first row.  When no snapshot lies there
(a window shorter than the snapshot interval), they use the last snapshot, which lies
before the window; `window_snapshot_indices` says which, so that every caller reports it.
"""

from __future__ import annotations


def window_snapshot_indices(run, start: int) -> tuple[list[int], bool]:
    """The indices of the snapshots at or after row ``start`` of the run's time series, and
    whether any is; without one, the last snapshot's index and False.

    Parameters
    ----------
    run : ringsim Run
    start : int
        First row of the equilibrium window (a row past the end: the last row).
    """
    t = run.timeseries["t"]
    return snapshots_from(run, float(t[min(start, t.size - 1)]))


def snapshots_from(run, t_start: float) -> tuple[list[int], bool]:
    """The indices of the snapshots taken at or after ``t_start`` [s], and whether any is;
    without one, the last snapshot's index and False."""
    chosen = [i for i in range(run.n_snapshots) if run.snapshot_times[i] >= t_start]
    return (chosen, True) if chosen else ([run.n_snapshots - 1], False)


def count_in_window(run, start: int) -> int:
    """The number of snapshots at or after row ``start`` (0 when none is)."""
    indices, in_window = window_snapshot_indices(run, start)
    return len(indices) if in_window else 0
