"""Top view of a self-gravitating sheet to scale, showing its wakes.

The surface density of one snapshot is binned on cells of about one mean particle diameter,
smoothed by a Gaussian of one cell (``scipy.ndimage``), and shown as Sigma / <Sigma> over the
box drawn to scale (x radial, outward to the right; y azimuthal, the orbital motion up).
A bar of length lambda_cr and the crest direction of the dominant wave
(``analysis.wakes.wake_statistics``: trailing crests lean with the shear) are drawn on it.
"""

from __future__ import annotations

import math

import numpy as np

from ringsim.plots.common import pyplot, set_readable_axis


def surface_density_map(x, y, mass, Lx: float, Ly: float, cell: float,
                        smooth_cells: float = 1.0) -> np.ndarray:
    """Sigma / <Sigma> on a grid of cells about ``cell`` [m] wide, (ny, nx), periodically
    smoothed by a Gaussian of ``smooth_cells`` cells.

    Parameters
    ----------
    x, y : array [m]
    mass : array [kg]
    Lx, Ly, cell : float [m]
    """
    from scipy.ndimage import gaussian_filter

    nx, ny = max(8, round(Lx / cell)), max(8, round(Ly / cell))
    hist, _, _ = np.histogram2d(y, x, bins=(ny, nx), range=[[-Ly / 2, Ly / 2],
                                                            [-Lx / 2, Lx / 2]],
                                weights=mass)
    sigma = gaussian_filter(hist, smooth_cells, mode="wrap")
    return sigma / sigma.mean()


def wake_figure(snap: dict, Lx: float, Ly: float, title: str, lambda_cr: float,
                stats: dict | None = None):
    """Top view of one snapshot's surface density, to scale, with lambda_cr and the wakes.

    Parameters
    ----------
    snap : dict with x, y [m], radius [m], mass [kg]
    Lx, Ly : float [m]
    title : str
    lambda_cr : float [m]
        Toomre's critical wavelength, drawn as a bar.
    stats : dict, optional
        ``wake_statistics`` of the snapshot (wavelength [m], pitch_angle_deg [deg], mode_m,
        mode_n; None without a significant wake): the crest direction is drawn and the
        title gives them, or says that there is no significant wake.
    """
    plt = pyplot()
    cell = 2.0 * float(np.mean(snap["radius"]))
    density = surface_density_map(snap["x"], snap["y"], snap["mass"], Lx, Ly, cell)
    aspect = Ly / Lx
    fig, ax = plt.subplots(figsize=(7.0, 7.0 * min(max(aspect, 0.4), 2.0) + 0.8))
    vmax = max(2.0, float(np.quantile(density, 0.995)))
    image = ax.imshow(density, origin="lower", extent=(-Lx / 2, Lx / 2, -Ly / 2, Ly / 2),
                      cmap="magma", vmin=0.0, vmax=vmax, interpolation="nearest")
    ax.set_aspect("equal")
    colorbar = fig.colorbar(image, ax=ax, shrink=0.85)
    colorbar.set_label(f"surface density Σ / ⟨Σ⟩ (cells of {cell:.2g} m, smoothed)")
    set_readable_axis(ax, "x", [-Lx / 2, Lx / 2], log=False, pad=0.0)
    set_readable_axis(ax, "y", [-Ly / 2, Ly / 2], log=False, pad=0.0)
    ax.set_xlabel("x (radial, outward) [m]")
    ax.set_ylabel("y (azimuthal, orbital motion) [m]")
    # lambda_cr bar in the lower left corner
    x0, y0 = -0.45 * Lx, -0.44 * Ly
    bar = min(lambda_cr, 0.9 * Lx)
    ax.plot([x0, x0 + bar], [y0, y0], color="cyan", lw=3, solid_capstyle="butt")
    ax.text(x0, y0 + 0.015 * Ly, f"λ_cr = {lambda_cr:.3g} m", color="cyan", fontsize=9,
            va="bottom")
    subtitle = "top view drawn to scale"
    if stats is not None and stats.get("wavelength") is None:
        subtitle = "no significant wake against a random sheet; top view drawn to scale"
    if stats is not None and stats.get("wavelength") is not None:
        pitch = math.radians(stats["pitch_angle_deg"])
        # crest direction: pitch from the azimuthal axis, trailing (pitch > 0) leaning to -y
        # at larger x
        dx, dy = math.sin(pitch), -math.cos(pitch)
        half = 0.2 * min(Lx, Ly)
        ax.plot([-half * dx, half * dx], [-half * dy, half * dy], color="cyan", lw=1.5,
                ls="--")
        subtitle = (f"dominant wave: λ = {stats['wavelength']:.3g} m "
                    f"({stats['wavelength'] / lambda_cr:.2g} λ_cr), pitch "
                    f"{stats['pitch_angle_deg']:.3g}°, mode (m, n) = "
                    f"({stats['mode_m']}, {stats['mode_n']}), significant\n"
                    f"dashed: crest direction; top view drawn to scale")
    ax.set_title(f"{title}\n{subtitle}", fontsize=9)
    return fig
