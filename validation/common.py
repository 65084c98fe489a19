"""What the validation cases share: sizes, result rows, cached runs, scenarios, energy balance.

Every case of the ladder (``case1_constant_eps`` ... ``case5_rebound_example``) returns a
``CaseResult``: rows (``Comparison``) of ringsim's value with its standard error against a
reference with its uncertainty and source.  Results are stored as JSON beside the runs
(``save_result``, ``load_results``), and finished run files are reused when their scenario
is unchanged (``run_cached``).  All SI inside; results in units of the particle radius r
and Omega.

The ladder runs from a source checkout: it reads ``scenarios/bridges.yaml`` and writes
``docs/validation.md`` and ``docs/figures/`` of the repository (``ROOT``).
"""

from __future__ import annotations

import dataclasses
import json
import math
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

import ringsim
from ringsim.analysis import timeseries
from ringsim.config.scenario import scenario_from_dict
from ringsim.errors import InputError
from ringsim.physics import restitution as rs
from ringsim.plots.common import pyplot, save_figure
from ringsim.store.runfile import open_run

#: The repository (a source checkout) whose docs/ and runs/ the ladder writes.
ROOT = Path(__file__).resolve().parents[1]
DOC = ROOT / "docs" / "validation.md"
WORKDIR = ROOT / "runs" / "validation"

TWO_PI = 2.0 * math.pi
#: Orbital frequency of the constant-eps cases [1/s]; results are in units of r Omega.
OMEGA_LAB = 2.0e-4
#: Saturn's GM [m^3/s^2] and the orbital radius of cases 3-4 [m] (Wisdom & Tremaine 1988
#: and Salo 1991 place their patches in Saturn's rings; 100 000 km is inside the B ring).
SATURN_GM = 3.7931e16
RING_RADIUS = 1.0e8
#: Solid ice [kg/m^3].
ICE = 900.0


# --- sizes -----------------------------------------------------------------------------------

@dataclass(frozen=True)
class Sizes:
    """Particle numbers and durations [orbits] of every case."""

    case1_n: int = 1000
    case1_orbits: float = 40.0
    case1_orbits_dilute: float = 100.0      # tau <= 0.15 collides rarely: longer run
    case1_taus: tuple[float, ...] = (0.1, 0.25, 0.5, 0.75, 1.0, 1.5)
    case3_n: int = 1000
    case3_orbits: float = 40.0
    case3_taus: tuple[float, ...] = (0.25, 0.5, 1.0)
    case5_n: int | None = None              # None: the example's own N (about 1490)
    case5_orbits: float = 10.0
    case5_skip_orbits: float = 2.0


FULL = Sizes()
QUICK = Sizes(case1_n=300, case1_orbits=15.0, case1_orbits_dilute=30.0,
              case1_taus=(0.1, 0.25, 0.5, 1.0, 1.5), case3_n=300, case3_orbits=15.0,
              case3_taus=(0.25, 1.0), case5_n=600,
              case5_orbits=8.0, case5_skip_orbits=2.0)


# --- results ---------------------------------------------------------------------------------

@dataclass
class Comparison:
    """One row of a case table: ringsim's value against a reference.

    ``kind`` "value": reference = ``ref_value`` +- ``ref_err``; the difference is
    (ringsim - ref) / hypot(ringsim_err, ref_err).  ``kind`` "range": the reference is an
    interval [``ref_low``, ``ref_high``] (a qualitative statement read as a range); the
    difference is the distance outside it in units of ringsim's error (0 inside).
    ``expected`` says whether agreement ("agree") or disagreement ("disagree", e.g.
    equipartition) is the physically expected outcome; ``max_sigma`` is the tolerance.
    """

    quantity: str
    ringsim: float
    ringsim_err: float
    reference: str
    source: str
    kind: str = "value"
    ref_value: float = math.nan
    ref_err: float = 0.0
    ref_low: float = -math.inf
    ref_high: float = math.inf
    max_sigma: float = 3.0
    expected: str = "agree"

    @property
    def sigma(self) -> float:
        """Difference in units of the combined uncertainty (signed for "value")."""
        if self.kind == "range":
            if self.ref_low <= self.ringsim <= self.ref_high:
                return 0.0
            edge = self.ref_low if self.ringsim < self.ref_low else self.ref_high
            err = self.ringsim_err
            return (self.ringsim - edge) / err if err > 0 else math.copysign(math.inf,
                                                                             self.ringsim - edge)
        combined = math.hypot(self.ringsim_err, self.ref_err)
        diff = self.ringsim - self.ref_value
        if combined > 0:
            return diff / combined
        return 0.0 if diff == 0 else math.copysign(math.inf, diff)

    @property
    def agrees(self) -> bool:
        return bool(abs(self.sigma) <= self.max_sigma)

    @property
    def as_expected(self) -> bool:
        return self.agrees == (self.expected == "agree")

    def to_dict(self) -> dict:
        d = dataclasses.asdict(self)
        d.update(sigma=self.sigma, agrees=self.agrees, as_expected=self.as_expected)
        return d


