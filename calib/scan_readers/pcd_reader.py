"""PCD (PCL's format: ascii, binary, binary_compressed; organized clouds with NaN) through open3d."""

from __future__ import annotations

from pathlib import Path

import numpy as np

from airmat.errors import InputError
from calib.scan_readers.raw import RawCloud

__all__ = ["read"]


def read(path: Path, *, scan_index=None) -> RawCloud:
    """Every point of the file, NaN kept (the caller counts and drops them)."""
    import open3d as o3d

    header = _header(path)
    o3d.utility.set_verbosity_level(o3d.utility.VerbosityLevel.Error)
    cloud = o3d.io.read_point_cloud(str(path), format="pcd", remove_nan_points=False,
                                    remove_infinite_points=False)
    xyz = np.asarray(cloud.points, dtype=float)
    declared = int(header.get("POINTS", ["0"])[0]) if header.get("POINTS", [""])[0].isdigit() else None
    if len(xyz) == 0 or (declared is not None and len(xyz) != declared):
        raise InputError(f"cannot parse PCD file (truncated or corrupt?): read {len(xyz)} of "
                         f"{declared} points", path=path)
    fields = header.get("FIELDS", [])
    sizes = header.get("SIZE", [])
    float32 = "x" in fields and len(sizes) == len(fields) and sizes[fields.index("x")] == "4"
    return RawCloud(vertices=xyz, float32=float32)


def _header(path: Path) -> dict:
    """The PCD header's keyword lines, up to DATA: {KEY: [values]}."""
    try:
        with open(path, "rb") as fh:
            head = fh.read(4096).decode("ascii", errors="replace")
    except OSError as err:
        raise InputError(f"cannot read: {err.strerror or err}", path=path) from None
    out = {}
    for line in head.split("\n"):
        words = line.split()
        if not words or words[0].startswith("#"):
            continue
        out[words[0].upper()] = words[1:]
        if words[0].upper() == "DATA":
            break
    if "DATA" not in out or "FIELDS" not in out:
        raise InputError("not a PCD file (no FIELDS ... DATA header)", path=path)
    return out
