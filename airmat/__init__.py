"""airmat: reconfigurable inflatable surfaces with tension-string patterns.

The numerical library lives in the top-level packages ``calib`` (Equation 3,
scan fitting, posterior), ``design`` (near-developable surface, stripes,
string lengths, inflation check) and ``data_synthetic`` (ground truth).
This package holds what they share: the error hierarchy, atomic output,
progress bars, unit conversions and the ``airmat`` command line.
"""

__version__ = "0.1.0"
__all__ = ["__version__"]
