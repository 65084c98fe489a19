"""The quantities ringsim reports, declared once: name, unit, label, display and meaning.

Every number ringsim writes with a unit is a `Quantity` of `QUANTITY`: the time series of
the run file and the entries of the equilibrium that ``ringsim analyze --json`` and
``ringsim compare --json`` write.  The rest is derived from this table:

* the run file's ``units`` attributes (``store.runfile.TIMESERIES_UNITS``, from
  `TIMESERIES`; the spin rows ``physics.friction.SPIN_ROW_UNITS``, from `SPIN_ROW`);
* the units of the equilibrium JSON and the rows of the printed tables
  (``analysis.equilibrium.QUANTITIES`` from `EQUILIBRIUM`, ``PLAIN_UNITS`` from `PLAIN`,
  ``analysis.gravitating.GRAVITY_QUANTITIES`` from `GRAVITY`; ``analysis.spins``);
* the axis labels and speed unit of the figures (``plots.common``);
* the table of time series in docs/run_file.md (`timeseries_markdown`;
  tests/test_quantities.py checks that the document holds the generated text).

A name is the key users see.  An entry of a nested JSON object whose unit or meaning
differs from the quantity of the same name, or whose name alone says little, is declared
as ``"object.key"``: ``energy_budget.normal_dissipation`` is a rate per unit area [W/m^2],
the time series ``normal_dissipation`` an energy per output interval [J].

Units are the strings the files carry: SI (``"m/s"``, ``"m^2/s"``), `DIMENSIONLESS`,
``"count"``, or a named reference (``"orbits"``, ``"Omega"``, ``"mean radii"``).  Tables
and figures show a quantity in ``shown`` = ``scale`` x (the value in ``unit``): speeds in
mm/s (`SPEED_SHOWN`), everything else as stored.
"""

from __future__ import annotations

from dataclasses import dataclass

#: The unit of a pure number.
DIMENSIONLESS = "dimensionless"
#: How particles are weighted in an average, where a quantity is one ("cross section":
#: by pi r^2, the weighting of the optical depth and of occultations).
WEIGHTINGS = ("number", "mass", "cross section")
#: The unit speeds are shown in (tables and figures) and its factor from m/s.
SPEED_SHOWN = "mm/s"
SPEED_FACTOR = 1e3


@dataclass(frozen=True)
class Quantity:
    """One reported quantity.

    Parameters
    ----------
    name : str
        The key in the run file or the JSON (``"object.key"`` inside a nested object).
    unit : str
        The unit the files write (SI, `DIMENSIONLESS`, ``"count"`` or a named reference).
    meaning : str
        One line: what the number is (the docs' tables).
    label : str
        The name in printed tables and on figure axes; default the key with spaces.
    shown : str or None
        The unit shown in tables and figures; None: ``unit`` ("" for `DIMENSIONLESS`).
    scale : float
        Factor from ``unit`` to ``shown`` (1e3 from m/s to mm/s).
    weighting : None or one of `WEIGHTINGS`
        How the particles are weighted, for averages over particles.
    """

    name: str
    unit: str
    meaning: str
    label: str = ""
    shown: str | None = None
    scale: float = 1.0
    weighting: str | None = None

    def __post_init__(self):
        if not self.label:
            object.__setattr__(self, "label", self.name.rpartition(".")[2].replace("_", " "))
        if self.shown is None:
            object.__setattr__(self, "shown", "" if self.unit == DIMENSIONLESS else self.unit)
        if self.weighting is not None and self.weighting not in WEIGHTINGS:
            raise ValueError(f"{self.name}: weighting {self.weighting!r} not in {WEIGHTINGS}")

    @property
    def table_label(self) -> str:
        """The label with the shown unit in brackets (none for a shown pure number)."""
        return self.label + (f" [{self.shown}]" if self.shown else "")

    @property
    def weighted_label(self) -> str:
        """The label naming the weighting, without the unit (a ratio's row)."""
        return (f"{self.label}, {self.weighting.replace(' ', '-')}-weighted" if self.weighting
                else self.label)

    @property
    def headline_label(self) -> str:
        """`table_label` naming the weighting, for the rows of ``analyze``'s table."""
        return self.weighted_label + (f" [{self.shown}]" if self.shown else "")

    def axis_label(self, separator: str = " ") -> str:
        """A figure axis' label: the label and, in brackets, the shown unit (the stored
        unit where nothing is shown, e.g. ``[dimensionless]``)."""
        return f"{self.label}{separator}[{self.shown or self.unit}]"


