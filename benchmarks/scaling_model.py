"""Cost model of one shearing sheet of 1e7-1e8 particles decomposed over MPI ranks.

Not a measurement: a model fed with the single-machine costs measured by this folder's
scripts (docs/performance.md) and with an assumed cluster network.  It writes the section
"## Estimates" of docs/scaling.md, whose text explains the design the model describes; a
test (tests/test_scaling_model.py) checks that the section is this script's output, so the
page cannot drift from the inputs below.

Each rank is one process on one core with its own REBOUND simulation of its domain (so
REBOUND's serial SEI step is not shared between cores), and per step it:
  * sends the particles within the interaction reach of each face to the neighbour ranks
    and receives theirs (positions and velocities before the collision search and the
    short-range forces; the post-collision state of ghost pairs after resolution);
  * for self-gravity, takes part in the distributed mesh FFT: one transpose per real-to-
    complex transform (density forward; gx, gy, gz back), each moving the rank's share of
    the complex mesh, and in the mesh's halo exchange (one layer of cells a face).

Time per step = the rank's particles times the measured one-core cost per particle-step,
plus latency times messages, plus bytes over bandwidth; the efficiency is the first over
the sum.  Communication is not overlapped with computation (an upper bound on its cost).

Usage: python benchmarks/scaling_model.py [--write-doc]
"""

from __future__ import annotations

import argparse
import math
from dataclasses import dataclass

from ringsim.report import replace_section

DOC = "docs/scaling.md"
HEADING = "## Estimates"

#: Inputs: (value, unit, source).
T_NO_GRAVITY = (238e-9, "s per particle-step",
                "docs/performance.md, Scale: line detection, no gravity, 1 thread, N = 1e6")
T_GRAVITY_NOW = (5.72e-6, "s per particle-step",
                 "docs/performance.md, Where the production step goes: kappa = 0, 2.1 lambda_cr")
T_GRAVITY_TARGET = (0.52e-6, "s per particle-step",
                    "issue 41's target: 2 x the same state's 0.26 us without gravity")
BANDWIDTH = (12.5e9, "B/s", "assumed: InfiniBand HDR100 (100 Gb/s) a node")
LATENCY = (1.5e-6, "s per message", "assumed: typical MPI point-to-point latency")
BYTES_PER_PARTICLE = (96, "B", "8 doubles (position, velocity, mass, radius), 3 of spin, an id")
BYTES_PER_MODE = (16, "B", "one complex double of the mesh's spectrum")
STEPS_PER_ORBIT = (1000, "", "dt = 1e-3 orbit, the production runs' (docs/performance.md)")


@dataclass(frozen=True)
class Sheet:
    """A sheet to decompose.

    Attributes
    ----------
    name : str
    Lx, Ly : float [m]
        Radial and azimuthal box sizes.
    N : float
        Particle count.
    reach : float [m]
        Interaction reach: the collision search's (2 r_max and a margin) or, with gravity,
        the short-range pair sum's cutoff.
    cell : float [m]
        Mesh cell (with gravity).
    layers : int
        Mesh layers (with gravity).
    gravity : bool
    slabs : bool
        Decomposition along x only (True) or in x and y (False).
    """

    name: str
    Lx: float
    Ly: float
    N: float
    reach: float
    cell: float
    layers: int
    gravity: bool
    slabs: bool


#: The sheets: an overstability box of the size of Rein & Latter (2013, MNRAS 431, 145:
#: radial size 1e5 particle radii) with 1 m spheres at tau = 1.5 (9.5e6 particles), without
#: and with gravity; an A-ring wake box of the size-distribution issue's ring (2.5 cm-5 m,
#: q = 3, tau = 0.5: 3.5e5 particles in 2 x 2 lambda_cr, lambda_cr = 60 m) at 20 x 20 and
#: 40 x 40 lambda_cr.  Gravity's reach is the production pair-sum cutoff (5 r_s at r_s =
#: 5.45 m, docs/performance.md); mesh cells of 3 m and 13 layers are the thin-sheet
#: benchmark's (docs/performance.md, Self-gravity), which issue 41's method is to reach.
SHEETS = (
    Sheet("overstability box, no gravity", 1e5, 200.0, 9.5e6, 2.5, 3.0, 13, False, True),
    Sheet("overstability box, gravity", 1e5, 200.0, 9.5e6, 27.0, 3.0, 13, True, True),
    Sheet("A-ring wakes 20x20 lambda_cr", 1200.0, 1200.0, 3.5e7, 27.0, 3.0, 13, True, False),
    Sheet("A-ring wakes 40x40 lambda_cr", 2400.0, 2400.0, 1.4e8, 27.0, 3.0, 13, True, False),
)

