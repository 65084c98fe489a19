"""The files ringsim may create, replace and delete, and the outputs it may write.

A run file ``RUN.h5`` owns three names beside it: ``RUN.h5.lock`` (``store.lock``),
``RUN.h5.tmp`` (the copy a commit changes, ``store.runfile``) and the folder
``RUN.h5.parts/`` (``store.bulk``).  ringsim creates, replaces and deletes these four names
and nothing else of a run's, never through a symbolic link: `refuse_links` checks each
with ``lstat`` before a run touches any of them, files are created with ``O_NOFOLLOW``
and ``O_EXCL``, and only part files of ringsim's own names are removed from the folder.
``-o RUN.h5 --force`` replaces only a regular file that is a ringsim run file
(`check_replaceable`), never a scenario, another HDF5 file or a device.

The other outputs (``--json``, ``--csv``, ``--plots``, ``--rebound``, ...) go through
`check_output`: never the same file as an input of the command, never over an existing
file without ``--force``, never below something that is not a folder, and a folder only
where a folder is asked for.

Each refusal is an InputError (exit status 2) naming the file, before anything is written.
"""

from __future__ import annotations

import os
import shutil
import stat
from collections.abc import Iterable, Mapping
from pathlib import Path

from ringsim.errors import InputError

#: The first bytes of every HDF5 file.
HDF5_SIGNATURE = b"\x89HDF\r\n\x1a\n"


def own_files(path: str | os.PathLike) -> dict[str, Path]:
    """The names a run file ``path`` owns: itself, its lock, its temporary copy and its
    part-file folder (``{"run file": RUN.h5, "lock": RUN.h5.lock, ...}``)."""
    path = Path(path)
    return {"run file": path, "lock": path.with_name(path.name + ".lock"),
            "temporary copy": path.with_name(path.name + ".tmp"),
            "part files": path.with_name(path.name + ".parts")}


def _lstat(path: Path) -> os.stat_result | None:
    try:
        return os.lstat(path)
    except FileNotFoundError:
        return None


def refuse_links(path: str | os.PathLike) -> None:
    """InputError if any name the run file ``path`` owns is a symbolic link, or is of the
    wrong kind (a folder where a file belongs, a file where the part-file folder does).
    Nothing is touched."""
    for role, item in own_files(path).items():
        st = _lstat(item)
        if st is None:
            continue
        if stat.S_ISLNK(st.st_mode):
            raise InputError(str(item), role, "is a symbolic link; ringsim creates, replaces "
                             "and deletes its own files only, never through a link: remove "
                             "the link or choose another -o")
        kind = stat.S_ISDIR if role == "part files" else stat.S_ISREG
        if not kind(st.st_mode):
            raise InputError(str(item), role, "is not a "
                             f"{'folder' if role == 'part files' else 'regular file'}; "
                             "ringsim replaces and deletes only its own files")


def is_run_file(path: Path) -> bool:
    """``path`` is an HDF5 file with the root attribute ``scenario_yaml`` of a run file."""
    import h5py

    try:
        with open(path, "rb") as f:
            if f.read(len(HDF5_SIGNATURE)) != HDF5_SIGNATURE:
                return False
        with h5py.File(path, "r") as f:
            return "scenario_yaml" in f.attrs
    except (OSError, RuntimeError, ValueError):
        return False


def check_replaceable(path: str | os.PathLike) -> None:
    """InputError unless ``path`` is absent or a regular file that is a ringsim run file
    (what ``--force`` may replace)."""
    path = Path(path)
    refuse_links(path)
    st = _lstat(path)
    if st is not None and not is_run_file(path):
        raise InputError(str(path), "output", "is not a ringsim run file; --force replaces "
                         "only run files: remove it yourself or choose another -o")


def create_new(path: Path, copy_of: Path | None = None) -> None:
    """Create ``path`` as a new file, empty or a copy of ``copy_of``, never through a link:
    a leftover regular file of that name is removed first, a link or any other kind is
    refused (InputError)."""
    st = _lstat(path)
    if st is not None:
        if not stat.S_ISREG(st.st_mode):
            raise InputError(str(path), "temporary copy", "is a symbolic link or not a "
                             "regular file; ringsim writes its own files only")
        path.unlink()
    fd_out = os.open(path, os.O_WRONLY | os.O_CREAT | os.O_EXCL | os.O_NOFOLLOW, 0o644)
    with os.fdopen(fd_out, "wb") as dst:
        if copy_of is not None:
            with open(os.open(copy_of, os.O_RDONLY | os.O_NOFOLLOW), "rb") as src:
                shutil.copyfileobj(src, dst, 1 << 20)


def folder_of_parts(folder: Path) -> bool:
    """``folder`` exists as a real folder (not a link); InputError for a link in its
    place."""
    st = _lstat(folder)
    if st is None:
        return False
    if not stat.S_ISDIR(st.st_mode):
        raise InputError(str(folder), "part files", "is a symbolic link or not a folder; "
                         "ringsim deletes only its own part files")
    return True


def _same(a: Path, b: Path) -> bool:
    try:
        return os.path.samefile(a, b)
    except OSError:
        return False


def _blocking_parent(path: Path) -> Path | None:
    """The nearest existing ancestor of ``path`` if it is not a folder, else None."""
    for parent in path.parents:
        if os.path.lexists(parent):
            return None if parent.is_dir() else parent
    return None


def check_output(path: str | os.PathLike, option: str, inputs: Iterable[str | os.PathLike],
                 force: bool, folder: bool = False) -> None:
    """InputError (exit status 2) unless ringsim may write the output ``path`` of command-
    line ``option``: not the same file as any of ``inputs`` (same inode, whatever the
    name), and, when it exists, replaced only with ``force``.  ``folder`` outputs
    (``--plots DIR``) must be folders when they exist, and one that holds figures (PNG
    files) already is written into only with ``force``."""
    path = Path(path)
    for source in inputs:
        if _same(path, Path(source)):
            raise InputError(str(path), option, f"is an input of this command ({source}); "
                             "ringsim never writes over its input: choose another file")
    blocking = _blocking_parent(path)
    if blocking is not None:
        raise InputError(str(path), option, f"{blocking} is not a folder")
    if not os.path.lexists(path):
        return
    if folder:
        if not path.is_dir():
            raise InputError(str(path), option, "exists and is not a folder: give a "
                             "folder for the figures")
        if not force and any(path.glob("*.png")):
            raise InputError(str(path), option, "holds figures already; replace them with "
                             "--force, or give another folder")
        return
    if path.is_dir():
        raise InputError(str(path), option, "is a folder: give a file name")
    if not force:
        raise InputError(str(path), option, "exists; overwrite it with --force")


def check_outputs(outputs: Mapping[str, str | None], inputs: Iterable[str | os.PathLike],
                  force: bool) -> None:
    """`check_output` for each given output of a command (option -> path or None); a
    ``--plots`` output is a folder.  Called before the command does any work."""
    inputs = [source for source in inputs if source]
    for option, path in outputs.items():
        if path:
            check_output(path, option, inputs, force, folder=option == "--plots")