@dataclass
class CaseResult:
    """Everything the report needs of one case."""

    number: int
    title: str
    setup: str
    comparisons: list[Comparison]
    discussion: str
    figure: str = ""
    cpu_seconds: float = 0.0
    sizes: str = ""
    extra: dict = field(default_factory=dict)

    @property
    def passed(self) -> bool:
        return all(c.as_expected for c in self.comparisons)

    def to_dict(self) -> dict:
        d = dataclasses.asdict(self)
        d["comparisons"] = [c.to_dict() for c in self.comparisons]
        d["passed"] = self.passed
        return d

    @classmethod
    def from_dict(cls, d: dict) -> CaseResult:
        names = {f.name for f in dataclasses.fields(Comparison)}
        rows = [Comparison(**{k: v for k, v in c.items() if k in names})
                for c in d["comparisons"]]
        keep = {f.name for f in dataclasses.fields(cls)} - {"comparisons"}
        return cls(comparisons=rows, **{k: v for k, v in d.items() if k in keep})


def _json_default(x):
    if isinstance(x, np.generic):
        return x.item()
    if isinstance(x, np.ndarray):
        return x.tolist()
    raise TypeError(f"not JSON serializable: {type(x).__name__}")


def save_result(result: CaseResult, workdir: Path) -> Path:
    path = workdir / "results" / f"case{result.number}.json"
    path.parent.mkdir(parents=True, exist_ok=True)
    path.write_text(json.dumps(result.to_dict(), indent=1, default=_json_default,
                               allow_nan=True))
    return path


def load_results(workdir: Path) -> dict[int, CaseResult]:
    out = {}
    for path in sorted((workdir / "results").glob("case*.json")):
        result = CaseResult.from_dict(json.loads(path.read_text()))
        out[result.number] = result
    return out


# --- running ---------------------------------------------------------------------------------

#: Run files used by the case being run: path -> (wall time of the run [s], run now?).
RUNS_USED: dict[str, tuple[float, bool]] = {}


def run_cached(scenario, path: Path):
    """``ringsim.run`` the scenario into ``path`` unless a finished run of the same scenario
    is already there; returns the opened run."""
    path = Path(path)
    if path.exists():
        try:
            run = open_run(path)
            if (run.attrs.get("status") == "finished"
                    and run.scenario.to_dict() == scenario.to_dict()):
                RUNS_USED[str(path)] = (float(run.attrs.get("wall_time_s", 0.0)), False)
                return run
        except (OSError, KeyError, ValueError, InputError):
            pass
    ringsim.run(scenario, output=path, force=True, progress=False)
    run = open_run(path)
    RUNS_USED[str(path)] = (float(run.attrs.get("wall_time_s", 0.0)), True)
    return run


def value(entry: dict) -> tuple[float, float]:
    """(mean, stderr) of an equilibrium entry."""
    return float(entry["mean"]), float(entry["stderr"])


def equilibrium_entry(eq: dict, tau: float) -> dict:
    """The numbers of one run's equilibrium the case tables show: c/(r Omega), H/r and the
    filling factor as (mean, stderr), the collision frequency, and the equilibrium verdict."""
    return {"tau": tau, "c": value(eq["velocity_dispersion_rOmega"]),
            "h": value(eq["thickness_r"]), "ff": value(eq["filling_factor"]),
            "collision_frequency": value(eq["collision_frequency"]),
            "in_equilibrium": eq["in_equilibrium"], "reason": eq["reason"]}


def sheet_scenario(name: str, *, size_distribution: dict, restitution: dict, tau: float,
                   n: int, orbits: float, planet: dict | None = None, seed: int = 1,
                   collision_detection: str = "tree", dt="auto", initial_dispersion: float = 2.0,
                   density: float = ICE, timeseries_every: float = 0.1,
                   log_collisions: int = 0, z_box: float | str = "auto"):
    """A non-gravitating sheet scenario (validated like a user's YAML)."""
    d = {
        "name": name, "seed": seed,
        "planet": planet or {"Omega": OMEGA_LAB},
        "particles": {"density": density, "size_distribution": size_distribution},
        "sheet": {"optical_depth": tau, "n_particles": n, "gravity": False,
                  "initial_dispersion": initial_dispersion, "z_box": z_box},
        "restitution": restitution,
        "integration": {"orbits": orbits, "dt": dt, "collision_detection": collision_detection},
        "output": {"timeseries_every": timeseries_every, "snapshot_every": 1000.0,
                   "log_collisions": log_collisions},
    }
    return scenario_from_dict(d, source=f"<validation {name}>")


