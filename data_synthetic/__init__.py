"""Synthetic ground truth: specimen scans, calibration sets and analytic target surfaces (SI units).

One generator per module (functions are not re-exported under their module's name, so that
``airmat.synthetic.specimen_scan`` stays the module):

- ``airmat.synthetic.specimen_scan.specimen_scan`` -- one realistic scan of a bent specimen.
- ``airmat.synthetic.ply_write.write_ply`` -- PLY in every common encoding.
- ``airmat.synthetic.calibration_set.calibration_set`` -- scans + manifest.csv + truth.json.
- ``airmat.synthetic.targets`` -- analytic surfaces (cylinder, cone, sphere cap, saddle).
- ``airmat.synthetic.zoo`` -- the target zoo: 36 seeded targets of every kind, with their mattress and
  the designer's expected verdict (``bench/bench_zoo.py`` runs them).
- ``airmat.design.presets.preset`` -- the five target presets with their mattress.
"""

import airmat  # noqa: F401  (sets the BLAS thread defaults before numpy loads)

from airmat.lazy import attach

# public name -> its submodule, imported on first use (``airmat.lazy``)
__getattr__, __dir__, __all__ = attach(__name__, {"ply_write": ["write_ply"]})
