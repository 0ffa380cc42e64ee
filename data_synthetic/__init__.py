"""Synthetic ground truth: specimen scans, calibration sets and analytic target surfaces (SI units).

- :func:`specimen_scan` -- one realistic scan of a bent specimen (``data_synthetic.specimen_scan``).
- :func:`write_ply` -- PLY in every common encoding (``data_synthetic.ply_write``).
- :func:`calibration_set` -- a folder of scans + manifest.csv + truth.json (``data_synthetic.calibration_set``).
- :func:`preset` -- the five target presets with their mattress (``data_synthetic.targets``).
"""

from data_synthetic.specimen_scan import SpecimenScan, specimen_scan
from data_synthetic.ply_write import write_ply
from data_synthetic.calibration_set import CalibrationSet, calibration_set
from data_synthetic.targets import preset

__all__ = ["SpecimenScan", "specimen_scan", "write_ply", "CalibrationSet", "calibration_set", "preset"]
