"""PCD (PCL's format: ascii, binary, binary_compressed; organized clouds with NaN).

An ascii PCD is read with polars' CSV reader
(:func:`airmat.calib.scan_readers.text_reader.read_columns_fast`, several times
faster than open3d's), a binary one with ``np.fromfile`` and a structured
dtype built from the header (FIELDS, SIZE, TYPE, COUNT), a binary_compressed
one by python-lzf (liblzf; the optional ``fast`` extra) and numpy: its body
is one LZF block holding each field's column in turn. open3d reads what
those refuse, and compressed bodies when python-lzf is not installed.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from airmat.errors import InputError
from airmat.calib.scan_readers.raw import RawCloud

__all__ = ["read"]


def read(path: Path, *, scan_index=None) -> RawCloud:
    """Every point of the file, NaN kept (the caller counts and drops them)."""
    header = _header(path)
    fields = header.get("FIELDS", [])
    sizes = header.get("SIZE", [])
    float32 = "x" in fields and len(sizes) == len(fields) and sizes[fields.index("x")] == "4"
    data = header["DATA"][:1]
    reader = {"ascii": _read_ascii, "binary": _read_binary, "binary_compressed": _read_compressed}.get(data[0]) \
        if data else None
    xyz = reader(path, header) if reader is not None else None
    if xyz is None:
        if data == ["ascii"]:
            _check_ascii_rows(path, header)   # open3d pads a short ascii body with zeros up to POINTS
        xyz = _read_open3d(path)
    declared = int(header.get("POINTS", ["0"])[0]) if header.get("POINTS", [""])[0].isdigit() else None
    if len(xyz) == 0 or (declared is not None and len(xyz) != declared):
        raise InputError(f"cannot parse PCD file (truncated or corrupt?): read {len(xyz)} of "
                         f"{declared} points", path=path)
    return RawCloud(vertices=xyz, float32=float32)


def _check_ascii_rows(path: Path, header: dict) -> None:
    """Refuse an ascii body with fewer rows than its POINTS (counted in C: its line breaks)."""
    points = header.get("POINTS", [""])[0]
    if not points.isdigit():
        return
    with open(path, "rb") as fh:
        fh.seek(header["_body"])
        body = fh.read()
    rows = body.count(b"\n") + (not body.endswith(b"\n"))   # at least the rows it holds
    if rows < int(points):
        raise InputError(f"truncated PCD: the header declares {points} points, the file has {rows} rows",
                         path=path)


def _read_open3d(path: Path) -> np.ndarray:
    from airmat.lazy import import_open3d

    o3d = import_open3d()

    o3d.utility.set_verbosity_level(o3d.utility.VerbosityLevel.Error)
    cloud = o3d.io.read_point_cloud(str(path), format="pcd", remove_nan_points=False,
                                    remove_infinite_points=False)
    return np.asarray(cloud.points, dtype=float)


def _read_ascii(path: Path, header: dict) -> np.ndarray | None:
    """x, y, z of an ascii body as written (open3d reads the text in double too), or None."""
    from airmat.calib.scan_readers.text_reader import read_columns_fast

    fields = header["FIELDS"]
    counts = header.get("COUNT", ["1"] * len(fields))
    if not {"x", "y", "z"} <= set(fields) or len(counts) != len(fields) or not all(c.isdigit() for c in counts):
        return None
    start = np.concatenate([[0], np.cumsum([int(c) for c in counts])])
    cols = [int(start[fields.index(a)]) for a in "xyz"]
    return read_columns_fast(path, header["_skip"], None, int(start[-1]), cols, nan=True)


#: PCD TYPE letter -> numpy kind
_KINDS = {"F": "f", "I": "i", "U": "u"}


def _fields(header: dict) -> list[np.dtype] | None:
    """Each field's numpy type, shaped by its COUNT (little-endian), or None for an unusual header."""
    fields, sizes, types = header["FIELDS"], header.get("SIZE", []), header.get("TYPE", [])
    counts = header.get("COUNT", ["1"] * len(fields))
    if not (len(fields) == len(sizes) == len(types) == len(counts)) or not {"x", "y", "z"} <= set(fields) \
            or not all(c.isdigit() and z.isdigit() and t in _KINDS for c, z, t in zip(counts, sizes, types)) \
            or not header.get("POINTS", [""])[0].isdigit():
        return None
    return [np.dtype((f"<{_KINDS[t]}{z}", (int(c),))) for z, t, c in zip(sizes, types, counts)]


