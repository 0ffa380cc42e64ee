"""PTS, XYZ and TXT point columns through numpy.

Layouts seen in the wild: ``x y z [intensity r g b ...]`` separated by blanks,
commas or semicolons; an optional header line of names (CloudCompare's
``//X,Y,Z``), an optional first line holding the point count (Leica and
Metashape ``.pts``; open3d reads it as a point), ``#`` comments.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from airmat.errors import InputError
from calib.scan_readers.raw import RawCloud

__all__ = ["read"]

#: lines looked at for a header before the first row of coordinates
_MAX_HEADER = 20


def read(path: Path, *, scan_index=None) -> RawCloud:
    """The first three columns of every data row, float64, in the file's unit."""
    try:
        with open(path, "rb") as fh:
            head = fh.read(1 << 14).decode("utf-8", errors="replace").splitlines()[:_MAX_HEADER + 1]
            skip, delimiter = _layout(head, path)
            fh.seek(0)
            xyz = np.loadtxt(fh, delimiter=delimiter, usecols=(0, 1, 2), skiprows=skip,
                             comments=("#", "//"), dtype=float, ndmin=2)
    except OSError as err:
        raise InputError(f"cannot read: {err.strerror or err}", path=path) from None
    except ValueError as err:  # a row that is not numbers, or too few columns
        raise InputError(f"cannot parse {path.suffix[1:].upper()} columns: {err}", path=path) from None
    return RawCloud(vertices=xyz)


def _layout(lines: list[str], path: Path):
    """(lines to skip, delimiter) from the file's first lines."""
    for i, line in enumerate(lines):
        text = line.strip()
        if not text or text.startswith(("#", "//")):
            continue
        delimiter = "," if "," in text else ";" if ";" in text else None
        tokens = [t for t in text.replace(",", " ").replace(";", " ").split()]
        if len(tokens) >= 3 and all(_is_number(t) for t in tokens[:3]):
            return i, delimiter
        if len(tokens) == 1 and tokens[0].isdigit():
            continue  # a point count line
        if any(_is_number(t) for t in tokens[:3]):
            break
    raise InputError("no rows of x y z numbers found in the first lines", path=path)


def _is_number(token: str) -> bool:
    try:
        float(token)
    except ValueError:
        return False
    return True
