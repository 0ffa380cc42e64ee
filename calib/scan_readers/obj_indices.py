"""OBJ relative face indices that trimesh reads wrongly, refused with what to do.

An OBJ face may name its corners relative to the vertices read so far
(``f -3 -2 -1``: the last three). trimesh resolves them against all the
file's vertices, which is right only when every vertex comes before the first
face; a file that lists more vertices after a face (one object after another,
each with relative indices) comes out silently wrong (vertices dropped, faces
repeated). Absolute indices are read right in any layout.
"""

from __future__ import annotations

import re
from pathlib import Path

from airmat.errors import InputError

__all__ = ["check_obj_indices"]

_FACE = re.compile(rb"(?m)^[ \t]*f[ \t]")
_VERTEX = re.compile(rb"(?m)^[ \t]*v[ \t]")
_RELATIVE = re.compile(rb"(?m)^[ \t]*f[ \t][^\n]*?(?<=[ \t])-\d")


def check_obj_indices(path) -> None:
    """Raise :class:`airmat.errors.InputError` for an OBJ whose relative face indices trimesh misreads.

    Parameters
    ----------
    path : str or Path
        An OBJ file.
    """
    path = Path(path)
    text = path.read_bytes()
    first_face = _FACE.search(text)
    if first_face is None or _RELATIVE.search(text) is None:
        return
    if _VERTEX.search(text, first_face.start()) is not None:
        raise InputError("the OBJ's faces use relative (negative) vertex indices with vertices listed after "
                         "faces, which the OBJ reader (trimesh) resolves wrongly: export it with absolute "
                         "indices", path=path)
