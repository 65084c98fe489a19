"""Where a command writes its outputs: checked before it does any work.

``--json``, ``--csv``, ``--rebound``, ``--plot`` and ``--write-restitution`` name a file;
``--plots`` names a folder.  A file target that is an existing folder, a folder target
that is an existing file, or a target below something that is not a folder, is bad input
(exit status 2, one line naming the option), refused before anything is computed or
written, so that a mistyped target never leaves half of a command's outputs behind.
"""

from __future__ import annotations

import os
from pathlib import Path

from ringsim.errors import InputError


def _blocking_parent(path: Path) -> Path | None:
    """The nearest existing ancestor of ``path`` if it is not a folder, else None."""
    for parent in path.parents:
        if os.path.lexists(parent):
            return None if parent.is_dir() else parent
    return None


def check_file_target(path: str | os.PathLike | None, option: str) -> None:
    """Refuse a file target that is a folder or lies below a non-folder (None: no target)."""
    if path is None:
        return
    target = Path(path)
    if target.is_dir():
        raise InputError(str(path), option, "is a folder; give a file name")
    blocking = _blocking_parent(target)
    if blocking is not None:
        raise InputError(str(path), option, f"{blocking} is not a folder")


def check_folder_target(path: str | os.PathLike | None, option: str) -> None:
    """Refuse a folder target that is an existing non-folder or lies below a non-folder
    (None: no target)."""
    if path is None:
        return
    target = Path(path)
    if os.path.lexists(target) and not target.is_dir():
        raise InputError(str(path), option, "exists and is not a folder; give a folder")
    blocking = _blocking_parent(target)
    if blocking is not None:
        raise InputError(str(path), option, f"{blocking} is not a folder")
