"""LAS and LAZ through laspy (LAZ decompressed by its lazrs backend, in parallel).

LAS stores integers with a scale and an offset per axis; laspy returns the
scaled coordinates in float64. Surveys are georeferenced: the unit is the
linear unit of the CRS the file carries (a WKT VLR, LAS 1.4's way, or the
GeoTIFF keys' ``ProjLinearUnitsGeoKey``; US state-plane CRSs are in US
survey feet), metres when it names none. The scale is the coordinates' step
(``Scan.quantization``): PDAL's default of 0.01 is a 1 cm grid.

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

import logging
from pathlib import Path

import numpy as np

from airmat.errors import InputError
from airmat.units import SCAN_UNITS
from airmat.calib.scan_readers.raw import RawCloud, check_step, library_message
from airmat.calib.scan_readers.stated_units import unit_from_geokeys, unit_from_wkt

__all__ = ["read", "crs_unit"]

log = logging.getLogger(__name__)

#: a scale above this (m) is worth a warning: its rounding is more than a scanner's noise
_WARN_STEP = 1e-3


def read(path: Path, *, scan_index=None) -> RawCloud:
    """Scaled coordinates of every point record, float64, in the CRS's unit (metres when it names none)."""
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
    units, step = crs_unit(header) or "m", float(np.max(np.abs(header.scales)))
    check_step(xyz, step, path, f"the {path.suffix[1:].upper()} stores integers times its scale {step:g} {units}",
               "write it with a finer scale (0.0001 m: PDAL writers.las scale_x=0.0001)", SCAN_UNITS[units])
    metres = step * SCAN_UNITS[units]
    if metres > _WARN_STEP:   # PDAL's default scale, 0.01: a centimetre grid
        log.warning("%s: the %s stores integers times its scale %g %s, a %.3g mm grid: rounding adds %.2g mm of "
                    "noise (sd step/sqrt(12)), which the fit's noise level and error bar include; a scale of "
                    "0.0001 m keeps a scanner's precision", path, path.suffix[1:].upper(), step, units,
                    metres * 1e3, metres * 1e3 / np.sqrt(12))
    return RawCloud(vertices=xyz, units=units, step=step)


def crs_unit(header) -> str | None:
    """The linear unit of a LAS header's CRS (its WKT VLR, else its GeoTIFF keys), or None."""
    from laspy.vlrs.known import GeoKeyDirectoryVlr, WktCoordinateSystemVlr

    vlrs = list(header.vlrs) + list(getattr(header, "evlrs", None) or [])
    for vlr in vlrs:
        if isinstance(vlr, WktCoordinateSystemVlr) and vlr.string:
            unit = unit_from_wkt(vlr.string)
            if unit is not None:
                return unit
    for vlr in vlrs:
        if isinstance(vlr, GeoKeyDirectoryVlr):
            unit = unit_from_geokeys([(k.id, k.value_offset) for k in vlr.geo_keys if k.tiff_tag_location == 0])
            if unit is not None:
                return unit
    return None


def _xyz_layers():
    """laspy's DecompressionSelection of the layers holding X, Y (with the returns) and Z."""
    from laspy import DecompressionSelection

    return DecompressionSelection.xy_returns_channel() | DecompressionSelection.Z