def _speed(name: str, meaning: str, label: str = "", weighting: str | None = None) -> Quantity:
    """A speed [m/s], shown in `SPEED_SHOWN`."""
    return Quantity(name, "m/s", meaning, label, SPEED_SHOWN, SPEED_FACTOR, weighting)


_FRICTION = "runs with friction: "
_SIZES = "runs with more than one radius (2-D: rows × bins): "

_DECLARED = (
    # --- the time series of the run file (one row per output) -------------------------------
    Quantity("t", "s", "time of the row"),
    Quantity("orbits", "orbits", "time in orbits of 2π/Ω"),
    Quantity("dt", "s", "the integration step in use"),
    _speed("velocity_dispersion", "1-D rms speed relative to the shear flow vy = -1.5 Ω x: "
           "sqrt(trace W / 3)", "velocity dispersion c", "number"),
    _speed("velocity_dispersion_mass_weighted", "the same as `velocity_dispersion`",
           "velocity dispersion c", "mass"),
    *(Quantity(f"sigma_{ij}", "m^2/s^2", "component of the mean-subtracted dispersion "
               "tensor W", weighting="number") for ij in ("xx", "yy", "zz", "xy")),
    Quantity("thickness", "m", "rms z about the mean", "thickness H (rms z)",
             weighting="number"),
    Quantity("thickness_mass_weighted", "m", "rms z about the mean", "thickness H (rms z)",
             weighting="mass"),
    Quantity("filling_factor", DIMENSIONLESS, "volume fraction of particles in the midplane "
             "slab |z - <z>| < <r>", "midplane filling factor"),
    Quantity("optical_depth", DIMENSIONLESS, "dynamical optical depth Σπr² / (Lx Ly)"),
    Quantity("collisions", "count", "collisions resolved since the previous row"),
    Quantity("collisions_log_n", "count", "REBOUND's cumulative collision counter"),
    Quantity("collisions_plog", "kg m^2/s", "REBOUND's cumulative radial momentum-flux log "
             "(the collisional viscosity is 2 Δplog / (3 Ω Σ Lx Ly Δt))"),
    Quantity("mean_epsilon", DIMENSIONLESS, "mean applied ε of the interval's collisions",
             "mean applied epsilon"),
    _speed("mean_impact_speed", "mean normal impact speed of the interval's collisions"),
    Quantity("translational_viscosity", "m^2/s", "(2 / 3Ω) <w_x w_y>", weighting="mass"),
    Quantity("max_vertical_amplitude", "m", "largest sqrt(z² + (v_z/Ω)²): how high any "
             "particle can go before its next collision"),
    Quantity("z_half_period", "m", "half the vertical period of the box (the guard keeps the "
             "amplitude below 0.4 of it)"),
    Quantity("overlapping_pairs", "count", "pairs overlapping by more than 10 % of the "
             "smaller radius"),
    Quantity("multi_encounters", "count", "collisions of the interval in which a partner had "
             "already been deflected earlier in the same step (by a partner of at least 10 % "
             "of that pair's mass)"),
    Quantity("law_outside_speeds", "count", "impacts of the interval outside the impact "
             "speeds the restitution law was measured over"),
    Quantity("law_outside_sizes", "count", "impacts of the interval outside the reduced "
             "radii the restitution law was measured over"),
    *(Quantity(f"law_{what}_{side}", "count", f"impacts of the interval {side} the "
               f"{label} the restitution law was measured over")
      for what, label in (("speeds", "impact speeds"), ("sizes", "reduced radii"),
                          ("masses", "reduced masses")) for side in ("below", "above")),
    Quantity("law_critically_damped", "count", "impacts of the interval whose law gives "
             "ε = 0 because its damping ratio ξ ≥ 1 (critical damping; dilley)"),
    Quantity("law_inside_all", "count", "impacts of the interval inside the impact speeds, "
             "the reduced radii and the reduced masses the restitution law was measured at, "
             "all three at once (-1 in rows written before the counter existed, below -1e18 "
             "in the row of an interval resumed from a checkpoint without it: not counted)"),
    Quantity("momentum_residual", "m/s", "deviation of the sheet's mass-weighted mean motion "
             "relative to the shear flow from a free epicycle since the previous row (runtime "
             "invariant 3 below; 0 in row 0; NaN in rows written by format 1.0 before a "
             "`--resume`)"),
    Quantity("toomre_Q", DIMENSIONLESS, "gravitating runs only: Q = sqrt(sigma_xx) Ω / "
             "(3.36 G Σ), the stellar-disk form (`physics.gravity.toomre_q`; `analyze` adds "
             "`toomre_Q_mass`, from the mass-weighted sigma_xx of the snapshots)",
             "Toomre Q (number-weighted sigma_x)", weighting="number"),
    _speed("size_bin_velocity_dispersion", _SIZES + "`velocity_dispersion` of each size bin "
           "about the sheet's mass-weighted mean velocity",
           weighting="number"),
    Quantity("size_bin_thickness", "m", _SIZES + "rms z of each size bin about the sheet's "
             "mass-weighted mean height", weighting="number"),
    Quantity("size_bin_n", "count", _SIZES + "particles in each size bin"),
    *(_speed(f"size_bin_sigma_{axis}", _SIZES + f"rms {name} velocity of each size bin "
             "about the sheet's mass-weighted mean velocity (the velocity ellipsoid)",
             weighting="number")
      for axis, name in (("x", "radial"), ("y", "azimuthal"), ("z", "vertical"))),
    Quantity("size_bin_pair_collisions", "count", "runs with size bins and "
             "`output.log_collisions` > 0 (2-D: rows × bins²): sampled collisions of the "
             "interval per pair of bins, entry i n_bins + j the smaller partner in bin i, the "
             "larger in bin j (radii from R̄ and M̄ at the one bulk density)"),
    Quantity("size_bin_pair_epsilon_sum", DIMENSIONLESS, "as `size_bin_pair_collisions`: "
             "the summed law's ε of those collisions (mean ε = sum / count)"),
    Quantity("one_minus_epsilon_histogram", "count", "per interval, counts of 1 - ε in the "
             "bins `one_minus_epsilon_bin_edges` (first bin: 1 - ε < 1e-4, i.e. nearly "
             "elastic)"),
    Quantity("impact_speed_histogram", "count", "per interval, counts of the normal impact "
             "speed in the bins `impact_speed_bin_edges` (first and last bins: under- and "
             "overflow)"),
    Quantity("normal_dissipation", "J", "kinetic energy the normal impulses dissipated in "
             "the interval, counted by the resolver per collision, 1/2 M̄ J (2 v_n − J) with J "
             "the separation-speed change (the minimum-velocity floor included); all runs "
             "(absent in files written before it existed)"),
    Quantity("tangential_dissipation", "J", _FRICTION + "energy (translation + rotation) the "
             "tangential impulses dissipated in the interval, 1/2 M̄ f_t (1 − β²) |g_t|² per "
             "collision"),
    Quantity("sliding_collisions", "count", _FRICTION + "collisions of the interval on which "
             "Coulomb's bound acted (0 for constant β)"),
    Quantity("rotational_energy", "J", _FRICTION + "Σ 1/2 k m r² |w|², spins w relative to "
             "the rotating frame (a particle keeping one face to the planet has none)"),
    Quantity("rotational_energy_ratio", DIMENSIONLESS, _FRICTION + "`rotational_energy` / "
             "E_tr, E_tr = 3/2 Σm c_m² the kinetic energy relative to the shear flow (c_m = "
             "`velocity_dispersion_mass_weighted`; 0 while E_tr = 0)", "E_rot / E_tr"),
    Quantity("size_bin_rotational_energy", "J", _FRICTION + _SIZES + "`rotational_energy` "
             "of each size bin (`physics.spin_by_size`; NaN for an empty bin)"),
    Quantity("size_bin_rotational_energy_ratio", DIMENSIONLESS, _FRICTION + _SIZES
             + "each size bin's rotational energy over its translational energy 1/2 Σm |v − "
               "⟨v⟩_m|², velocities relative to the shear flow about the sheet's "
               "mass-weighted mean (`physics.spin_by_size`; NaN for an empty bin)",
             "E_rot / E_tr per size bin"),
    Quantity("mean_spin_z", "Omega", _FRICTION + "mean w_z / Ω in the rotating frame (w_z > "
             "0 prograde; synchronous rotation 0; a particle not rotating in inertial space "
             "−1; turning with the mean shear flow −3/4)", "mean w_z / Omega", "",
             weighting="number"),
    Quantity("rms_spin", "Omega", _FRICTION + "sqrt(<|w|²>) / Ω, rotating frame",
             "rms |w| / Omega", "", weighting="number"),
    # --- bin edges stored beside the time series (written once) ------------------------------
    Quantity("size_bin_edges", "m", "edges of the radius bins of the `size_bin_` series, "
             "log-spaced"),
    Quantity("one_minus_epsilon_bin_edges", DIMENSIONLESS, "edges of the bins of "
             "`one_minus_epsilon_histogram`"),
    Quantity("impact_speed_bin_edges", "m/s", "edges of the bins of `impact_speed_histogram`"),
    # --- the equilibrium (ringsim analyze) -----------------------------------------------------
    Quantity("velocity_dispersion_rOmega", "mean radius x Omega", "c / (<r> Ω)",
             "c / (<r> Omega)", "", weighting="number"),
    Quantity("thickness_r", "mean radii", "H / <r>", "H / <r>", "", weighting="number"),
    Quantity("collision_frequency", "1/orbit", "impacts per particle per orbit over the "
             "window", "collisions per particle per orbit", ""),
    Quantity("collisional_viscosity", "m^2/s", "2 Δplog / (3 Ω Σ Lx Ly Δt) over the window",
             "collisional viscosity"),
    Quantity("equilibrium_from_orbit", "orbits", "first orbit of the equilibrium window"),
    Quantity("tiled_copies_independent_from_orbit", "orbits", "first snapshot at which every "
             "tiled copy is independent of the first (Infinity while they are not)"),
    Quantity("n_particles", "count", "particles in the box"),
    Quantity("window_snapshots", "count", "snapshots in the equilibrium window, over which "
             "the local dispersions, the cross-section-weighted thickness and the by-size "
             "layers average (0: none lies in it, and they are from the last snapshot, "
             "which lies before the window)"),
    Quantity("mean_radius", "m", "mean particle radius <r> (first snapshot)"),
    Quantity("mean_mass", "kg", "mean particle mass of a size bin (first snapshot)"),
    Quantity("r_low", "m", "lower radius edge of a size bin"),
    Quantity("r_high", "m", "upper radius edge of a size bin"),
    Quantity("n", "count", "particles in a size bin, window mean"),
    Quantity("ratio", DIMENSIONLESS, "a quotient of two equilibrium numbers, with the "
             "propagated standard error"),
    Quantity("size_ratio.small_bin_m", "m", "radius edges of the smallest populated bin"),
    Quantity("size_ratio.large_bin_m", "m", "radius edges of the largest populated bin"),
    Quantity("size_ratio.equipartition", DIMENSIONLESS, "sqrt(<m>_large / <m>_small): the "
             "ratio equal kinetic energies would give"),
    Quantity("law_range.outside_speeds", "fraction of impacts", "share of the window's "
             "impacts outside the speeds the law was measured over"),
    Quantity("law_range.outside_sizes", "fraction of impacts", "share of the window's "
             "impacts outside the reduced radii the law was measured over"),
    Quantity("law_range.speeds", "m/s", "impact speeds the law was measured over",
             "impact speeds", "cm/s", 100.0),
    Quantity("law_range.sizes", "m", "reduced radii the law was measured over",
             "reduced radii", "cm", 100.0),
    *(_speed(f"sigma_{axis}", f"rms {name} velocity of a size bin about the sheet's "
             "mass-weighted mean velocity, window mean", f"sigma_{axis}", weighting="number")
      for axis, name in (("x", "radial"), ("y", "azimuthal"), ("z", "vertical"))),
    Quantity("pair_epsilon.edges", "m", "radius edges of the size bins of the pair table"),
    Quantity("pair_epsilon.counts", "count", "sampled collisions of the window per pair of "
             "size bins (row: the smaller partner's bin, column: the larger's)"),
    Quantity("pair_epsilon.mean_epsilon", DIMENSIONLESS, "mean law's ε of those collisions "
             "(NaN where none)"),
    Quantity("law_range.masses", "kg", "reduced masses the law was measured at",
             "reduced masses", "g", 1e3),
    Quantity("law_range.outside_masses", "fraction of impacts", "share of the window's "
             "impacts outside the reduced masses the law was measured at"),
    *(Quantity(f"law_range.{what}_{side}", "fraction of impacts", f"share of the window's "
               f"impacts {side} the {what} the law was measured over")
      for what in ("speeds", "sizes", "masses") for side in ("below", "above")),
    Quantity("law_range.critically_damped", "fraction of impacts", "share of the window's "
             "impacts whose law gives ε = 0 because ξ ≥ 1 (critical damping)"),
    Quantity("law_range.critically_damped_count", "count", "impacts of the window whose "
             "law gives ε = 0 because ξ ≥ 1"),
    Quantity("law_range.inside_all", "fraction of impacts", "share of the window's impacts "
             "inside the speeds, the reduced radii and the reduced masses the law was "
             "measured at, all three at once (NaN where the law states no range in one of "
             "them or the run file lacks the counter)"),
    # --- aggregation of the window (analysis.aggregation) -------------------------------------
    Quantity("aggregation.rows", "count", "time-series rows of the window"),
    Quantity("aggregation.overlap_rows", "count", "rows of the window with pairs overlapping "
             "by more than 10 % of the smaller radius"),
    Quantity("aggregation.max_overlapping_pairs", "count", "most such pairs in one row"),
    Quantity("aggregation.multi_encounter_share", "fraction of collisions", "multi-encounters "
             "per collision in the window"),
    Quantity("aggregation.bound_fraction_mean", "fraction of the mass", "share of the mass in "
             "bound Hill-sphere groups, the mean over the window's snapshots (the verdict's)",
             weighting="mass"),
    Quantity("aggregation.bound_fraction_max", "fraction of the mass", "largest share of the "
             "mass in bound Hill-sphere groups in a snapshot of the window", weighting="mass"),
    Quantity("aggregation.bound_fraction_last", "fraction of the mass", "share of the mass in "
             "bound Hill-sphere groups in the window's last snapshot", weighting="mass"),
    Quantity("aggregation.contact_fraction_last", "fraction of the mass", "share of the mass "
             "in contact groups of >= 10 particles in the window's last snapshot",
             weighting="mass"),
    # --- heating or cooling, and the velocity ellipsoid (analysis.thermal) ----------------------
    Quantity("thermal_balance.growth_rate", "1/orbit", "least-squares slope of ln c² against "
             "the orbit after the start's relaxation (3 orbits), error from batch means",
             "growth rate of ln c²"),
    Quantity("thermal_balance.sigma_xy_over_xx", DIMENSIONLESS, "σ_xy / σ_xx over the same "
             "rows (the shear stress's share)", "σ_xy / σ_xx", weighting="number"),
    Quantity("thermal_balance.sigma_yy_over_xx", DIMENSIONLESS, "σ_yy / σ_xx over the same "
             "rows", "σ_yy / σ_xx", weighting="number"),
    Quantity("thermal_balance.sigma_zz_over_xx", DIMENSIONLESS, "σ_zz / σ_xx over the same "
             "rows", "σ_zz / σ_xx", weighting="number"),
    # --- the energy budget and the spins (analysis.spins) --------------------------------------
    Quantity("energy_budget.heating", "W/m^2", "shear heating (9/4) Ω² Σ ν_trans + (3/2) Ω "
             "Δplog / (Lx Ly Δt)", "shear heating"),
    Quantity("energy_budget.normal_dissipation", "W/m^2", "dissipation of the normal "
             "impulses per unit area"),
    Quantity("energy_budget.tangential_dissipation", "W/m^2", "dissipation of the tangential "
             "impulses per unit area"),
    Quantity("energy_budget.ratio", DIMENSIONLESS, "heating over the dissipation (1 in a "
             "steady state)", "heating / dissipation"),
    Quantity("energy_budget.tangential_share", DIMENSIONLESS, "tangential share of the "
             "dissipation"),
    Quantity("rotational_energy_fraction", DIMENSIONLESS, "window mean of "
             "`rotational_energy_ratio`", "E_rot / E_tr"),
    Quantity("sliding_fraction", DIMENSIONLESS, "share of the window's collisions on which "
             "Coulomb's bound acted", "sliding collisions"),
    # --- random against coherent motion, weightings (analysis.motions) -------------------------
    Quantity("thickness_cross_section_weighted", "m", "rms z about the mean, each particle "
             "weighted by its cross section πr² (the weighting of the optical depth and of "
             "occultations), over the window's snapshots", "thickness H",
             weighting="cross section"),
    _speed("velocity_dispersion_number_weighted", "`velocity_dispersion` under a name that "
           "says its weighting", "velocity dispersion c", "number"),
    Quantity("thickness_number_weighted", "m", "`thickness` under a name that says its "
             "weighting", "thickness H (rms z)", weighting="number"),
    _speed("velocity_dispersion_local_number_weighted", "1-D rms speed about the local mean "
           "flow: velocities relative to the shear flow minus the mean of their (x, y) cell "
           "of side `local_dispersion_cell` (cells of 3 or more particles), with the bias of "
           "the cell means removed; the random part of `velocity_dispersion` without "
           "coherent motion (wakes); over the window's snapshots",
           "local velocity dispersion c_loc", "number"),
    _speed("velocity_dispersion_local_mass_weighted", "the same as "
           "`velocity_dispersion_local_number_weighted`, the particles' variances averaged "
           "by mass",
           "local velocity dispersion c_loc", "mass"),
    Quantity("local_dispersion_cell", "m", "side of the (x, y) cells of the local mean flow: "
             "λ_cr / 8, but at least the side holding 4 particles on average",
             "cell of the local mean flow"),
    Quantity("spin_bins.rotational_energy_random", "J", "per particle, 1/2 I |w - <w>_I|²: "
             "the spins about the bin's inertia-weighted mean spin (the same in the rotating "
             "and the inertial frame)", "E_rot about the mean"),
    Quantity("spin_bins.rotational_energy_mean_rotating", "J", "per particle, 1/2 I "
             "|<w>_I|²: the part of the mean spin, rotating frame", "E_rot of the mean spin"),
    Quantity("spin_bins.rotational_energy_mean_inertial", "J", "per particle, 1/2 I "
             "|<w>_I + Ω z|²: the part of the mean spin, inertial frame",
             "E_rot of the mean spin (inertial)"),
    Quantity("spin_bins.rotational_energy_fraction_random", DIMENSIONLESS, "E_rot about the "
             "mean over E_tr of the bin", "E_rot about the mean / E_tr"),
    Quantity("spin.rotational_energy_fraction_random", DIMENSIONLESS, "the spins about each "
             "size bin's mean spin over E_tr, summed over the bins, from the window's "
             "snapshots", "E_rot about the mean spin / E_tr"),
    # --- a gravitating run's equilibrium (analysis.gravitating) --------------------------------
    Quantity("r_h", DIMENSIONLESS, "Hill parameter of the mean pair",
             "Hill parameter r_h (mean pair)"),
    Quantity("toomre_Q_mass", DIMENSIONLESS, "Toomre Q from the mass-weighted sigma_x of the "
             "window's snapshots", "Toomre Q (mass-weighted sigma_x)", weighting="mass"),
    Quantity("lambda_cr", "m", "Toomre's critical wavelength 4π²GΣ/Ω²",
             "Toomre wavelength lambda_cr"),
    Quantity("wake_wavelength", "m", "wavelength of the window's wake: of the mean wave "
             "vector of the significant snapshots' dominant shear-periodic modes (null "
             "without a significant wake)"),
    Quantity("wake_pitch_angle", "deg", "pitch angle of the same mean wave vector",
             "wake pitch angle (trailing > 0)"),
    Quantity("wake_amplitude", DIMENSIONLESS, "peak contrast A of Σ = <Σ>(1 + A cos k·r) of "
             "the dominant mode, mean over the significant snapshots",
             "wake amplitude (peak contrast)"),
    Quantity("gravitational_viscosity", "m^2/s", "viscosity of the gravitational torque"),
    Quantity("viscous_heating", "W/m^2", "(9/4) Ω² Σ (ν_trans + ν_coll + ν_grav)",
             "viscous heating (nu_t + nu_c + nu_g)"),
    Quantity("collisional_dissipation", "W/m^2", "dissipation from the impact-speed "
             "histograms and the law"),
    Quantity("kinetic_energy_change", "W/m^2", "(3/2) Σ d(c²)/dt over the window",
             "d/dt random kinetic energy"),
    Quantity("energy_closure", DIMENSIONLESS, "heating / (dissipation + kinetic change)",
             "heating / (dissipation + d/dt E_kin)"),
    Quantity("energy_closure_without_gravity", DIMENSIONLESS, "the same with ν_grav left "
             "out", "the same without nu_g"),
)

