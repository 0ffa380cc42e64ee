"""The check: inflate a design with its strings and measure how far it lands from Ŝ.

Public API (SI units: metres, 1/m):

- :func:`check` -- inflate a :class:`~design.pipeline.DesignResult` at the median string
  lengths and at both tolerance ends (``inflation_check``).
- :func:`deviation`, :func:`realized_curvature`, :func:`surface_at` -- an inflation against Ŝ
  (``compare``).
- :func:`write_check` -- ``inflate.json``, ``inflated.ply``, ``deviation.png`` (``report``).
- :func:`validate_equation3` -- the paper's specimen experiment, simulated (``validation``).
"""

from check.compare import Deviation, deviation, realized_curvature, surface_at
from check.inflation_check import CheckRun, DesignCheck, check, design_strings
from check.report import write_check

__all__ = ["Deviation", "deviation", "realized_curvature", "surface_at", "CheckRun", "DesignCheck", "check",
           "design_strings", "write_check", "validate_equation3"]


def __getattr__(name):  # validation imports calib's cylinder fit: load it only when asked for
    if name == "validate_equation3":
        from check.validation import validate_equation3

        return validate_equation3
    raise AttributeError(name)
