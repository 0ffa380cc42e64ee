"""Calibration: scans of cylindrical specimens -> Equation 3's Delta and d with uncertainty.

Public API (SI units: metres, 1/m):

- :func:`kappa1`, :func:`string_length` -- Equation 3 and its inverse (``airmat.calib.model``).
- :func:`read_scan` -- E57, LAS/LAZ, PCD, PLY/OBJ/STL/OFF, GLB/glTF, PTS/XYZ/TXT scans to points in
  metres (``airmat.calib.scan_io``; one reader per format in ``airmat.calib.scan_readers``).
- :func:`fit_cylinder` -- robust cylinder fit of one scan (``airmat.calib.cylinder_fit``);
  :func:`fit_cylinder_stable` -- the same, compared over several seeds (``airmat.calib.cylinder_stability``).
- :func:`read_manifest` -- the calibration manifest CSV (``airmat.calib.manifest``).
- :func:`sample_posterior` -- emcee posterior of Delta, d and the scatter sigma (``airmat.calib.posterior``).
- :func:`kappa_curve` -- calibrated kappa_1(l/L) with 68/95% bands (``airmat.calib.curve``).
- :func:`calibrate` -- manifest -> scans -> fits -> posterior -> curve (``airmat.calib.calibrate``).
- :func:`write_calibration`, :func:`plot_curve`, :func:`plot_corner` -- output files (``airmat.calib.calibration_io``, ``airmat.calib.plots``);
  :func:`read_calibration` -- the same Calibration from its folder;
  :func:`curve_figure`, :func:`corner_figure` -- the same figures as ``matplotlib.figure.Figure``.
"""

import airmat  # noqa: F401  (sets the BLAS thread defaults before numpy loads)
from airmat.lazy import attach

# public name -> its submodule, imported on first use (``airmat.lazy``): ``airmat fit`` loads no emcee or plots
__getattr__, __dir__, __all__ = attach(__name__, {
    "model": ["bend_angle", "flat_length", "kappa1", "kappa_max", "string_length"],
    "scan_io": ["Scan", "read_scan"],
    "cylinder_fit": ["CylinderFit", "fit_cylinder"],
    "cylinder_stability": ["fit_cylinder_stable"],
    "manifest": ["Manifest", "read_manifest"],
    "posterior": ["DEFAULT_PRIORS", "Posterior", "Priors", "sample_posterior", "specimen_data"],
    "curve": ["KappaCurve", "kappa_curve"],
    "calibrate": ["Calibration", "SpecimenFit", "calibrate"],
    "calibration_io": ["write_calibration", "read_calibration"],
    "plots": ["plot_corner", "plot_curve", "curve_figure", "corner_figure"],
})
