"""The spin figure of a run with friction (``ringsim analyze --plots``: ``spins.png``).

Left: E_rot/E_tr against time, with the equilibrium window shaded, its mean, and the
collisional-balance closed form for constant beta (``physics.friction.
collisional_spin_ratio``; identical spheres only, where it applies).  Right: the
distribution of the spins in units of Omega over the snapshots of the window, |ω| per size
bin (log axis), and the mean ω_z per size bin with the kinematic marks (synchronous
rotation 0; turning with the mean shear flow -3/4; not rotating in inertial space -1).
Spins are relative to the rotating frame of the sheet.  Spins are ω, peculiar velocities w
(``structure``): the symbols never share a letter.
"""

from __future__ import annotations

import numpy as np

from ringsim.plots.common import equilibrium_start, pyplot, set_readable_axis


def _window_spins(run, t_start: float):
    """(|w|, w_z, radius) [rad/s, rad/s, m] of every particle in the snapshots at or
    after t_start [s] (the last snapshot if none)."""
    snaps = [run.snapshot(i) for i in range(run.n_snapshots)]
    chosen = [s for s in snaps if s["t"] >= t_start and "wx" in s] or snaps[-1:]
    w = np.concatenate([np.sqrt(s["wx"] ** 2 + s["wy"] ** 2 + s["wz"] ** 2) for s in chosen])
    wz = np.concatenate([s["wz"] for s in chosen])
    radius = np.concatenate([s["radius"] for s in chosen])
    return w, wz, radius, len(chosen)


def spin_figure(run, eq: dict):
    """The figure (matplotlib Figure) of a run with friction; see the module docstring."""
    plt = pyplot()
    ts = run.timeseries
    Omega = run.scenario.orbital_frequency
    period = run.scenario.orbital_period
    spin = eq["spin"]
    start = equilibrium_start(eq)
    fig, (ax_t, ax_w, ax_z) = plt.subplots(1, 3, figsize=(15, 5.6))
    ax_t.plot(ts["orbits"][1:], ts["rotational_energy_ratio"][1:], color="C0", lw=1.0,
              label="E_rot / E_tr")
    frac = spin["rotational_energy_fraction"]
    if start is not None:
        ax_t.axvspan(start, float(ts["orbits"][-1]), color="C0", alpha=0.08,
                     label="equilibrium window")
        ax_t.axhline(frac["mean"], color="C0", ls="--", lw=1.0,
                     label=f"window mean {frac['mean']:.3f} ± {frac['stderr']:.2g}")
    if spin["collisional_spin_ratio"] is not None and spin.get("closed_form_applies", True):
        ax_t.axhline(spin["collisional_spin_ratio"], color="k", ls=":", lw=1.2,
                     label=f"collisional balance (closed form) "
                           f"{spin['collisional_spin_ratio']:.3f}")
    ax_t.set_xlabel("time [orbits]")
    ax_t.set_ylabel("E_rot / E_tr (E_tr relative to the shear flow)\n[dimensionless]")
    ax_t.set_title(f"{eq['name']}: rotational / translational energy", fontsize=10)
    ax_t.legend(fontsize=8, loc="lower right")
    w, wz, radius, n_snaps = _window_spins(run, (start or 0.0) * period)
    edges = np.asarray(ts.get("size_bin_edges", [radius.min(), radius.max() * (1 + 1e-12)]))
    positive = w[w > 0] / Omega
    if positive.size:
        bins = np.logspace(np.log10(positive.min()), np.log10(positive.max()), 40)
        index = np.clip(np.searchsorted(edges, radius, side="right") - 1, 0, edges.size - 2)
        for b in range(edges.size - 1):
            members = (index == b) & (w > 0)
            if members.any():
                ax_w.hist(w[members] / Omega, bins=bins, histtype="step", lw=1.2,
                          label=f"r = {edges[b]:.3g}-{edges[b + 1]:.3g} m")
        set_readable_axis(ax_w, "x", bins, log=True, pad=0.0)
    ax_w.set_xlabel("spin rate |ω| / Ω (rotating frame) [dimensionless]")
    ax_w.set_ylabel(f"particles (summed over {n_snaps} snapshots)")
    ax_w.set_title(f"spin rates per size bin; rms {spin['rms_spin']['mean']:.3g} Ω",
                   fontsize=10)
    below = {"loc": "upper center", "bbox_to_anchor": (0.5, -0.16), "frameon": False}
    ax_w.legend(fontsize=7, ncols=2, **below)   # below the panels: their data fill them

    index = np.clip(np.searchsorted(edges, radius, side="right") - 1, 0, edges.size - 2)
    centres, means, errors = [], [], []
    for b in range(edges.size - 1):
        members = index == b
        if members.sum() > 1:
            centres.append(float(np.sqrt(edges[b] * edges[b + 1])))
            means.append(float(np.mean(wz[members])) / Omega)
            # particles of one snapshot only are independent: n per snapshot
            errors.append(float(np.std(wz[members])) / Omega
                          / np.sqrt(members.sum() / n_snaps))
    ax_z.errorbar(centres, means, yerr=errors, fmt="o", color="C3",
                  label="mean ω_z per size bin (± std / sqrt(n per snapshot))")
    for value, text, style in ((0.0, "synchronous (0)", "-"),
                               (-0.75, "turning with the mean shear flow (-3/4)", "--"),
                               (-1.0, "not rotating in inertial space (-1)", ":")):
        ax_z.axhline(value, color="k", ls=style, lw=1.0, label=text)
    ax_z.axhline(spin["mean_spin_z"]["mean"], color="C3", lw=1.0, alpha=0.6,
                 label=f"all particles {spin['mean_spin_z']['mean']:.3f} ± "
                       f"{spin['mean_spin_z']['stderr']:.2g}")
    if len(centres) > 1:
        set_readable_axis(ax_z, "x", edges, log=True, pad=0.0)
    ax_z.set_xlabel("particle radius [m]")
    ax_z.set_ylabel("mean spin ω_z / Ω (rotating frame, > 0 prograde)\n[dimensionless]")
    ax_z.set_title("mean z-spin per size bin", fontsize=10)
    ax_z.legend(fontsize=7, **below)
    fig.tight_layout()
    return fig