def _read_binary(path: Path, header: dict) -> np.ndarray | None:
    """x, y, z of a binary (uncompressed, little-endian) body, NaN kept, or None for an unusual header."""
    types = _fields(header)
    if types is None:
        return None
    fields = header["FIELDS"]
    # PCL pads records with repeated "_" fields: name the columns by position
    dtype = np.dtype([(f"f{i}", t) for i, t in enumerate(types)])
    n = int(header["POINTS"][0])
    if path.stat().st_size - header["_body"] < dtype.itemsize * n:
        raise InputError(f"cannot parse PCD file (truncated or corrupt?): the body holds fewer than the "
                         f"{n} points declared", path=path)
    data = np.fromfile(path, dtype=dtype, count=n, offset=header["_body"])
    return np.column_stack([data[f"f{fields.index(a)}"][:, 0] for a in "xyz"]).astype(float)


def _read_compressed(path: Path, header: dict) -> np.ndarray | None:
    """x, y, z of a binary_compressed body (LZF, one column per field in turn), NaN kept, or None
    (no python-lzf, an unusual header, or a body that does not decompress to the declared size).

    The body: uint32 compressed size, uint32 decompressed size, the LZF
    block; decompressed, field k is ``POINTS`` values of its type and COUNT,
    after the columns of the fields before it.
    """
    try:
        import lzf  # python-lzf: liblzf's decoder (the optional ``fast`` extra)
    except ImportError:
        return None
    types = _fields(header)
    if types is None:
        return None
    n = int(header["POINTS"][0])
    with open(path, "rb") as fh:
        fh.seek(header["_body"])
        sizes = np.frombuffer(fh.read(8), "<u4")
        if len(sizes) != 2 or int(sizes[1]) != n * sum(t.itemsize for t in types):
            return None
        block = fh.read(int(sizes[0]))
    try:
        body = lzf.decompress(block, int(sizes[1])) if n else b""
    except ValueError:  # corrupt or truncated: open3d reads it or the point count refuses it
        return None
    if body is None or len(body) != int(sizes[1]):
        return None
    starts = np.concatenate([[0], np.cumsum([n * t.itemsize for t in types])])
    xyz = np.empty((n, 3))
    for j, a in enumerate("xyz"):
        k = header["FIELDS"].index(a)
        xyz[:, j] = np.frombuffer(body, types[k], count=n, offset=int(starts[k]))[:, 0]
    return xyz


def _header(path: Path) -> dict:
    """The PCD header's keyword lines, up to DATA: {KEY: [values]}."""
    try:
        with open(path, "rb") as fh:
            head = fh.read(4096).decode("ascii", errors="replace")
    except OSError as err:
        raise InputError(f"cannot read: {err.strerror or err}", path=path) from None
    out = {}
    offset = 0
    for i, line in enumerate(head.split("\n")):
        offset += len(line) + 1
        words = line.split()
        if not words or words[0].startswith("#"):
            continue
        out[words[0].upper()] = words[1:]
        if words[0].upper() == "DATA":
            out["_skip"] = i + 1  # header lines before the body
            out["_body"] = offset  # its byte offset (the header is ascii)
            break
    if "DATA" not in out or "FIELDS" not in out:
        raise InputError("not a PCD file (no FIELDS ... DATA header)", path=path)
    return out