#: Every quantity by name.
QUANTITY: dict[str, Quantity] = {q.name: q for q in _DECLARED}
if len(QUANTITY) != len(_DECLARED):
    raise ValueError("a quantity is declared twice")

#: The run file's time series, in the order of a row (``/timeseries/NAME``).
TIMESERIES = ("t", "orbits", "dt", "velocity_dispersion", "velocity_dispersion_mass_weighted",
              "sigma_xx", "sigma_yy", "sigma_zz", "sigma_xy", "thickness",
              "thickness_mass_weighted", "filling_factor", "optical_depth", "collisions",
              "collisions_log_n", "collisions_plog", "mean_epsilon", "mean_impact_speed",
              "translational_viscosity", "max_vertical_amplitude", "z_half_period",
              "overlapping_pairs", "multi_encounters", "law_outside_speeds",
              "law_outside_sizes", "law_speeds_below", "law_speeds_above",
              "law_sizes_below", "law_sizes_above", "law_masses_below", "law_masses_above",
              "law_critically_damped", "law_inside_all", "momentum_residual", "toomre_Q",
              "size_bin_velocity_dispersion", "size_bin_thickness", "size_bin_n",
              "size_bin_sigma_x", "size_bin_sigma_y", "size_bin_sigma_z",
              "size_bin_pair_collisions", "size_bin_pair_epsilon_sum",
              "one_minus_epsilon_histogram", "impact_speed_histogram", "normal_dissipation",
              "tangential_dissipation", "sliding_collisions", "rotational_energy",
              "rotational_energy_ratio", "mean_spin_z", "rms_spin",
              "size_bin_rotational_energy", "size_bin_rotational_energy_ratio")