RANKS = (16, 64, 256, 1024)


def ghost_particles(sheet: Sheet, ranks: int) -> float:
    """Particles a rank receives from its neighbours in one exchange."""
    density = sheet.N / (sheet.Lx * sheet.Ly)
    w = sheet.reach
    if sheet.slabs:
        return 2.0 * density * sheet.Ly * w
    side_x = sheet.Lx / math.sqrt(ranks)
    side_y = sheet.Ly / math.sqrt(ranks)
    return density * (2.0 * (side_x + side_y) * w + 4.0 * w * w)


def step_time(sheet: Sheet, ranks: int, t_particle: float) -> dict[str, float]:
    """Computation and communication of one step on one rank [s]."""
    compute = sheet.N / ranks * t_particle
    neighbours = 2 if sheet.slabs else 8
    ghost_bytes = 2.0 * ghost_particles(sheet, ranks) * BYTES_PER_PARTICLE[0]
    messages = 2 * neighbours
    mesh_bytes = 0.0
    if sheet.gravity:
        nx, ny = sheet.Lx / sheet.cell, sheet.Ly / sheet.cell
        modes = nx * (ny / 2 + 1) * sheet.layers
        transposes = 4 if sheet.slabs else 8
        mesh_bytes = transposes * modes / ranks * BYTES_PER_MODE[0]
        halo = (2 * ny if sheet.slabs else 2 * (nx + ny) / math.sqrt(ranks)) * sheet.layers
        mesh_bytes += 2 * halo * 8
        messages += transposes * (ranks - 1) + 2 * neighbours
    comm = messages * LATENCY[0] + (ghost_bytes + mesh_bytes) / BANDWIDTH[0]
    return {"compute": compute, "comm": comm, "bytes": ghost_bytes + mesh_bytes}


def table() -> str:
    """The section of docs/scaling.md: inputs and the estimates."""
    lines = [HEADING, "",
             "Written by `python benchmarks/scaling_model.py --write-doc` (a model, not a "
             "measurement; the script's docstring states it).", "",
             "| input | value | unit | source |", "|---|---|---|---|"]
    for label, (value, unit, source) in (
            ("one core, no gravity", T_NO_GRAVITY), ("one core, gravity now", T_GRAVITY_NOW),
            ("one core, gravity at issue 41's target", T_GRAVITY_TARGET),
            ("bandwidth a node", BANDWIDTH), ("latency", LATENCY),
            ("bytes a ghost particle", BYTES_PER_PARTICLE),
            ("bytes a mesh mode", BYTES_PER_MODE), ("steps an orbit", STEPS_PER_ORBIT)):
        lines.append(f"| {label} | {value:.3g} | {unit} | {source} |")
    lines += ["", "| sheet | N | gravity cost | ranks | particles a rank | ghosts a rank "
              "| bytes a step a rank [kB] | compute a step [ms] | communication a step [ms] "
              "| efficiency | wall per 1000 orbits [h] | core-hours per 1000 orbits |",
              "|---|---|---|---|---|---|---|---|---|---|---|---|"]
    for sheet in SHEETS:
        costs = [("-", T_NO_GRAVITY[0])] if not sheet.gravity else [
            ("now", T_GRAVITY_NOW[0]),
            ("target", T_GRAVITY_TARGET[0])]
        for label, t_particle in costs:
            for ranks in RANKS:
                s = step_time(sheet, ranks, t_particle)
                wall = s["compute"] + s["comm"]
                steps = 1000 * STEPS_PER_ORBIT[0]
                lines.append(
                    f"| {sheet.name} | {sheet.N:.2g} | {label} | {ranks} | "
                    f"{sheet.N / ranks:.3g} | {ghost_particles(sheet, ranks):.3g} | "
                    f"{s['bytes'] / 1e3:.4g} | {s['compute'] * 1e3:.4g} | "
                    f"{s['comm'] * 1e3:.3g} | {s['compute'] / wall:.2f} | "
                    f"{wall * steps / 3600:.3g} | {wall * steps * ranks / 3600:.3g} |")
    return "\n".join(lines) + "\n"


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--write-doc", action="store_true", help=f"write the section of {DOC}")
    args = parser.parse_args()
    text = table()
    print(text)
    if args.write_doc:
        replace_section(DOC, HEADING, text, "Beyond one machine")


if __name__ == "__main__":
    main()
