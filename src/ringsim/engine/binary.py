"""REBOUND simulations to and from the bytes a checkpoint stores.

REBOUND 5.2.2 writes and reads its binaries through files only; these two functions go
through a temporary file.  Function pointers (the resolver, the sheet detector, the
ghost-box field) are not saved by REBOUND: the run loop installs them again.
"""

from __future__ import annotations

import os
import tempfile
import warnings
from pathlib import Path

import rebound

from ringsim.engine import native
from ringsim.store import runfile


def simulation_binary(sim: rebound.Simulation) -> bytes:
    """REBOUND's binary of ``sim`` (``save_to_file``) as bytes, for the checkpoint."""
    fd, name = tempfile.mkstemp(suffix=".bin")
    os.close(fd)
    try:
        with native.rebound_sei(sim):     # the file names REBOUND's SEI (same bits)
            sim.save_to_file(name, delete_file=True)
        return Path(name).read_bytes()
    finally:
        os.unlink(name)


def simulation_from_binary(binary: bytes, path: Path) -> rebound.Simulation:
    """The simulation of a checkpoint; RunFileError naming ``path`` if it does not load."""
    fd, name = tempfile.mkstemp(suffix=".bin")
    try:
        os.write(fd, binary)
        os.close(fd)
        with warnings.catch_warnings():
            # REBOUND reminds that function pointers are not saved; the caller re-installs
            # the resolver.
            warnings.filterwarnings("ignore", message="You have to reset function pointers")
            try:
                return rebound.Simulation(name)
            except (RuntimeError, ValueError, OSError) as exc:
                raise runfile.RunFileError(path, f"does not load in REBOUND "
                                           f"{rebound.__version__} ({exc})",
                                           "/checkpoint") from None
    finally:
        os.unlink(name)
