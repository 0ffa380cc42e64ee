"""E57 (ASTM E2807) through pye57: one scan, or every scan merged with its pose.

E57 coordinates are metres by the standard. Each scan's pose (rotation and
translation in the file) is applied, so merged scans share one frame.
Points flagged invalid by the scanner (``cartesianInvalidState`` != 0) come
back as NaN, so they are counted with the other non-finite points.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from airmat.errors import InputError
from calib.scan_readers.raw import RawCloud, library_message

__all__ = ["read"]


def read(path: Path, *, scan_index: int | None = None) -> RawCloud:
    """Points of scan ``scan_index`` (all scans, merged with their poses, when None), metres."""
    import pye57

    try:
        e57 = pye57.E57(str(path), mode="r")
    except Exception as err:  # libE57 raises its own exception types
        raise InputError(f"cannot parse E57 file: {library_message(err)}", path=path) from None
    try:
        n = e57.scan_count
        if n == 0:
            raise InputError("no scans in the E57 file", path=path)
        if scan_index is not None and not 0 <= scan_index < n:
            raise InputError(f"--scan-index {scan_index} out of range: the file holds {n} scan(s) "
                             f"(0..{n - 1})", path=path)
        indices = range(n) if scan_index is None else [scan_index]
        parts = [_scan_points(e57, i, path) for i in indices]
    finally:
        e57.close()
    return RawCloud(vertices=np.concatenate(parts), units="m", n_scans=n)


def _scan_points(e57, i: int, path: Path) -> np.ndarray:
    try:
        data = e57.read_scan(i, ignore_missing_fields=True, transform=True)
    except Exception as err:
        raise InputError(f"cannot read scan {i} of the E57 file: {library_message(err)}",
                         path=path) from None
    if "cartesianX" not in data:
        raise InputError(f"scan {i} of the E57 file has no cartesian coordinates", path=path)
    xyz = np.column_stack([data["cartesianX"], data["cartesianY"], data["cartesianZ"]]).astype(float)
    invalid = data.get("cartesianInvalidState")
    if invalid is not None:
        xyz[np.asarray(invalid) != 0] = np.nan
    return xyz
