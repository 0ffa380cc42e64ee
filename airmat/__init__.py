"""airmat: reconfigurable inflatable surfaces with tension-string patterns.

The numerical library lives in the top-level packages ``calib`` (Equation 3,
scan fitting, posterior), ``design`` (near-developable surface, stripes,
string lengths, exports), ``inflation`` (the U_B simulator), ``check`` (an
inflation against Ŝ) and ``data_synthetic`` (ground truth). This package
holds what they share: the error hierarchy, atomic output, progress bars,
unit conversions, lazy package exports (``airmat.lazy``), figures without
pyplot (``airmat.figures``) and the ``airmat`` command line. It imports
nothing heavy itself: every package imports it first.
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

__version__ = "0.1.0"
__all__ = ["__version__"]
