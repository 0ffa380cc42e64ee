"""Synthetic ground truth: specimen scans, calibration sets and analytic target surfaces (SI units).

One generator per module (functions are not re-exported under their module's name, so that
``data_synthetic.specimen_scan`` stays the module):

- ``data_synthetic.specimen_scan.specimen_scan`` -- one realistic scan of a bent specimen.
- ``data_synthetic.ply_write.write_ply`` -- PLY in every common encoding.
- ``data_synthetic.calibration_set.calibration_set`` -- scans + manifest.csv + truth.json.
- ``data_synthetic.targets`` -- analytic surfaces (cylinder, cone, sphere cap, saddle).
- ``design.presets.preset`` -- the five target presets with their mattress.
"""

import airmat  # noqa: F401  (sets the BLAS thread defaults before numpy loads)

from data_synthetic.ply_write import write_ply


__all__ = ["write_ply"]
