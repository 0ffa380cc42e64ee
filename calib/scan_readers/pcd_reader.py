"""PCD (PCL's format: ascii, binary, binary_compressed; organized clouds with NaN) through open3d.

An ascii PCD is read with pandas' C parser (:func:`calib.scan_readers.text_reader.read_columns_fast`,
about 5 times faster than open3d's), open3d when that parser refuses the body.
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
    xyz = _read_ascii(path, header) if header["DATA"][:1] == ["ascii"] else None
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
    xyz = xyz[:, np.argsort(np.argsort(cols))]  # pandas returns the columns in file order
    return xyz


def _header(path: Path) -> dict:
    """The PCD header's keyword lines, up to DATA: {KEY: [values]}."""
    try:
        with open(path, "rb") as fh:
            head = fh.read(4096).decode("ascii", errors="replace")
    except OSError as err:
        raise InputError(f"cannot read: {err.strerror or err}", path=path) from None
    out = {}
    for i, line in enumerate(head.split("\n")):
        words = line.split()
        if not words or words[0].startswith("#"):
            continue
        out[words[0].upper()] = words[1:]
        if words[0].upper() == "DATA":
            out["_skip"] = i + 1  # header lines before the body
            break
    if "DATA" not in out or "FIELDS" not in out:
        raise InputError("not a PCD file (no FIELDS ... DATA header)", path=path)
    return out
