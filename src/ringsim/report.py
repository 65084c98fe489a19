"""Markdown reports: replace one ``## section`` of a document, leaving the others untouched.

Used by the scripts in ``benchmarks/`` that write their measured figures
into ``docs/*.md``, where several scripts share one file.
"""

from __future__ import annotations

import re
from pathlib import Path

#: Starts the line that ends the part of a section a script writes; the text after it is
#: kept (``<!-- end of the part benchmarks/X.py writes; the text below is kept -->``).
KEPT_MARKER = "<!-- end of the part "


def replace_section(path: str | Path, heading: str, text: str, title: str) -> None:
    """Put ``text`` (which starts with ``heading``) in place of that section of ``path``.

    The section runs from its heading line (``heading`` as a whole line: a longer heading
    that starts with it is another section) to the next ``## `` heading or the end, or to
    a line `KEPT_MARKER` ``...`` ``-->`` inside it, after which the hand-written rest of the
    section (its ``###`` subsections) is kept; ``text`` then ends with its own such line.
    A missing section is appended; a missing file is created with ``# title``.
    """
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    old = path.read_text() if path.exists() else f"# {title}\n"
    found = re.search(rf"^{re.escape(heading)}$", old, flags=re.MULTILINE)
    if found is not None:
        head, rest = old[:found.start()], old[found.start():]
        following = rest.find("\n## ")
        section = rest if following < 0 else rest[:following + 1]
        marker = section.find("\n" + KEPT_MARKER)
        if marker >= 0:
            following = section.find("\n", marker + 1)
        tail = rest[following + 1:].lstrip("\n") if following >= 0 else ""
        new = head + text.rstrip() + "\n" + ("\n" + tail if tail else "")
    else:
        new = old.rstrip() + "\n\n" + text.rstrip() + "\n"
    path.write_text(new)
