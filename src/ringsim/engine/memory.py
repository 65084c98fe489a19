"""The memory a run needs, checked before anything is allocated.

A sheet of N particles holds REBOUND's particles, the collision search's grids, the
resolver's arrays, a snapshot's arrays, a checkpoint's binary copy and the file's write
buffers.  `BYTES_PER_PARTICLE` bounds all of them together; a scenario whose particles need
more than the machine's physical memory is bad input (exit status 2), refused in one line
naming ``sheet.n_particles`` before REBOUND or numpy allocates anything for it.
"""

from __future__ import annotations

import os

from ringsim.errors import InputError

#: Memory a run needs per particle [bytes], everything together: about five times the
#: growth of a run's peak resident memory from 2 000 to 100 000 particles
#: (docs/performance.md, "Memory").
BYTES_PER_PARTICLE = 4096


def physical_memory() -> int | None:
    """The machine's physical memory [bytes], or None where the system does not say."""
    try:
        pages, size = os.sysconf("SC_PHYS_PAGES"), os.sysconf("SC_PAGE_SIZE")
    except (ValueError, OSError, AttributeError):
        return None
    return pages * size if pages > 0 and size > 0 else None


def check_particle_memory(scenario, available: int | None = None) -> None:
    """Refuse a scenario whose ``sheet.n_particles`` need more than ``available`` bytes
    (default: the physical memory) with `InputError` naming the key.

    A start from a file (``sheet.initial_state``) takes its count from the file, whose
    arrays are checked when they are read.
    """
    if scenario.sheet.initial_state is not None:
        return
    available = physical_memory() if available is None else available
    n = scenario.sheet.n_particles
    need = n * BYTES_PER_PARTICLE
    if available is not None and need > available:
        raise InputError(scenario.source, "sheet.n_particles",
                         f"{n} particles need about {need / 2**30:.3g} GiB "
                         f"({BYTES_PER_PARTICLE} bytes each), more than this machine's "
                         f"{available / 2**30:.3g} GiB of memory")
