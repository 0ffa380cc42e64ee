"""Write point clouds as PLY in every common encoding (ascii, binary little/big endian).

trimesh and open3d write only ascii and little-endian PLY (open3d always in
double), so this small writer builds the vertex element as a numpy structured
array and dumps it in one call: float32 or float64 coordinates, optional
``red green blue`` colours and extra scalar properties such as a scanner's
``confidence``. Coordinates are written as given (the caller picks the file
unit, normally millimetres). The file is written atomically.
"""

from __future__ import annotations

import io
import os

import numpy as np

from airmat.atomic import atomic_write_bytes
from airmat.errors import InputError

__all__ = ["write_ply", "ENCODINGS"]

#: PLY encodings this writer produces
ENCODINGS = ("ascii", "binary_little_endian", "binary_big_endian")

#: numpy dtype kind+size -> PLY scalar type name
_PLY_TYPES = {
    ("f", 4): "float", ("f", 8): "double",
    ("i", 1): "char", ("i", 2): "short", ("i", 4): "int",
    ("u", 1): "uchar", ("u", 2): "ushort", ("u", 4): "uint",
}
#: printf formats that round-trip each kind in ascii
_ASCII_FMT = {"f4": "%.9g", "f8": "%.17g"}


def _ply_type(dtype: np.dtype, name: str) -> str:
    key = (dtype.kind, dtype.itemsize)
    if key not in _PLY_TYPES:
        raise InputError(f"PLY property {name!r}: dtype {dtype} has no PLY type "
                         f"(use float32/float64 or an 8/16/32-bit integer)")
    return _PLY_TYPES[key]


def _vertex_table(points, colors, extra, dtype) -> np.ndarray:
    """Structured (N,) array of the vertex element, native byte order."""
    pts = np.asarray(points, dtype=dtype)
    if pts.ndim != 2 or pts.shape[1] != 3:
        raise InputError(f"points must have shape (N, 3), got {pts.shape}")
    n = len(pts)
    fields = [("x", pts.dtype), ("y", pts.dtype), ("z", pts.dtype)]
    columns = [pts[:, 0], pts[:, 1], pts[:, 2]]
    if colors is not None:
        col = np.asarray(colors)
        if col.shape != (n, 3):
            raise InputError(f"colors must have shape ({n}, 3), got {col.shape}")
        if col.dtype.kind == "f":  # floats in [0, 1] -> 0..255
            col = np.clip(np.rint(col * 255.0), 0, 255)
        col = col.astype(np.uint8)
        fields += [("red", np.uint8), ("green", np.uint8), ("blue", np.uint8)]
        columns += [col[:, 0], col[:, 1], col[:, 2]]
    for name, values in (extra or {}).items():
        values = np.asarray(values)
        if values.shape != (n,):
            raise InputError(f"extra property {name!r} must have shape ({n},), got {values.shape}")
        if values.dtype.kind == "b":
            values = values.astype(np.uint8)
        elif values.dtype.kind == "i" and values.dtype.itemsize == 8:
            values = values.astype(np.int32)
        elif values.dtype.kind == "u" and values.dtype.itemsize == 8:
            values = values.astype(np.uint32)
        _ply_type(values.dtype, name)
        fields.append((str(name), values.dtype))
        columns.append(values)
    table = np.empty(n, dtype=fields)
    for (name, _), col in zip(fields, columns):
        table[name] = col
    return table


def _header(table: np.ndarray, encoding: str) -> bytes:
    lines = ["ply", f"format {encoding} 1.0", "comment written by airmat (airmat.synthetic.ply_write)",
             f"element vertex {len(table)}"]
    for name in table.dtype.names:
        lines.append(f"property {_ply_type(table.dtype[name], name)} {name}")
    lines.append("end_header")
    return ("\n".join(lines) + "\n").encode("ascii")


def _ascii_body(table: np.ndarray) -> bytes:
    fmt = [_ASCII_FMT.get(table.dtype[name].str[1:], "%d") for name in table.dtype.names]
    buf = io.StringIO()
    np.savetxt(buf, table, fmt=" ".join(fmt))
    return buf.getvalue().encode("ascii")


def write_ply(path: str | os.PathLike, points, *, encoding: str = "binary_little_endian",
              dtype: str = "float32", colors=None, extra: dict | None = None) -> None:
    """Write a point cloud as a PLY file.

    Parameters
    ----------
    path : path
        Output file; written atomically (a temporary file renamed into place).
    points : array_like of shape (N, 3)
        Coordinates, written as given (no unit conversion; airmat files use mm).
    encoding : {"ascii", "binary_little_endian", "binary_big_endian"}
        PLY encoding.
    dtype : {"float32", "float64"}
        Scalar type of the coordinates (PLY ``float`` or ``double``).
    colors : array_like of shape (N, 3), optional
        ``red green blue``: uint8, or floats in [0, 1].
    extra : dict of str -> array_like of shape (N,), optional
        Further vertex properties (e.g. ``{"confidence": c}``), each written
        with its own dtype (float32/float64/8-32 bit integers).

    Raises
    ------
    airmat.errors.InputError
        For an unknown encoding or dtype, or arrays of the wrong shape.

    Examples
    --------
    >>> import pathlib, tempfile
    >>> with tempfile.TemporaryDirectory() as d:
    ...     p = pathlib.Path(d) / "a.ply"
    ...     write_ply(p, np.eye(3), encoding="binary_big_endian", dtype="float64")
    ...     p.read_bytes().split(b"\\n")[1]
    b'format binary_big_endian 1.0'
    """
    if encoding not in ENCODINGS:
        raise InputError(f"unknown PLY encoding {encoding!r}; use one of {', '.join(ENCODINGS)}", path=path)
    if str(np.dtype(dtype)) not in ("float32", "float64"):
        raise InputError(f"PLY coordinates must be float32 or float64, got {dtype!r}", path=path)
    table = _vertex_table(points, colors, extra, np.dtype(dtype))
    if encoding == "ascii":
        body = _ascii_body(table)
    else:
        order = "<" if encoding == "binary_little_endian" else ">"
        body = table.astype(table.dtype.newbyteorder(order)).tobytes()
    atomic_write_bytes(path, _header(table, encoding) + body)
