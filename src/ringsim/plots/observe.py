"""Figures of ``ringsim observe --plots``: what a ring observer reads from an occultation.

* ``observe_tau_azimuth.png``: tau_n against the azimuth phi at every opening angle B, with
  the fitted bar model and the geometric optical depth (the wake asymmetry);
* ``observe_tau_elevation.png``: tau_n against B, its range over phi, and the bar model
  along the wakes and across them;
* ``observe_scan.png``: a synthetic radial occultation scan at the lowest B along the
  azimuth of peak transmission, at the instrument's radial resolution;
* ``observe_sightline.png``: the sheet seen along two lines of sight (along the wakes and
  90 deg from them): rays that pass are white.

The arrays come from ``analysis.observe`` and ``analysis.wake_model``; nothing is computed here.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from ringsim.analysis.observe import observation_pictures
from ringsim.analysis.wake_model import bar_optical_depth
from ringsim.plots.common import pyplot, save_figure, set_readable_axis

TAU_LABEL = "normal optical depth τ_n = −sin B ln T"


def _bar_parameters(obs: dict):
    fit = obs["bar_model"]
    if "height_over_width" not in fit:
        return None
    return [fit[k]["value"] for k in ("gap_fraction", "height_over_wavelength",
                                      "gap_optical_depth", "wake_orientation_deg")]


def tau_azimuth_figure(obs: dict):
    """tau_n against phi [deg] at every B, with the bar model and the geometric tau."""
    plt = pyplot()
    fig, ax = plt.subplots(figsize=(9.0, 5.0))
    params = _bar_parameters(obs)
    elevations = sorted({v["elevation_deg"] for v in obs["views"]})
    fine = np.linspace(0.0, 360.0, 361)
    values = [obs["geometric_optical_depth"]]
    for i, b in enumerate(elevations):
        row = sorted((v for v in obs["views"] if v["elevation_deg"] == b),
                     key=lambda v: v["azimuth_deg"])
        phi = [v["azimuth_deg"] for v in row]
        tau = [v["normal_optical_depth"] for v in row]
        err = [v["normal_optical_depth_stderr"] for v in row]
        values += tau
        color = f"C{i % 10}"
        ax.errorbar(phi, tau, yerr=err, fmt="o", ms=4, color=color, label=f"B = {b:g}°")
        if params is not None:
            ax.plot(fine, bar_optical_depth(np.full_like(fine, b), fine, *params), "--",
                    color=color, lw=1)
    ax.axhline(obs["geometric_optical_depth"], color="k", lw=1, ls=":",
               label="geometric Σπr²/A")
    if params is not None:
        ax.plot([], [], "k--", lw=1, label="bar model fit")
    set_readable_axis(ax, "x", [0.0, 360.0], log=False, pad=0.02)
    set_readable_axis(ax, "y", values, log=False, include_zero=True)
    ax.set_xlabel("azimuth φ of the line of sight, from radial toward orbital motion [deg]")
    ax.set_ylabel(TAU_LABEL)
    ax.set_title("Azimuthal asymmetry of the synthetic occultations")
    ax.legend(loc="upper left", bbox_to_anchor=(1.01, 1.0), fontsize=8)
    fig.tight_layout()
    return fig


def tau_elevation_figure(obs: dict):
    """tau_n against B [deg]: mean over phi, its range, the bar model along and across."""
    plt = pyplot()
    fig, ax = plt.subplots(figsize=(8.5, 5.0))
    rows = obs["azimuthal_asymmetry"]
    B = np.array([r["elevation_deg"] for r in rows])
    lo = np.array([r["normal_optical_depth_min"] for r in rows])
    hi = np.array([r["normal_optical_depth_max"] for r in rows])
    mean = np.array([r["normal_optical_depth_mean"] for r in rows])
    ax.fill_between(B, lo, hi, color="C0", alpha=0.25, label="range over φ")
    ax.plot(B, mean, "o-", color="C0", label="mean over φ")
    params = _bar_parameters(obs)
    values = list(lo) + list(hi) + [obs["geometric_optical_depth"]]
    if params is not None:
        fine = np.linspace(max(B.min(), 1.0), 90.0, 200)
        for offset, style, label in ((0.0, "--", "bar model along the wakes"),
                                     (90.0, "-.", "bar model across the wakes")):
            ax.plot(fine, bar_optical_depth(fine, np.full_like(fine, params[3] + offset),
                                            *params), style, color="C3", label=label)
    ax.axhline(obs["geometric_optical_depth"], color="k", lw=1, ls=":",
               label="geometric Σπr²/A")
    set_readable_axis(ax, "x", [0.0, 90.0], log=False, pad=0.02)
    set_readable_axis(ax, "y", values, log=False, include_zero=True)
    ax.set_xlabel("ring opening angle B [deg]")
    ax.set_ylabel(TAU_LABEL)
    ax.set_title("Normal optical depth against the opening angle")
    ax.legend(loc="upper left", bbox_to_anchor=(1.01, 1.0), fontsize=8)
    fig.tight_layout()
    return fig


def scan_figure(pictures: dict):
    """Transmission along a radial track: fine samples and the instrument's bins."""
    plt = pyplot()
    scan = pictures["scan"]
    fig, ax = plt.subplots(figsize=(10.0, 4.2))
    ax.plot(scan["x"], scan["transmission"], color="0.6", lw=0.5,
            label="single rays (every 5 cm)")
    edges = scan["bin_edges"]
    ax.stairs(scan["binned"], edges, color="C3", lw=2,
              label=f"UVIS-like bins of {pictures['resolution']:g} m")
    set_readable_axis(ax, "x", [edges[0], edges[-1]], log=False, pad=0.0)
    set_readable_axis(ax, "y", [0.0, 1.0], log=False, pad=0.02)
    ax.set_xlabel("radial distance along the track [m] (three box widths)")
    ax.set_ylabel("transmission T")
    ax.set_title(f"Synthetic occultation scan at B = {pictures['elevation_deg']:g}°, "
                 f"φ = {pictures['azimuth_deg']:g}° (snapshot {pictures['snapshot']})")
    ax.legend(loc="upper left", bbox_to_anchor=(1.01, 1.0), fontsize=8)
    fig.tight_layout()
    return fig


