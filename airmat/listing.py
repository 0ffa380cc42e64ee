"""The "wrote ... to DIR" line of every command: the files a run published, read from its folder."""

from __future__ import annotations

import os
from collections.abc import Iterable
from pathlib import Path

__all__ = ["listed"]


def listed(folder: str | os.PathLike, first: Iterable[str] = ()) -> str:
    """The files a run published in ``folder``, as the list of its "wrote ... to DIR" line.

    The names in ``first`` that are there come first, in that order, then the others
    sorted; a sub-folder ends with ``/``. Read from the folder, so the line names what the
    run wrote, options included (e.g. ``design --pdf A4``).
    """
    names = {p.name + ("/" if p.is_dir() else "") for p in Path(folder).iterdir()}
    lead = [n for n in first if n in names]
    return ", ".join(lead + sorted(names.difference(lead)))
