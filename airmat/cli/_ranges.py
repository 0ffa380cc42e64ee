"""Sane ranges of the physical options, refused up front (exit 2) rather than by a solver later.

The ranges are generous: they only keep out values no drop-stitch mattress
has (a thickness of a metre, a pressure of ten bar) and unit slips.

==================  ===============  ==========================================
option              range            why
==================  ===============  ==========================================
``--thickness-mm``  [10, 500] mm     drop-stitch panels are 50-300 mm thick
``--d-mm``          [10, 500] mm     the same thickness, in ``synth``
``--pressure-pa``   (0, 1e5] Pa      drop-stitch panels hold at most ~1 bar
``--L-mm``          [50, 2000] mm    string-end spacing (paper 300 mm)
==================  ===============  ==========================================
"""

from __future__ import annotations

import math

from airmat.errors import InputError

__all__ = ["RANGES", "check_range"]

#: option -> (low, high, low included, unit)
RANGES = {
    "--thickness-mm": (10.0, 500.0, True, "mm"),
    "--d-mm": (10.0, 500.0, True, "mm"),
    "--pressure-pa": (0.0, 1e5, False, "Pa"),
    "--L-mm": (50.0, 2000.0, True, "mm"),
}


def check_range(option: str, value) -> None:
    """InputError naming ``option`` and its range unless ``value`` lies in :data:`RANGES`.

    Examples
    --------
    >>> check_range("--pressure-pa", 2000.0)
    >>> check_range("--pressure-pa", 1e12)
    Traceback (most recent call last):
    ...
    airmat.errors.InputError: --pressure-pa: 1e+12 Pa is outside (0, 100000] Pa
    """
    if value is None:
        return
    lo, hi, lo_in, unit = RANGES[option]
    ok = math.isfinite(value) and (lo <= value if lo_in else lo < value) and value <= hi
    if not ok:
        raise InputError(f"{option}: {value:g} {unit} is outside {'[' if lo_in else '('}{lo:g}, {hi:g}] {unit}",
                         option=option, value=value)
