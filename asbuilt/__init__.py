"""The physical loop: a scan of the built, inflated mattress back to its string lengths.

:func:`airmat.correct` (``pipeline.correct``) runs the steps in order; ``correct_io`` writes its folder.

Modules (SI units inside: metres, 1/m; millimetres in files):

- ``true_world`` -- a design inflated in a "true world" whose (Δ, d) and cut errors differ from
  its calibration: the synthetic as-built mattress (``airmat synth-built``).
- ``registration`` -- a scan in any frame and unit, with floor and clutter, registered onto the
  design's predicted inflated face (global start, then robust point-to-plane ICP).
- ``deviation_map`` -- the registered scan against Ŝ and against the prediction.
- ``update`` -- the calibration posterior and each string's length error updated with the scan
  as data, through the inflation's Jacobian (Laplace).
- ``updated_calibration`` -- the updated posterior as a calibration (``airmat design --calibration``).
- ``correction`` -- corrected string lengths and the re-tie list (``airmat correct``).
"""

import airmat  # noqa: F401  (sets the BLAS thread defaults before numpy loads)