#: The bin edges stored once beside the time series.
TIMESERIES_EDGES = ("size_bin_edges", "one_minus_epsilon_bin_edges", "impact_speed_bin_edges")
#: The spin rows of a run with friction (``physics.friction.spin_row``).
SPIN_ROW = ("rotational_energy", "rotational_energy_ratio", "mean_spin_z", "rms_spin")
#: The equilibrium's table quantities, in the order ``analyze`` and ``compare`` print them.
EQUILIBRIUM = ("velocity_dispersion", "velocity_dispersion_rOmega", "thickness", "thickness_r",
               "filling_factor", "collision_frequency", "mean_epsilon",
               "translational_viscosity", "collisional_viscosity")
#: The plain numbers of an equilibrium (and the per-size-bin edges and count), whose units
#: the JSON's ``units`` entry gives.
PLAIN = ("orbits", "n_particles", "mean_radius", "optical_depth", "equilibrium_from_orbit",
         "window_snapshots", "r_low", "r_high", "n")
#: A gravitating run's equilibrium quantities, in the printed order.
GRAVITY = ("r_h", "toomre_Q", "toomre_Q_mass", "lambda_cr", "wake_wavelength",
           "wake_pitch_angle", "wake_amplitude", "gravitational_viscosity", "viscous_heating",
           "collisional_dissipation", "kinetic_energy_change", "energy_closure",
           "energy_closure_without_gravity")


