"""What the validation cases share: sizes, result rows, cached runs, scenarios, energy balance.

The ladder's case (``case5_rebound_example``) returns a
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
from ringsim.config.scenario import scenario_from_dict
from ringsim.errors import InputError
from ringsim.plots.common import pyplot, save_figure  # noqa: F401  (pyplot: the cases' figures)
from ringsim.store.runfile import open_run

#: The repository (a source checkout) whose docs/ and runs/ the ladder writes.
ROOT = Path(__file__).resolve().parents[1]
DOC = ROOT / "docs" / "validation.md"
WORKDIR = ROOT / "runs" / "validation"

#: Orbital frequency of the sheets of ``sheet_scenario`` [1/s]; results are in units of r Omega.
OMEGA_LAB = 2.0e-4
#: Solid ice [kg/m^3].
ICE = 900.0


# --- sizes -----------------------------------------------------------------------------------

@dataclass(frozen=True)
class Sizes:
    """Particle numbers and durations [orbits] of every case."""

    case5_n: int | None = None              # None: the example's own N (about 1490)
    case5_orbits: float = 10.0
    case5_skip_orbits: float = 2.0


FULL = Sizes()
QUICK = Sizes(case5_n=600, case5_orbits=8.0, case5_skip_orbits=2.0)


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


def figure_file(fig, figures: Path, name: str) -> Path:
    """Lay out ``fig``, write it as ``figures/name`` (PNG) and close it; returns the path."""
    return save_figure(fig, figures / name)
