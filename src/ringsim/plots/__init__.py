"""Figures of ringsim, all written as PNG with the non-interactive Agg backend.

Speeds are in mm/s in every figure (velocity dispersions, the restitution laws' impact
speeds, fit data), lengths in m, time in orbits; axes carry labels with units, and tick
labels are chosen from the data so that they stay readable for any range.

* ``laws``: epsilon(v) curves of the restitution laws (``ringsim epsilon --plot``);
* ``timeseries``: c, H, collision rate, filling factor, velocity ellipsoid and per-size
  c(t), H(t) against time;
* ``structure``: per-size equilibria, epsilon distribution, velocity distributions,
  vertical profile, particle picture;
* ``run``: ``plot_run`` (``analyze --plots``) and ``plot_comparison`` (``compare --plots``);
* ``sweep``: ``plot_sweep`` (``sweep --plots``);
* ``fits``: ``plot_fits``, the data and fitted laws of ``ringsim fit --plot``;
* ``spins``, ``wakes``: the spins of a run with friction and the top view of a
  self-gravitating sheet (``analyze --plots``);
* ``observe``: ``plot_observation``, the synthetic occultations (``observe --plots``);
* ``common``: units, readable axes, run styles, equilibrium window, ``save_figure``.
"""

from ringsim.plots.common import SPEED_SCALE, SPEED_UNIT, save_figure
from ringsim.plots.laws import (
    PANEL_TITLES,
    Curve,
    epsilon_figure,
    paper_curves,
    plot_epsilon_curves,
)
from ringsim.plots.observe import plot_observation
from ringsim.plots.run import comparison_figures, plot_comparison, plot_run, run_figures
from ringsim.plots.sweep import plot_sweep, sweep_figure

__all__ = [
    "PANEL_TITLES",
    "SPEED_SCALE",
    "SPEED_UNIT",
    "Curve",
    "comparison_figures",
    "epsilon_figure",
    "paper_curves",
    "plot_comparison",
    "plot_epsilon_curves",
    "plot_observation",
    "plot_run",
    "plot_sweep",
    "run_figures",
    "save_figure",
    "sweep_figure",
]