def unit(name: str) -> str:
    """The unit of a declared quantity; KeyError for an undeclared one."""
    return QUANTITY[name].unit


def units(names) -> dict[str, str]:
    """name -> unit for the given names, in their order."""
    return {name: QUANTITY[name].unit for name in names}


def table_rows(names) -> dict[str, tuple[str, str, str, float]]:
    """name -> (label, unit, shown unit, scale): the rows of the printed tables."""
    return {name: (QUANTITY[name].label, QUANTITY[name].unit, QUANTITY[name].shown or "",
                   QUANTITY[name].scale) for name in names}


def markdown_unit(text: str) -> str:
    """A unit as the docs write it: ``m²/s²``, ``1`` for `DIMENSIONLESS`, ``Ω``."""
    if text == DIMENSIONLESS:
        return "1"
    return text.replace("^2", "²").replace("^3", "³").replace("Omega", "Ω")


def _meaning(q: Quantity) -> str:
    text = q.meaning + (f", {q.weighting}-weighted" if q.weighting else "")
    return text.replace("|", "\\|")


def markdown_table(names) -> str:
    """The Markdown table (dataset, units, meaning) of the named quantities.

    Consecutive quantities of the same meaning share a row, with their units listed in
    order where they differ.
    """
    groups: list[list[Quantity]] = []
    for name in names:
        q = QUANTITY[name]
        if groups and _meaning(groups[-1][-1]) == _meaning(q):
            groups[-1].append(q)
        else:
            groups.append([q])
    lines = ["| dataset | units | meaning |", "|---|---|---|"]
    for group in groups:
        shown = [markdown_unit(q.unit) for q in group]
        text = shown[0] if len(set(shown)) == 1 else ", ".join(shown)
        lines.append(f"| {', '.join(f'`{q.name}`' for q in group)} | {text} | "
                     f"{_meaning(group[0])} |")
    return "\n".join(lines) + "\n"


def timeseries_markdown() -> str:
    """The table of ``/timeseries/`` in docs/run_file.md: every time series, then the bin
    edges stored beside them."""
    return markdown_table(TIMESERIES + TIMESERIES_EDGES)
