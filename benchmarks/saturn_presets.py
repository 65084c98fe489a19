"""The Saturn presets' step: cost per particle-step with and without self-gravity.

Each preset of ``scenarios/saturn-*-ring.yaml`` (its own particles, friction, law and line
detection, one thread) is built and stepped from its initial state: ``--steps`` steps after
two warm-up steps without self-gravity (the baseline, the same sheet in the same process),
then as the preset runs it (P3M with its field-only particles).  CPU time per
particle-step, the ratio, and what an orbit costs at dt = 1e-3 orbit.  The initial state is
cooler and thinner than an equilibrium; the figures are the set-up's, not the
equilibrium's.  With ``--write-doc`` the table replaces the section "## The Saturn presets"
of docs/performance.md.

Usage: python benchmarks/saturn_presets.py [--presets a b c] [--steps 5] [--write-doc]
"""

from __future__ import annotations

import argparse
import platform
import time
from datetime import datetime, timezone

from ringsim.config.scenario import load_scenario, scenario_from_dict, with_overrides
from ringsim.engine.sheet import build_sheet
from ringsim.report import replace_section

STEPS_PER_ORBIT = 1000    # dt = 1e-3 orbit, the presets' dt: auto in line mode


def cost(path: str, gravity: bool, steps: int) -> tuple[float, int]:
    """CPU seconds per particle-step of the preset at ``path`` and its particle count."""
    sc = load_scenario(path)
    if not gravity:
        d = sc.to_dict()
        d["sheet"] = {k: v for k, v in d["sheet"].items()
                      if k not in ("gravity_solver", "softening", "p3m_split",
                                   "p3m_pair_min_radius")}
        d["sheet"]["gravity"] = False
        sc = scenario_from_dict(d, source=path)
    sc = with_overrides(sc, {"integration.threads": 1})
    sim = build_sheet(sc).sim
    sim.steps(2)
    t0 = time.process_time()
    sim.steps(steps)
    return (time.process_time() - t0) / steps / sim.N, sim.N


def table(presets: list[str], steps: int) -> str:
    rows = []
    for name in presets:
        path = f"scenarios/saturn-{name}-ring.yaml"
        base, n = cost(path, False, steps)
        grav, _ = cost(path, True, steps)
        rows.append(f"| {name.upper()} ring | {n} | {base * 1e9:.0f} | {grav * 1e9:.0f} | "
                    f"{grav / base:.2f} | {grav * n * STEPS_PER_ORBIT / 60:.1f} |")
    when = datetime.now(timezone.utc).strftime("%Y-%m-%d %H:%M UTC")
    head = (f"## The Saturn presets\n\n`python benchmarks/saturn_presets.py --steps {steps} "
            f"--write-doc`, {when}, {platform.machine()} {platform.system()}, one thread, "
            "CPU times (the machine shared).  Each preset from its initial state (cooler "
            "and thinner than its equilibrium): the step without self-gravity (the baseline, "
            "same sheet, same process) and as the preset runs (P3M, field-only particles "
            "below `sheet.p3m_pair_min_radius`).\n\n"
            "| preset | particles | no gravity [ns per particle-step] | with gravity [ns] "
            "| gravity / no gravity | CPU-minutes per orbit |\n|---|---|---|---|---|---|\n")
    return head + "\n".join(rows) + "\n"


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--presets", nargs="+", default=["a", "b", "c"])
    parser.add_argument("--steps", type=int, default=5)
    parser.add_argument("--write-doc", action="store_true")
    args = parser.parse_args()
    text = table(args.presets, args.steps)
    print(text)
    if args.write_doc:
        replace_section("docs/performance.md", "## The Saturn presets", text, "Performance")


if __name__ == "__main__":
    main()
