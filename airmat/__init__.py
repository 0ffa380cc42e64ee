"""airmat: reconfigurable inflatable surfaces with tension-string patterns.

``import airmat`` gives the stage functions and the readers and writers a user
needs, loaded on first use (start-up stays light)::

    import airmat

    cal = airmat.calibrate("specimens/manifest.csv", seed=1)      # Equation 3's Δ, d (SI: m, 1/m)
    target, mattress = airmat.preset("vault1")                   # or airmat.load_target(path, units="mm")
    result = airmat.make_design(target, mattress, calibration=cal)
    refined = airmat.refine(result, resolution=0.020)
    checked = airmat.check_design(refined.design, resolution=0.020, known=refined.known_runs)
    airmat.write_design(refined.design, "out/design")

The stages live in subpackages, one folder each in the repository:
``airmat.calib`` (scans, cylinder fit, Equation 3, posterior), ``airmat.design``
(Ŝ, curvature field, stripes, string lengths, exports), ``airmat.inflation``
(the U_B simulator), ``airmat.check`` (inflation against Ŝ, refinement,
Monte-Carlo), ``airmat.report`` (report.html) and ``airmat.synthetic``
(scans and targets with known truth). The modules directly in ``airmat`` are
what they share: errors, atomic output, progress bars, units, lazy exports.
The Python API uses SI units (metres, 1/m); files and the command line use
millimetres.
"""

import os as _os

# One BLAS thread unless the user says otherwise. airmat's numerics are
# elementwise numpy and sparse solves; the dense BLAS calls it makes are tiny
# (scipy's Delaunay.transform does one 2x2 LAPACK solve per triangle), and
# with OpenBLAS threads on a 2-core machine that was busy they ran 20-100x
# slower (51 s instead of 0.8 s for the stripes of the vault2 preset).
# Effective only when set before numpy is first imported: every airmat
# package imports this module first.
for _var in ("OPENBLAS_NUM_THREADS", "OMP_NUM_THREADS", "MKL_NUM_THREADS"):
    _os.environ.setdefault(_var, "1")

__version__ = "0.2.0"

#: public name -> "module:attribute" it is loaded from on first use
_FACADE = {
    # calibrate
    "read_scan": "airmat.calib.scan_io:read_scan",
    "fit_cylinder": "airmat.calib.cylinder_fit:fit_cylinder",
    "calibrate": "airmat.calib.calibrate:calibrate",
    "read_calibration": "airmat.calib.calibration_io:read_calibration",
    "write_calibration": "airmat.calib.calibration_io:write_calibration",
    "plan": "airmat.calib.experiment_design:plan",
    # design
    "load_target": "airmat.design.target:load_target",
    "preset": "airmat.design.presets:preset",
    "Mattress": "airmat.design.mattress:Mattress",
    "DesignParams": "airmat.design.pipeline:DesignParams",
    "make_design": "airmat.design.pipeline:design",
    "read_design": "airmat.design.design_io:read_design",
    "write_design": "airmat.design.design_io:write_design",
    # check and refine
    "check_design": "airmat.check.inflation_check:check",
    "monte_carlo": "airmat.check.inflation_check:monte_carlo",
    "tolerance": "airmat.check.tolerance:tolerance",
    "refine": "airmat.check.refinement:refine",
    "write_report": "airmat.report.page:write_report",
    # the physical loop
    "correct": "airmat.asbuilt.pipeline:correct",
}
_SUBPACKAGES = ("calib", "design", "inflation", "check", "report", "synthetic", "asbuilt", "cli")

__all__ = ["__version__", *_FACADE]


def __getattr__(name):
    import importlib

    if name in _SUBPACKAGES:
        return importlib.import_module(f"{__name__}.{name}")
    target = _FACADE.get(name)
    if target is None:
        raise AttributeError(f"module {__name__!r} has no attribute {name!r}")
    module, _, attr = target.partition(":")
    value = getattr(importlib.import_module(module), attr)
    globals()[name] = value
    return value


def __dir__():
    return sorted(set(globals()) | set(__all__))
