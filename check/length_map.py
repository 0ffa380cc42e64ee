"""The one place where a real string length becomes the simulator's rest length, and back.

A real string of length l, tied to the mattress's grid, slips by Δ at each end
(Equation 3's l* = l + 2Δ); the simulated ends do not slip, so the simulator
is given l*: :class:`LengthMap`. The simulator does not bend exactly as
Equation 3 says (``airmat validate``), so :class:`CalibratedLengthMap` instead
gives each real length the simulated rest length at which the simulated
specimen bends to the calibrated κ₁ (Equation 3 with the posterior median's
Δ and d), from a table of simulated specimens (:mod:`airmat.check.calibrated_map`,
where that map and its table are defined; :func:`length_map` picks one of the two).
Every conversion between a real length and a simulated one goes through one
of these maps: the check, the envelope (each lo95 / hi95 length through the
same map) and any later refinement. SI units (m).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from airmat.errors import InputError
from airmat.check.calibrated_map import CalibratedLengthMap, calibrated_length_map

__all__ = ["LengthMap", "CalibratedLengthMap", "length_map"]


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


def length_map(calibration, *, calibrated: bool = False, resolution: float | None = None,
               thickness: float | None = None, params=None, workers: int = 1, cache: bool = True):
    """The map of a design's calibration.

    Parameters
    ----------
    calibration : airmat.design.calibration_source.CalibrationSource
    calibrated : bool
        False: :class:`LengthMap` with Δ the posterior median (Equation 3's l + 2Δ).
        True: :class:`CalibratedLengthMap` built from simulated specimens at the
        calibration's L (:func:`airmat.check.calibrated_map.calibrated_length_map`; cached on disk).
    resolution : float
        Mesh edge length (m) of the specimens; required when ``calibrated``.
    thickness : float, optional
        Mattress thickness (m) of the specimens; default the posterior median of d.
    params : airmat.inflation.model.Parameters, optional
    workers : int
        Processes for the specimen inflations.
    cache : bool
        Read and write the on-disk cache.

    Returns
    -------
    LengthMap or CalibratedLengthMap
    """
    if not calibrated:
        return LengthMap(delta=calibration.delta_median)
    if resolution is None or not resolution > 0:
        raise InputError(f"the calibrated length map needs a resolution > 0 m, got {resolution!r}")
    d = float(np.median(calibration.d))
    return calibrated_length_map(L=float(calibration.L), delta=calibration.delta_median, d=d,
                                 thickness=d if thickness is None else float(thickness), resolution=float(resolution),
                                 params=params, workers=workers, cache=cache)