MONODISPERSE_1M = {"kind": "monodisperse", "radius": 1.0}
SATURN = {"GM": SATURN_GM, "a": RING_RADIUS}
BRIDGES = {"model": "bridges", "v_c": rs.BRIDGES_V_C, "exponent": rs.BRIDGES_EXPONENT}


def figure_file(fig, figures: Path, name: str) -> Path:
    """Lay out ``fig``, write it as ``figures/name`` (PNG) and close it; returns the path."""
    return save_figure(fig, figures / name)




def dispersion_against_tau(table: list[dict], label: str):
    """A figure of two panels, the first with c/(r Omega) against tau (error bars) drawn.

    ``table``: one dict per optical depth with ``tau`` and ``c`` = (mean, stderr) [r Omega].
    Returns the figure, both axes and the optical depths (array).
    """
    plt = pyplot()
    fig, (ax_c, ax_2) = plt.subplots(1, 2, figsize=(11, 4.3))
    taus = np.array([t["tau"] for t in table])
    cm = np.array([t["c"] for t in table])
    ax_c.errorbar(taus, cm[:, 0], yerr=cm[:, 1], fmt="o-", label=label)
    return fig, ax_c, ax_2, taus


# --- energy balance of a sheet ---------------------------------------------------------------

def bin_mean_square_speed(counts: np.ndarray, edges: np.ndarray) -> np.ndarray:
    """Mean v^2 [m^2/s^2] within each logarithmic speed bin, for a density that follows the
    local power law of the neighbouring bins (within a bin of 10 per decade a log-uniform
    density would bias sum v^2 by ~2%; the local slope removes most of that).

    Parameters
    ----------
    counts : array (n_bins,) of collision counts
    edges : array (n_bins + 1,) [m/s], 0 < edges
    """
    lo, hi = edges[:-1], edges[1:]
    width = np.log(hi / lo)
    with np.errstate(divide="ignore", invalid="ignore"):
        log_density = np.log(np.where(counts > 0, counts / width, np.nan))
    centre = 0.5 * (np.log(lo) + np.log(hi))
    left = np.concatenate([[0], np.arange(counts.size - 1)])
    right = np.concatenate([np.arange(1, counts.size), [counts.size - 1]])
    with np.errstate(invalid="ignore"):
        slope = (log_density[right] - log_density[left]) / (centre[right] - centre[left])
    slope = np.where(np.isfinite(slope), slope, 0.0)

    def integral(k):  # int_lo^hi v^k dln v
        safe = np.where(np.abs(k) > 1e-9, k, 1.0)
        return np.where(np.abs(k) > 1e-9, (hi**safe - lo**safe) / safe, width)

    return integral(slope + 2.0) / integral(slope)


def energy_balance(run, eq: dict) -> dict:
    """Viscous heating and collisional dissipation of a constant-eps run of identical
    particles over its equilibrium window [W/m^2].

    Heating by the shear: (9/4) Omega^2 Sigma (nu_trans + nu_col) (Wisdom & Tremaine 1988;
    nu_col from REBOUND's collisions_plog).  Dissipation: (1 - eps^2) (M_bar/2) sum v_n^2
    per unit area and time, M_bar = m/2, with sum v_n^2 from the impact-speed histograms of
    the run file (``bin_mean_square_speed``).  In a steady state they are equal.
    """
    ts = run.timeseries
    Omega = run.scenario.orbital_frequency
    eps = float(run.scenario.restitution_dict()["epsilon"])
    first = run.snapshot(0)
    area = float(run.attrs["Lx"]) * float(run.attrs["Ly"])
    sigma = float(first["mass"].sum()) / area
    m = float(first["mass"][0])
    start = int(np.searchsorted(ts["orbits"], eq["equilibrium_from_orbit"]["mean"] - 1e-9))
    start = max(start, 1)
    edges = ts["impact_speed_bin_edges"]
    hist = ts["impact_speed_histogram"]
    # underflow [0, 1e-7 m/s] and overflow [100 m/s, inf) hold (almost) nothing
    inner = bin_mean_square_speed(hist[start:, 1:-1].sum(axis=0).astype(float), edges[1:-1])
    v2 = np.concatenate([[edges[1] ** 2 / 3.0], inner, [edges[-2] ** 2]])
    dt = np.diff(ts["t"], prepend=np.nan)
    dissipation = (1.0 - eps**2) * (m / 4.0) * (hist @ v2) / (area * dt)
    dplog = np.diff(ts["collisions_plog"], prepend=np.nan)
    heating = (2.25 * Omega**2 * sigma * ts["translational_viscosity"]
               + 1.5 * Omega * dplog / (area * dt))
    h = timeseries.autocorrelated_mean(heating[start:])
    d = timeseries.autocorrelated_mean(dissipation[start:])
    ratio = h[0] / d[0]
    return {"heating": h[:2], "dissipation": d[:2], "ratio": ratio,
            "ratio_err": abs(ratio) * math.hypot(h[1] / h[0], d[1] / d[0])}