def sightline_figure(pictures: dict):
    """The sheet seen along two lines of sight: passing rays white, blocked ones black."""
    plt = pyplot()
    Lx, Ly = pictures["Lx"], pictures["Ly"]
    fig, axes = plt.subplots(1, 2, figsize=(11.0, 6.0), layout="constrained")
    for ax, (phi, image) in zip(axes, pictures["images"], strict=True):
        ax.imshow(image, origin="lower", extent=(-Lx / 2, Lx / 2, -Ly / 2, Ly / 2),
                  cmap="gray", vmin=0.0, vmax=1.0, interpolation="nearest")
        ax.set_aspect("equal")
        set_readable_axis(ax, "x", [-Lx / 2, Lx / 2], log=False, pad=0.0)
        set_readable_axis(ax, "y", [-Ly / 2, Ly / 2], log=False, pad=0.0)
        ax.set_xlabel("x of the ray at z = 0 (radial) [m]")
        ax.set_ylabel("y of the ray at z = 0 (azimuthal) [m]")
        ax.set_title(f"φ = {phi:g}°: T = {image.mean():.3f}", fontsize=10)
    fig.suptitle(f"The sheet seen along the line of sight at B = "
                 f"{pictures['elevation_deg']:g}° (white: the star shows through)")
    return fig


def plot_observation(run, obs: dict, out_dir: str | Path) -> list[Path]:
    """The four figures of ``ringsim observe --plots`` written into ``out_dir``."""
    out = Path(out_dir)
    pictures = observation_pictures(run, obs)
    figures = {"observe_tau_azimuth.png": tau_azimuth_figure(obs),
               "observe_tau_elevation.png": tau_elevation_figure(obs),
               "observe_scan.png": scan_figure(pictures),
               "observe_sightline.png": sightline_figure(pictures)}
    return [save_figure(fig, out / name) for name, fig in figures.items()]
