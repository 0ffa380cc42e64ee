"""The one place where a real string length becomes the simulator's rest length, and back.

A real string of length l, tied to the mattress's grid, slips by Δ at each end
(Equation 3's l* = l + 2Δ); the simulated ends do not slip, so the simulator
is given l*. Every conversion between a real length and a simulated one goes
through a :class:`LengthMap`: the check, the envelope and any later
refinement or Monte-Carlo sampling use the same map. SI units (m).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

__all__ = ["LengthMap", "length_map"]


@dataclass(frozen=True)
class LengthMap:
    """Real string length l -> simulated rest length l* = l + 2Δ (m), monotone both ways.

    Attributes
    ----------
    delta : float
        End slip Δ (m) of each string end.
    """

    delta: float

    def to_simulated(self, l) -> np.ndarray:
        """Simulated rest lengths (m) of real lengths ``l`` (m), any shape.

        Examples
        --------
        >>> LengthMap(0.018).to_simulated([0.2, 0.25]).round(6).tolist()
        [0.236, 0.286]
        """
        return np.asarray(l, float) + 2.0 * self.delta

    def to_real(self, l_sim) -> np.ndarray:
        """Real lengths (m) whose simulated rest length is ``l_sim`` (m): the inverse of :meth:`to_simulated`.

        Examples
        --------
        >>> m = LengthMap(0.018)
        >>> bool(np.allclose(m.to_real(m.to_simulated([0.2, 0.25])), [0.2, 0.25]))
        True
        """
        return np.asarray(l_sim, float) - 2.0 * self.delta


def length_map(calibration) -> LengthMap:
    """The map of a design's calibration: Δ its posterior median.

    Parameters
    ----------
    calibration : design.calibration_source.CalibrationSource

    Returns
    -------
    LengthMap
    """
    return LengthMap(delta=calibration.delta_median)
