"""The paper's values (Todo et al., IASS 2024, §2.2 and §4) and the workshop's defaults, in SI units.

Equation 3's calibration of the paper's mattresses: string ends a geodesic
distance L = 300 mm apart, each slipping Δ = 18 mm toward the other, a
mattress d = 70 mm thick. Without a calibration the designer uses these
with a *stated, not measured* nominal uncertainty (1-sigma 3 mm on Δ, 5 mm
on d). The paper's two mattresses are 830 × 740 mm and 2600 × 1600 mm.

Examples
--------
>>> from airmat.constants import PAPER_L, PAPER_DELTA, PAPER_D, SMALL_MATTRESS
>>> round(PAPER_L - 2 * PAPER_DELTA, 3), SMALL_MATTRESS
(0.264, (0.83, 0.74))
"""

__all__ = ["PAPER_L", "PAPER_DELTA", "PAPER_D", "PAPER_DELTA_SD", "PAPER_D_SD",
           "SMALL_MATTRESS", "LARGE_MATTRESS", "CUT_TOLERANCE"]

PAPER_L = 0.300         #: geodesic distance L between a string's ends (m)
PAPER_DELTA = 0.018     #: slip Δ of each string end toward the other (m)
PAPER_D = 0.070         #: inflated thickness d of the paper's mattresses (m)
PAPER_DELTA_SD = 0.003  #: nominal 1-sigma of Δ without a calibration (m), stated, not measured
PAPER_D_SD = 0.005      #: nominal 1-sigma of d without a calibration (m), stated, not measured

SMALL_MATTRESS = (0.83, 0.74)  #: (W, H) of the paper's small mattress (m)
LARGE_MATTRESS = (2.60, 1.60)  #: (W, H) of the paper's large mattress (m)

#: default cut tolerance (m): a string re-tied at the same nodes whose length changes by at most this
#: is kept as it is (``airmat retie --cut-tolerance-mm``)
CUT_TOLERANCE = 1e-3
