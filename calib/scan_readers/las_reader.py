"""LAS and LAZ through laspy (LAZ decompressed by its lazrs backend, in parallel).

LAS stores integers with a scale and an offset per axis; laspy returns the
scaled coordinates in float64. Surveys are georeferenced: the unit is the
CRS's, taken as metres (pass ``--scan-units`` for a CRS in feet).
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from airmat.errors import InputError
from calib.scan_readers.raw import RawCloud, library_message

__all__ = ["read"]


def read(path: Path, *, scan_index=None) -> RawCloud:
    """Scaled coordinates of every point record, float64, metres."""
    import laspy

    try:
        # LazrsParallel decompresses the chunks on every core; same points as the serial backend
        las = laspy.read(str(path), laz_backend=(laspy.LazBackend.LazrsParallel, laspy.LazBackend.Lazrs))
    except OSError as err:
        raise InputError(f"cannot read: {err.strerror or err}", path=path) from None
    except Exception as err:  # laspy/lazrs raise several types for a bad file
        raise InputError(f"cannot parse {path.suffix[1:].upper()} file: {library_message(err)}",
                         path=path) from None
    xyz = np.column_stack([np.asarray(las.x, float), np.asarray(las.y, float), np.asarray(las.z, float)])
    return RawCloud(vertices=xyz, units="m")
