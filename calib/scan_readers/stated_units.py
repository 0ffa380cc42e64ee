"""The unit a scan file states: an exporter's comment (OBJ, PLY) or a LAS file's CRS (WKT or GeoTIFF keys).

Formats that carry no unit are read in millimetres unless told otherwise,
which is right for most lab software and wrong by a factor of 10 to 300 for
the rest: SketchUp writes ``# File units = inches`` at the top of its OBJ,
several PLY exporters a ``comment Units: cm`` header line, and a LAS survey
in a US state-plane CRS is in US survey feet (its WKT names the
``LENGTHUNIT``, its GeoTIFF keys the ``ProjLinearUnitsGeoKey``). These
functions return that unit as a key of :data:`airmat.units.SCAN_UNITS`, or
None when the file does not say.
"""

from __future__ import annotations

import logging
import re

from airmat.units import SCAN_UNITS

__all__ = ["unit_from_comments", "unit_from_wkt", "unit_from_geokeys", "unit_from_factor"]

log = logging.getLogger(__name__)

#: a comment's unit word -> SCAN_UNITS key
_WORDS = {"m": "m", "meter": "m", "meters": "m", "metre": "m", "metres": "m",
          "cm": "cm", "centimeter": "cm", "centimeters": "cm", "centimetre": "cm", "centimetres": "cm",
          "mm": "mm", "millimeter": "mm", "millimeters": "mm", "millimetre": "mm", "millimetres": "mm",
          "in": "in", "inch": "in", "inches": "in", "ft": "ft", "foot": "ft", "feet": "ft"}
#: "units inches", "Units: cm", "File units = inches", "unit=mm"
_COMMENT_UNIT = re.compile(r"(?i)\bunits?\b\s*[:=]?\s*([a-z]+)\b")
#: EPSG unit of measure codes of GeoTIFF's linear-unit keys
_EPSG_UNITS = {9001: "m", 9002: "ft", 9003: "us-ft"}
#: ProjLinearUnitsGeoKey, then GeogLinearUnitsGeoKey (a geocentric CRS)
_LINEAR_KEYS = (3076, 2052)
#: WKT keywords that open the vertical part of a compound CRS
_VERTICAL = re.compile(r"\b(VERT_CS|VERTCRS|VERTICALCRS)\[")
_WKT_UNIT = re.compile(r'\b(?:LENGTHUNIT|UNIT)\[\s*"([^"]*)"\s*,\s*([0-9.eE+-]+)')
_ANGLES = ("degree", "radian", "grad", "gon", "arc", "second", "minute")


def unit_from_comments(lines) -> str | None:
    """The unit named by a comment line (``units inches``, ``Units: cm``, ``File units = inches``).

    Parameters
    ----------
    lines : iterable of str
        The file's comment lines (an OBJ's ``#`` lines, a PLY header's ``comment`` and ``obj_info``).

    Returns
    -------
    str or None
        A key of :data:`airmat.units.SCAN_UNITS`; None when no comment names a unit.

    Examples
    --------
    >>> unit_from_comments(["# Exported from SketchUp", "# File units = inches"])
    'in'
    >>> unit_from_comments(["comment Units: cm"]), unit_from_comments(["comment made by open3d"])
    ('cm', None)
    """
    for line in lines:
        for match in _COMMENT_UNIT.finditer(line):
            unit = _WORDS.get(match.group(1).lower())
            if unit is not None:
                return unit
    return None


def unit_from_factor(metres: float) -> str | None:
    """The SCAN_UNITS key whose metres per unit is ``metres`` (to 1e-5; Clarke's foot reads as a foot)."""
    best = min(SCAN_UNITS, key=lambda u: abs(SCAN_UNITS[u] / metres - 1))
    return best if abs(SCAN_UNITS[best] / metres - 1) < 1e-5 else None


def unit_from_wkt(wkt: str) -> str | None:
    """The horizontal linear unit of a WKT (1 or 2) coordinate reference system, or None.

    The unit of the horizontal CRS is the last length unit before the vertical
    part of a compound CRS: a WKT1 ``PROJCS`` closes with its ``UNIT``, a WKT2
    ``PROJCRS`` with its axes' ``LENGTHUNIT`` (the ellipsoid's, in metres,
    comes first). A geographic CRS (degrees) names no length unit: None.

    Examples
    --------
    >>> unit_from_wkt('PROJCS["x",GEOGCS["y",UNIT["degree",0.0174532925199433]],UNIT["US survey foot",0.3048006096]]')
    'us-ft'
    """
    horizontal = _VERTICAL.split(wkt, maxsplit=1)[0]
    lengths = [(name, float(factor)) for name, factor in _WKT_UNIT.findall(horizontal)
               if not any(a in name.lower() for a in _ANGLES)]
    if not lengths:
        return None
    name, factor = lengths[-1]
    unit = unit_from_factor(factor) if factor > 0 else None
    if unit is None:
        log.debug("WKT length unit %r (%g m) is not a scan unit; taken as metres", name, factor)
    return unit


def unit_from_geokeys(keys) -> str | None:
    """The linear unit of GeoTIFF keys ``[(id, value)]`` (ProjLinearUnits 3076, GeogLinearUnits 2052), or None."""
    values = dict(keys)
    for key in _LINEAR_KEYS:
        if key in values:
            return _EPSG_UNITS.get(int(values[key]))
    return None
