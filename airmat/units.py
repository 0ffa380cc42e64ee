"""Unit conversions at the file/CLI boundary: files are in mm, the library in SI."""

MM = 1e-3          #: metres per millimetre
M_TO_MM = 1e3      #: millimetres per metre
SCAN_UNITS = {"m": 1.0, "cm": 1e-2, "mm": 1e-3, "in": 0.0254}  #: metres per scan unit

__all__ = ["MM", "M_TO_MM", "SCAN_UNITS"]
