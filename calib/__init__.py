"""Calibration: scans of cylindrical specimens -> Equation 3's Delta and d with uncertainty.

Public API (SI units: metres, 1/m):

- :func:`kappa1`, :func:`string_length` -- Equation 3 and its inverse (``calib.model``).
"""

from calib.model import bend_angle, flat_length, kappa1, kappa_max, string_length

__all__ = ["bend_angle", "flat_length", "kappa1", "kappa_max", "string_length"]
