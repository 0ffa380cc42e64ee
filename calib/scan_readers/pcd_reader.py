"""PCD (PCL's format: ascii, binary, binary_compressed; organized clouds with NaN) through open3d.

An ascii PCD is read with pyarrow's CSV reader, or pandas' C parser
(:func:`calib.scan_readers.text_reader.read_columns_fast`, 5-10 times faster
than open3d's), a binary one with ``np.fromfile`` and a structured dtype
built from the header (FIELDS, SIZE, TYPE, COUNT); open3d reads
binary_compressed bodies and whatever those two refuse.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from airmat.errors import InputError
from calib.scan_readers.raw import RawCloud

__all__ = ["read"]


def read(path: Path, *, scan_index=None) -> RawCloud:
    """Every point of the file, NaN kept (the caller counts and drops them)."""
    header = _header(path)
    fields = header.get("FIELDS", [])
    sizes = header.get("SIZE", [])
    float32 = "x" in fields and len(sizes) == len(fields) and sizes[fields.index("x")] == "4"
    data = header["DATA"][:1]
    xyz = _read_ascii(path, header) if data == ["ascii"] else _read_binary(path, header) if data == ["binary"] \
        else None
    if xyz is None:
        xyz = _read_open3d(path)
    declared = int(header.get("POINTS", ["0"])[0]) if header.get("POINTS", [""])[0].isdigit() else None
    if len(xyz) == 0 or (declared is not None and len(xyz) != declared):
        raise InputError(f"cannot parse PCD file (truncated or corrupt?): read {len(xyz)} of "
                         f"{declared} points", path=path)
    return RawCloud(vertices=xyz, float32=float32)


def _read_open3d(path: Path) -> np.ndarray:
    import open3d as o3d

    o3d.utility.set_verbosity_level(o3d.utility.VerbosityLevel.Error)
    cloud = o3d.io.read_point_cloud(str(path), format="pcd", remove_nan_points=False,
                                    remove_infinite_points=False)
    return np.asarray(cloud.points, dtype=float)


def _read_ascii(path: Path, header: dict) -> np.ndarray | None:
    """x, y, z of an ascii body as written (open3d reads the text in double too), or None."""
    from calib.scan_readers.text_reader import read_columns_fast

    fields = header["FIELDS"]
    counts = header.get("COUNT", ["1"] * len(fields))
    if not {"x", "y", "z"} <= set(fields) or len(counts) != len(fields) or not all(c.isdigit() for c in counts):
        return None
    start = np.concatenate([[0], np.cumsum([int(c) for c in counts])])
    cols = [int(start[fields.index(a)]) for a in "xyz"]
    with open(path, "rb") as fh:
        xyz = read_columns_fast(fh, header["_skip"], None, cols, nan=True)
    if xyz is None:
        return None
    xyz = xyz[:, np.argsort(np.argsort(cols))]  # the columns come in file order
    return xyz


#: PCD TYPE letter -> numpy kind
_KINDS = {"F": "f", "I": "i", "U": "u"}


def _read_binary(path: Path, header: dict) -> np.ndarray | None:
    """x, y, z of a binary (uncompressed, little-endian) body, NaN kept, or None for an unusual header."""
    fields, sizes, types = header["FIELDS"], header.get("SIZE", []), header.get("TYPE", [])
    counts = header.get("COUNT", ["1"] * len(fields))
    if not (len(fields) == len(sizes) == len(types) == len(counts)) or not {"x", "y", "z"} <= set(fields) \
            or not all(c.isdigit() and z.isdigit() and t in _KINDS for c, z, t in zip(counts, sizes, types)):
        return None
    # PCL pads records with repeated "_" fields: name the columns by position
    dtype = np.dtype([(f"f{i}", f"<{_KINDS[t]}{z}", (int(c),))
                      for i, (z, t, c) in enumerate(zip(sizes, types, counts))])
    if not header.get("POINTS", [""])[0].isdigit():
        return None
    n = int(header["POINTS"][0])
    if path.stat().st_size - header["_body"] < dtype.itemsize * n:
        raise InputError(f"cannot parse PCD file (truncated or corrupt?): the body holds fewer than the "
                         f"{n} points declared", path=path)
    data = np.fromfile(path, dtype=dtype, count=n, offset=header["_body"])
    return np.column_stack([data[f"f{fields.index(a)}"][:, 0] for a in "xyz"]).astype(float)


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
