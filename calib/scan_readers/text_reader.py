"""PTS, XYZ and TXT point columns through polars' CSV reader, numpy as the strict fallback.

Layouts seen in the wild: ``x y z [intensity r g b ...]`` separated by blanks,
tabs, commas or semicolons; an optional header line of names (CloudCompare's
``//X,Y,Z``), an optional first line holding the point count (Leica and
Metashape ``.pts``; open3d reads it as a point), ``#`` comments.

``polars.read_csv`` parses on every core with an explicit float64 schema,
converting only the columns needed (the rest of each row is skipped), with
the same bits as ``numpy.loadtxt`` (numpy's C parser, one thread; both round
decimals correctly); the CPU time of a 1M-point read is in ``docs/benchmarks.md``
under ``bench/bench_cylinder.py --formats``. ``#`` comment lines below the
first row get a second polars pass (looking for them costs it half again).
What polars does not read cleanly (runs of blanks, a short row, a word,
``nan`` in a scan, a ``//`` comment below the header, old-Mac line ends) goes
to ``numpy.loadtxt``, which reads it or names the row that is wrong.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from airmat.errors import InputError
from airmat.calib.scan_readers.raw import RawCloud

__all__ = ["read", "read_columns_fast"]

#: lines looked at for a header before the first row of coordinates
_MAX_HEADER = 20


def read(path: Path, *, scan_index=None) -> RawCloud:
    """The first three columns of every data row, float64, in the file's unit."""
    try:
        with open(path, "rb") as fh:
            head = fh.read(1 << 14).decode("utf-8", errors="replace").splitlines()[:_MAX_HEADER + 1]
        skip, delimiter, width = _layout(head, path)
        xyz = read_columns_fast(path, skip, delimiter, width)
        if xyz is None:
            xyz = np.loadtxt(path, delimiter=delimiter if delimiter != "\t" else None, usecols=(0, 1, 2),
                             skiprows=skip, comments=("#", "//"), dtype=float, ndmin=2)
    except OSError as err:
        raise InputError(f"cannot read: {err.strerror or err}", path=path) from None
    except ValueError as err:  # a row that is not numbers, or too few columns
        raise InputError(f"cannot parse {path.suffix[1:].upper()} columns: {err}", path=path) from None
    return RawCloud(vertices=xyz)


def read_columns_fast(path: Path, skip: int, delimiter: str | None, width: int, usecols=(0, 1, 2), *,
                      nan: bool = False) -> np.ndarray | None:
    """Columns ``usecols`` of the rows after ``skip`` lines, float64, C order (columns in ``usecols``
    order), or None if polars does not read them all cleanly.

    Parameters
    ----------
    path : Path
        The text file (polars maps it and parses it on every core).
    skip : int
        Lines before the first data row (header, point count, comments).
    delimiter : str or None
        One character; None for one blank.
    width : int
        Fields in the first data row (longer rows are cut to it).
    usecols : sequence of int
        Column indices to return; further columns of a row are skipped
        unparsed (they may hold anything).
    nan : bool
        Whether ``nan`` is a value (ascii PCD); otherwise it refuses the file.

    Returns
    -------
    ndarray of shape (N, len(usecols)) or None
        Strict: an empty field, a short row, a word, or (unless ``nan``)
        ``nan`` gives None (the caller falls back to ``numpy.loadtxt``), never
        a silently filled value. Blank lines are skipped, as loadtxt does.
    """
    import polars as pl

    names = [f"f{i}" for i in range(max(width, max(usecols) + 1))]
    table = None
    # "#" comment lines below the header: a second pass
    for comment in (None, "#"):
        try:
            table = pl.read_csv(path, has_header=False, skip_lines=skip, separator=delimiter or " ",
                                quote_char=None, comment_prefix=comment, schema=dict.fromkeys(names, pl.Float64),
                                columns=sorted(set(usecols)), truncate_ragged_lines=True)
            break
        except (pl.exceptions.PolarsError, ValueError, OSError):
            continue
    if table is None:
        return None
    if table.null_count().sum_horizontal().item():
        # a blank line is a row of nulls; any other null is an empty field or a short row
        table = table.filter(~pl.all_horizontal(pl.all().is_null()))
        if table.null_count().sum_horizontal().item():
            return None
    if table.height == 0:
        return None
    out = table.select([f"f{col}" for col in usecols]).to_numpy(order="c")
    if not nan and np.isnan(out).any():
        return None
    return out


def _layout(lines: list[str], path: Path):
    """(lines to skip, delimiter, fields in the first data row) from the file's first lines."""
    for i, line in enumerate(lines):
        text = line.strip()
        if not text or text.startswith(("#", "//")):
            continue
        delimiter = "," if "," in text else ";" if ";" in text else \
            "\t" if "\t" in text and " " not in text else None
        tokens = [t for t in text.replace(",", " ").replace(";", " ").split()]
        if len(tokens) >= 3 and all(_is_number(t) for t in tokens[:3]):
            return i, delimiter, len(line.split(delimiter or " "))
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
