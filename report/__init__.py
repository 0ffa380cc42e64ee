"""The report: one self-contained ``report.html`` per run, with 3D views, from the objects in memory.

Public API:

- :func:`write_report`, :func:`report_html` -- the page for a ``Calibration``, a ``DesignResult``
  and/or a ``DesignCheck`` (``page``), plotly.js inlined: it opens offline.
- :func:`calibration_part`, :func:`design_part`, :func:`check_part` -- the sections (``calibration``,
  ``design``, ``check``); :func:`html_table` -- tables, sortable by a click (``table``).
- :func:`check_verdict`, :func:`design_verdict`, :func:`calibration_verdict` -- the card at the top of
  the page: lands within :data:`WITHIN_PCT_DIAG` % of the diagonal or not, the tolerance, the next
  command (``verdict``).
"""

import airmat  # noqa: F401  (sets the BLAS thread defaults before numpy loads)
from airmat.lazy import attach

# public name -> its submodule, imported on first use (``airmat.lazy``)
__getattr__, __dir__, __all__ = attach(__name__, {
    "page": ["Part", "report_html", "write_report", "REPORT_NAME"],
    "calibration": ["calibration_part"],
    "design": ["design_part"],
    "check": ["check_part"],
    "table": ["html_table"],
    "mesh": ["display_grid"],
    "verdict": ["Verdict", "check_verdict", "design_verdict", "calibration_verdict", "WITHIN_PCT_DIAG"],
})
