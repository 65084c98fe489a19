"""Build the figure gallery of docs/figures.md: every figure that ``ringsim analyze``,
``compare``, ``sweep``, ``study``, ``epsilon`` and ``fit`` make, from the bundled scenarios
with short overrides (a few minutes of CPU in all).

    python docs/make_figures.py [--workdir DIR [--reuse]] [--out docs/figures/gallery]

Run files go to ``--workdir`` (default: a temporary directory, deleted afterwards); the
PNGs to ``--out``.  Every figure is made by the command line itself (``ringsim.cli.main``),
so the gallery shows exactly what a user gets.
"""

from __future__ import annotations

import argparse
import json
import shutil
import tempfile
import time
from pathlib import Path

import yaml

import ringsim
from ringsim.cli import main
from ringsim.config.scenario import load_scenario, with_overrides
from ringsim.plots.study import plot_ratios

ROOT = Path(__file__).resolve().parents[1]
SCENARIOS = ROOT / "scenarios"

_ROUGH = {"integration.orbits": 10, "output.snapshot_every": 1.0,
          "friction": {"model": "coulomb", "mu": 0.5}}
_GRAVITY = {"integration.orbits": 3, "integration.until_equilibrium": False,
            "sheet.gravity_solver": "p3m", "output.snapshot_every": 0.5}

#: Gallery runs: name -> (bundled scenario, overrides).  Fewer particles and orbits than
#: the scenarios' own, so that the gallery builds quickly; the physics is the scenario's.
RUNS = {
    "kappa0": ("kappa0.yaml", {"sheet.n_particles": 600, "integration.orbits": 60,
                               "output.snapshot_every": 2.0}),
    "kappa0.1": ("kappa0.1.yaml", {"sheet.n_particles": 600, "integration.orbits": 60,
                                   "output.snapshot_every": 2.0}),
    # a cold, nearly flat ring (H ~ r): constant epsilon below the critical value
    "cold": ("constant-eps-0.5.yaml", {"name": "cold-eps0.5", "sheet.n_particles": 300,
                                       "integration.orbits": 50,
                                       "integration.collision_detection": "line",
                                       "output.snapshot_every": 1.0}),
    # a two-species mixture: per-size points at the species' radii
    "mixture": ("quickstart.yaml", {
        "name": "mixture", "integration.orbits": 10, "output.snapshot_every": 1.0,
        "particles.size_distribution": {"kind": "mixture", "components": [
            {"radius": 0.5, "number_fraction": 0.7}, {"radius": 2.0, "number_fraction": 0.3}]}}),
    # rough spheres (spins.png, compare_spins.png): the quick-start ring with friction
    "rough": ("quickstart.yaml", {"name": "rough", **_ROUGH}),
    "rough-kappa0.1": ("quickstart.yaml", {"name": "rough-kappa0.1", **_ROUGH,
                                           "restitution.kappa": 0.1}),
    # self-gravity (wakes.png, compare_toomre_q.png, compare_wakes.png): a few orbits of the
    # bundled gravitating pair on P3M
    "gravity-kappa0": ("kappa0-gravity.yaml", _GRAVITY),
    "gravity-kappa0.1": ("kappa0.1-gravity.yaml", _GRAVITY),
}

#: The pairs that ``compare`` draws: gallery folder -> the two runs.
COMPARES = {"compare": ("kappa0", "kappa0.1"), "compare-rough": ("rough", "rough-kappa0.1"),
            "compare-gravity": ("gravity-kappa0", "gravity-kappa0.1")}

#: The gallery sweep: kappa x seed on a small kappa0 patch.
SWEEP_BASE = ("kappa0.yaml", {"sheet.n_particles": 300, "integration.orbits": 12,
                              "output.snapshot_every": 4.0})
SWEEP_GRID = {"restitution.kappa": [0.0, 0.05, 0.1], "seed": [1, 2]}


def _cli(*argv: str) -> None:
    print("$ ringsim " + " ".join(argv), flush=True)
    status = main(list(argv))
    if status != 0:
        raise SystemExit(f"ringsim {argv[0]} failed with status {status}")


def _scenario(file: str, overrides: dict):
    return with_overrides(load_scenario(SCENARIOS / file), overrides)


def build(workdir: Path, out: Path, reuse: bool = False) -> list[Path]:
    """Make every gallery run and figure; returns the PNG paths.  With ``reuse``, finished
    run files already in ``workdir`` are kept (redraw the figures only)."""
    out.mkdir(parents=True, exist_ok=True)
    runs = {}
    for key, (file, overrides) in RUNS.items():
        path = workdir / f"{key}.h5"
        if reuse and path.exists() and ringsim.open_run(path).attrs["status"] == "finished":
            runs[key] = path
            continue
        start = time.perf_counter()
        runs[key] = ringsim.run(_scenario(file, overrides), output=workdir / f"{key}.h5",
                                force=True, progress=False)
        print(f"run {key}: {time.perf_counter() - start:.1f} s", flush=True)
    for key, path in runs.items():
        _cli("analyze", str(path), "--plots", str(out / f"analyze-{key}"), "--force")
    for folder, (first, second) in COMPARES.items():
        _cli("compare", str(runs[first]), str(runs[second]), "--plots", str(out / folder),
             "--force")

    base = workdir / "sweep-base.yaml"
    base.write_text(yaml.safe_dump(_scenario(*SWEEP_BASE).to_dict(), sort_keys=False))
    sweep = workdir / "sweep-kappa-small.yaml"
    sweep.write_text(yaml.safe_dump({"base": base.name, "grid": SWEEP_GRID}, sort_keys=False))
    _cli("sweep", str(sweep), "--workers", "1", "--out", str(workdir / "sweep"), "--plots",
         str(out / "sweep"))

    _cli("epsilon", "--plot", str(out / "epsilon.png"), "--force")
    _cli("epsilon", "--restitution", "model=dilley,kappa=0.1", "--radius", "0.5", "1", "5",
         "--plot", str(out / "epsilon-kappa0.1.png"), "--force")
    report = ROOT / "studies" / "kappa-powerlaw" / "study.quick.report" / "report.json"
    plot_ratios(json.loads(report.read_text()), out / "study")
    _cli("fit", str(ROOT / "docs" / "data" / "hatzes_like.csv"), "--model", "all",
         "--plot", str(out / "fit.png"), "--force")
    return sorted(out.rglob("*.png"))


def parse_args(argv=None):
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--workdir", type=Path, help="keep the run files here")
    parser.add_argument("--out", type=Path, default=ROOT / "docs" / "figures" / "gallery")
    parser.add_argument("--reuse", action="store_true", help="keep finished run files of "
                        "--workdir and the sweep's points (redraw the figures only)")
    return parser.parse_args(argv)


if __name__ == "__main__":
    args = parse_args()
    started = time.perf_counter()
    if args.workdir is not None:
        args.workdir.mkdir(parents=True, exist_ok=True)
        pngs = build(args.workdir, args.out, reuse=args.reuse)
    else:
        tmp = Path(tempfile.mkdtemp(prefix="ringsim-gallery-"))
        try:
            pngs = build(tmp, args.out)
        finally:
            shutil.rmtree(tmp)
    print(f"{len(pngs)} figures in {args.out} ({time.perf_counter() - started:.0f} s)")
