"""Sane ranges of the physical options, refused up front (exit 2) rather than by a solver later.

The ranges are generous: they only keep out values no drop-stitch mattress
has (a thickness of a metre, a pressure of ten bar) and unit slips.

==================  ===============  ==========================================
option              range            why
==================  ===============  ==========================================
``--thickness-mm``  [10, 500] mm     drop-stitch panels are 50-300 mm thick
``--pressure-pa``   (0, 1e5] Pa      drop-stitch panels hold at most ~1 bar
``--L-mm``          [50, 2000] mm    string-end spacing (paper 300 mm)
``--resolution-mm`` (0, 75] mm       ``demo``/``gallery``: L/4 for the paper's L = 300 mm;
                                     finer than the inflation mesh limit of the
                                     mattress is refused too (:func:`check_resolution`)
``--points``        [1e4, 1e7]       points per synthetic scan (``synth``, ``demo``): at 4000
                                     the cylinder fit refused 1 of 12 specimens
                                     (seeds 0 and 1), at 5000 and 8000 none of 48
``--mattress``      [50, 2e4] mm     each side (``design``): the shortest string end
                                     spacing to a 20 m hall; metres are named
==================  ===============  ==========================================
"""

from __future__ import annotations

import math

from airmat.errors import InputError

__all__ = ["RANGES", "check_range", "check_resolution"]

#: option -> (low, high, low included, unit)
RANGES = {
    "--thickness-mm": (10.0, 500.0, True, "mm"),
    "--pressure-pa": (0.0, 1e5, False, "Pa"),
    "--L-mm": (50.0, 2000.0, True, "mm"),
    "--resolution-mm": (0.0, 75.0, False, "mm"),
    "--points": (10_000, 10_000_000, True, "points"),
    "--mattress": (50.0, 20_000.0, True, "mm"),   # per side; parsed by airmat.cli.design.parse_size_mm
    "--cut-tolerance-mm": (0.0, 50.0, False, "mm"),
    "--keep-tolerance-mm": (0.0, 50.0, False, "mm"),
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


def check_resolution(resolution_mm: float, mattresses) -> None:
    """``--resolution-mm`` of an inflation check, refused before any step runs (``demo``, ``gallery``).

    In its range, and not so fine that the double-layer mesh of one of
    ``mattresses`` (objects with ``width``, ``height`` in m) would exceed the
    solver's limit (:data:`airmat.inflation.mesh.MAX_VERTICES`), which the inflation
    itself would only find out after the synthesis, calibration and design.
    """
    from airmat.inflation.mesh import MAX_VERTICES, grid_shape

    check_range("--resolution-mm", resolution_mm)
    for m in mattresses:
        nx, ny = grid_shape(m.width, m.height, resolution_mm * 1e-3)
        n_est = 2 * nx * ny + 2 * (nx + ny - 2)  # both faces and the rim, as build_mattress_mesh counts them
        if n_est > MAX_VERTICES:
            raise InputError(f"--resolution-mm: {resolution_mm:g} mm is too fine for the {m.width * 1e3:.0f} x "
                             f"{m.height * 1e3:.0f} mm mattress: {n_est} mesh vertices, limit {MAX_VERTICES}",
                             option="--resolution-mm", value=resolution_mm)
