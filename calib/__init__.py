"""Calibration: scans of cylindrical specimens -> Equation 3's Delta and d with uncertainty.

Public API (SI units: metres, 1/m):

- :func:`kappa1`, :func:`string_length` -- Equation 3 and its inverse (``calib.model``).
- :func:`read_scan` -- PLY/OBJ/STL/OFF scans to points in metres (``calib.scan_io``).
- :func:`fit_cylinder` -- robust cylinder fit of one scan (``calib.cylinder_fit``).
- :func:`read_manifest` -- the calibration manifest CSV (``calib.manifest``).
- :func:`sample_posterior` -- emcee posterior of Delta, d and the scatter sigma (``calib.posterior``).
- :func:`kappa_curve` -- calibrated kappa_1(l/L) with 68/95% bands (``calib.curve``).
- :func:`calibrate` -- manifest -> scans -> fits -> posterior -> curve (``calib.calibrate``).
- :func:`write_calibration`, :func:`plot_curve`, :func:`plot_corner` -- output files (``calib.calibration_io``, ``calib.plots``).
"""

import airmat  # noqa: F401  (sets the BLAS thread defaults before numpy loads)

from calib.model import bend_angle, flat_length, kappa1, kappa_max, string_length
from calib.scan_io import Scan, read_scan
from calib.cylinder_fit import CylinderFit, fit_cylinder
from calib.manifest import Manifest, read_manifest
from calib.posterior import DEFAULT_PRIORS, Posterior, Priors, sample_posterior, specimen_data
from calib.curve import KappaCurve, kappa_curve
from calib.calibrate import Calibration, SpecimenFit, calibrate
from calib.calibration_io import write_calibration
from calib.plots import plot_corner, plot_curve

__all__ = [
    "bend_angle", "flat_length", "kappa1", "kappa_max", "string_length",
    "Scan", "read_scan", "CylinderFit", "fit_cylinder",
    "Manifest", "read_manifest", "DEFAULT_PRIORS", "Posterior", "Priors", "sample_posterior",
    "specimen_data", "KappaCurve", "kappa_curve", "Calibration", "SpecimenFit", "calibrate",
    "write_calibration", "plot_corner", "plot_curve",
]
