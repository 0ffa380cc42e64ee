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

from dataclasses import dataclass
from pathlib import Path

import numpy as np

from airmat.errors import InputError
from airmat.calib.scan_readers.raw import RawCloud

__all__ = ["read", "read_columns_fast"]

#: lines looked at for a header before the first row of coordinates
_MAX_HEADER = 20


def read(path: Path, *, scan_index=None) -> RawCloud:
    """The x, y, z columns of every data row, float64, in the file's unit.

    The columns are the first three, or those a header names ``x y z`` (``ID,X,Y,Z,...``).
    A Leica PTS may hold several blocks, each after a line with its point count.
    """
    try:
        with open(path, "rb") as fh:
            head = fh.read(1 << 14).decode("utf-8", errors="replace").splitlines()[:_MAX_HEADER + 1]
        layout = _layout(head, path)
        xyz = None if layout.decimal_comma else \
            read_columns_fast(path, layout.skip, layout.delimiter, layout.width, layout.usecols)
        if xyz is None:
            xyz = _read_slow(path, layout)
    except OSError as err:
        raise InputError(f"cannot read: {err.strerror or err}", path=path) from None
    except ValueError as err:  # a row that is not numbers, or too few columns
        raise InputError(f"cannot parse {path.suffix[1:].upper()} columns: {err}", path=path) from None
    return RawCloud(vertices=xyz)


@dataclass(frozen=True)
class _Layout:
    skip: int                     #: lines before the first data row
    delimiter: str | None         #: one character; None for blanks
    width: int                    #: fields in the first data row
    usecols: tuple = (0, 1, 2)    #: the x, y, z columns
    decimal_comma: bool = False   #: "1,5;2,5;3,5": semicolon-separated with decimal commas


def _read_slow(path: Path, layout: _Layout) -> np.ndarray:
    """numpy's strict reader, on the rows between point-count lines (PTS blocks) with decimal commas
    made points: it reads the file or names the row that is wrong."""
    text = path.read_bytes().decode("utf-8", errors="replace")
    lines = text.splitlines()[layout.skip:]
    counts = [(i, ln) for i, ln in enumerate(lines) if ln.strip().isdigit()]
    if counts:   # a PTS of several blocks: each count line says how many rows follow it
        _check_blocks(counts, lines, layout.skip, path)
        drop = {i for i, _ in counts}
        lines = [ln for i, ln in enumerate(lines) if i not in drop]
    if layout.decimal_comma:
        lines = [ln.replace(",", ".") for ln in lines]
    delimiter = layout.delimiter if layout.delimiter != "\t" else None
    return np.loadtxt(lines, delimiter=delimiter, usecols=layout.usecols, comments=("#", "//"), dtype=float,
                      ndmin=2)


def _check_blocks(counts, lines, skip, path) -> None:
    """Each PTS block holds the rows its count line declares (the last one: up to the end)."""
    ends = [i for i, _ in counts[1:]] + [len(lines)]
    for (i, line), end in zip(counts, ends):
        rows = sum(1 for ln in lines[i + 1:end] if ln.strip() and not ln.lstrip().startswith(("#", "//")))
        if rows != int(line):
            raise InputError(f"the block of points counted on line {skip + i + 1} declares {int(line)} points, "
                             f"holds {rows} (a block cut short, or a number on a line of its own?)", path=path)


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


def _layout(lines: list[str], path: Path) -> _Layout:
    """How the file's first lines lay out the data: lines to skip, delimiter, width, x y z columns."""
    names = None
    for i, line in enumerate(lines):
        text = line.strip()
        if not text:
            continue
        delimiter = _delimiter(text)
        comma = delimiter in (";", "\t") and "," in text   # "1,5;2,5;3,5": decimal commas
        tokens = [t.replace(",", ".") if comma else t for t in
                  (text.split(delimiter) if delimiter else text.split())]
        tokens = [t.strip() for t in tokens if t.strip()] if delimiter else tokens
        if len(tokens) >= 3 and all(_is_number(t) for t in tokens[:3]) and not text.startswith(("#", "//")):
            usecols = _xyz_columns(names, delimiter) if names else (0, 1, 2)
            if max(usecols) >= len(tokens):
                usecols = (0, 1, 2)
            return _Layout(i, delimiter, len(line.split(delimiter or " ")), usecols, comma)
        if len(tokens) == 1 and tokens[0].isdigit():
            continue  # a point count line
        if not text.startswith("#") or text.startswith("//"):
            if any(_is_number(t) for t in tokens[:3]) and not text.startswith("//"):
                break
            names = text.lstrip("/#").strip()   # a header of column names (CloudCompare's "//X,Y,Z")
    raise InputError("no rows of x y z numbers found in the first lines", path=path)


def _delimiter(text: str) -> str | None:
    """The row's delimiter: a semicolon, a tab (without blanks), a comma; None for blanks."""
    if ";" in text:
        return ";"
    if "\t" in text and " " not in text.strip():
        return "\t"
    return "," if "," in text else None


#: column names of x, y, z in a header (any case)
_XYZ_NAMES = (("x", "//x", "east", "easting"), ("y", "north", "northing"), ("z", "height", "elevation"))


def _xyz_columns(header: str, delimiter: str | None) -> tuple:
    """The indices of the x, y, z columns a header line names; (0, 1, 2) when it does not name all three."""
    words = [w.strip().strip('"').lower() for w in (header.split(delimiter) if delimiter else header.split())]
    found = [next((k for k, w in enumerate(words) if w in names), None) for names in _XYZ_NAMES]
    return tuple(found) if None not in found and len(set(found)) == 3 else (0, 1, 2)


def _is_number(token: str) -> bool:
    try:
        float(token)
    except ValueError:
        return False
    return True
