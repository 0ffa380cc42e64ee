"""PTS, XYZ and TXT point columns through pyarrow's CSV reader, pandas and numpy as strict fallbacks.

Layouts seen in the wild: ``x y z [intensity r g b ...]`` separated by blanks,
commas or semicolons; an optional header line of names (CloudCompare's
``//X,Y,Z``), an optional first line holding the point count (Leica and
Metashape ``.pts``; open3d reads it as a point), ``#`` comments.

``pyarrow.csv.read_csv`` parses on every core and reads a single-character
delimiter (one blank, a comma, a semicolon) about twice as fast as
``pandas.read_csv`` (C engine), which is itself 3-5 times faster than
``numpy.loadtxt``; all three read the same bits. What pyarrow does not read
cleanly (runs of blanks or tabs, an empty field, a ``#`` comment) goes to
pandas; what pandas does not (a short row, a word, ``nan``, a ``//``
comment below the header) goes to ``numpy.loadtxt``, which reads it or
names the row that is wrong.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from airmat.errors import InputError
from calib.scan_readers.raw import RawCloud

__all__ = ["read", "read_columns_fast"]

#: lines looked at for a header before the first row of coordinates
_MAX_HEADER = 20


def read(path: Path, *, scan_index=None) -> RawCloud:
    """The first three columns of every data row, float64, in the file's unit."""
    try:
        with open(path, "rb") as fh:
            head = fh.read(1 << 14).decode("utf-8", errors="replace").splitlines()[:_MAX_HEADER + 1]
            skip, delimiter = _layout(head, path)
            fh.seek(0)
            xyz = read_columns_fast(fh, skip, delimiter)
            if xyz is None:
                fh.seek(0)
                xyz = np.loadtxt(fh, delimiter=delimiter, usecols=(0, 1, 2), skiprows=skip,
                                 comments=("#", "//"), dtype=float, ndmin=2)
    except OSError as err:
        raise InputError(f"cannot read: {err.strerror or err}", path=path) from None
    except ValueError as err:  # a row that is not numbers, or too few columns
        raise InputError(f"cannot parse {path.suffix[1:].upper()} columns: {err}", path=path) from None
    return RawCloud(vertices=xyz)


def read_columns_fast(fh, skip: int, delimiter: str | None, usecols=(0, 1, 2), *,
                      nan: bool = False) -> np.ndarray | None:
    """Columns ``usecols`` (in file order) of the rows after ``skip`` lines, float64, or None if neither
    pyarrow nor pandas reads them all.

    Strict: empty fields, words and (unless ``nan``) ``nan`` make it return
    None (the caller falls back to a slower reader), never a silently filled
    value.
    """
    out = _read_arrow(fh, skip, delimiter, usecols, nan=nan)
    if out is not None:
        return out
    fh.seek(0)
    import pandas as pd

    na = dict(keep_default_na=False, na_values=["nan", "NaN", "-nan"]) if nan else dict(na_filter=False)
    try:
        table = pd.read_csv(fh, sep=delimiter or r"\s+", header=None, skiprows=skip, usecols=list(usecols),
                            comment="#", engine="c", dtype=float, **na)
    except (ValueError, IndexError, pd.errors.ParserError, pd.errors.EmptyDataError):
        return None
    out = table.to_numpy(dtype=float)
    return out if out.ndim == 2 and out.shape[1] == len(usecols) and len(out) else None


def _read_arrow(fh, skip: int, delimiter: str | None, usecols, *, nan: bool) -> np.ndarray | None:
    """Columns ``usecols`` by pyarrow's multi-threaded CSV reader (one-character delimiter), or None.

    No value counts as missing: an empty field or a word fails the float
    conversion (None); ``nan`` parses as NaN and is refused unless ``nan``.
    """
    import pyarrow as pa
    import pyarrow.csv as pv

    names = [f"f{i}" for i in sorted(usecols)]  # in file order, as pandas returns them
    try:
        table = pv.read_csv(
            fh, read_options=pv.ReadOptions(skip_rows=skip, autogenerate_column_names=True),
            parse_options=pv.ParseOptions(delimiter=delimiter or " ", quote_char=False),
            convert_options=pv.ConvertOptions(include_columns=names, column_types=dict.fromkeys(names, pa.float64()),
                                              null_values=[], strings_can_be_null=False))
    except (pa.ArrowException, ValueError, KeyError):
        return None
    if table.num_rows == 0 or table.num_columns != len(names):
        return None
    out = np.column_stack([table.column(name).to_numpy() for name in names])
    return out if nan or not np.isnan(out).any() else None


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
