"""LAS and LAZ through laspy (LAZ decompressed by its lazrs backend, in parallel).

LAS stores integers with a scale and an offset per axis; laspy returns the
scaled coordinates in float64. Surveys are georeferenced: the unit is the
CRS's, taken as metres (pass ``--scan-units`` for a CRS in feet).

Only x, y, z are needed: in a LAZ of point format 6-10 (LAS 1.4, what
scanners and photogrammetry write today) the fields are compressed in
separate layers, and lazrs decodes only the x/y/return layer and the z layer
(the intensity, classification, GPS time, colour layers are skipped). Point
formats 0-5 (LAS 1.0-1.3) interleave every field in one arithmetic-coded
stream, so their LAZ decompression is the whole record whatever is asked.
The coordinates are scaled straight into one (N, 3) array, with laspy's
arithmetic (``X * scale + offset`` in float64: the same bits).
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from airmat.errors import InputError
from airmat.calib.scan_readers.raw import RawCloud, library_message

__all__ = ["read"]


def read(path: Path, *, scan_index=None) -> RawCloud:
    """Scaled coordinates of every point record, float64, metres."""
    import laspy

    try:
        # LazrsParallel decompresses the chunks on every core; same points as the serial backend
        las = laspy.read(str(path), laz_backend=(laspy.LazBackend.LazrsParallel, laspy.LazBackend.Lazrs),
                         decompression_selection=_xyz_layers())
    except OSError as err:
        raise InputError(f"cannot read: {err.strerror or err}", path=path) from None
    except Exception as err:  # laspy/lazrs raise several types for a bad file
        raise InputError(f"cannot parse {path.suffix[1:].upper()} file (truncated or corrupt?): "
                         f"{library_message(err)}", path=path) from None
    records, header = las.points.array, las.header
    xyz = np.empty((len(records), 3))
    for j, name in enumerate("XYZ"):
        np.multiply(records[name], header.scales[j], out=xyz[:, j])
        xyz[:, j] += header.offsets[j]
    return RawCloud(vertices=xyz, units="m")


def _xyz_layers():
    """laspy's DecompressionSelection of the layers holding X, Y (with the returns) and Z."""
    from laspy import DecompressionSelection

    return DecompressionSelection.xy_returns_channel() | DecompressionSelection.Z
