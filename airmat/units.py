"""Unit conversions at the file/CLI boundary: files are in mm, the library in SI."""

MM = 1e-3          #: metres per millimetre
M_TO_MM = 1e3      #: millimetres per metre
#: metres per scan unit; "us-ft" is the US survey foot (1200/3937 m) of state-plane CRSs, 2 ppm off the foot
SCAN_UNITS = {"m": 1.0, "cm": 1e-2, "mm": 1e-3, "in": 0.0254, "ft": 0.3048, "us-ft": 1200 / 3937}

__all__ = ["MM", "M_TO_MM", "SCAN_UNITS", "mm_to_m"]


def mm_to_m(x):
    """A size in mm as metres, correctly rounded: ``mm_to_m(830) == 0.83`` (``830 * MM`` is
    0.8300000000000001). A mattress read from a file or the command line is then the same
    number as the one a preset writes in metres, and so are its meshes: the refinement's path
    is sensitive enough that the last bit of the width had moved the refined saddle from
    0.86 to 0.94 % of the diagonal."""
    return x / M_TO_MM
