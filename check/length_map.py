"""The one place where a real string length becomes the simulator's rest length, and back.

A real string of length l, tied to the mattress's grid, slips by Δ at each end
(Equation 3's l* = l + 2Δ); the simulated ends do not slip, so the simulator
is given l*: :class:`LengthMap`. The simulator does not bend exactly as
Equation 3 says (``airmat validate``), so :class:`CalibratedLengthMap` instead
gives each real length the simulated rest length at which the simulated
specimen bends to the calibrated κ₁ (Equation 3 with the posterior median's
Δ and d), from a table of simulated specimens (:mod:`airmat.check.calibrated_map`).
Every conversion between a real length and a simulated one goes through one
of these maps: the check, the envelope (each lo95 / hi95 length through the
same map) and any later refinement. SI units (m).
"""

from __future__ import annotations

import logging
from dataclasses import dataclass

import numpy as np

__all__ = ["LengthMap", "CalibratedLengthMap", "length_map"]

log = logging.getLogger(__name__)


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


@dataclass(frozen=True)
class CalibratedLengthMap:
    """Real string length -> simulated rest length through a table of simulated specimens (m).

    Between the table's rows the map is a monotone cubic (PCHIP) of l_sim / L
    over l / L, and its inverse that cubic's exact inverse (bisection). Outside
    the table each end continues with slope 1 (a constant end slip, l* = l + s
    with s the end row's l_sim − l; the last row is Equation 3's flat length
    L − 2Δ at the simulator's flat length L, so above the table s = 2Δ), and
    says so in the log.

    Attributes
    ----------
    L : float
        String spacing of the specimens (m).
    l_real, l_sim : ndarray of shape (n,)
        The table, both strictly increasing (m).
    delta : float
        Δ (m) of the calibration median the table reproduces.
    d : float
        Equation 3's d (m) of the calibration median.
    resolution, thickness : float
        Mesh edge length and mattress thickness (m) the specimens were simulated at.
    """

    L: float
    l_real: np.ndarray
    l_sim: np.ndarray
    delta: float
    d: float
    resolution: float
    thickness: float

    def __post_init__(self):
        from airmat.errors import InputError

        r, s = np.asarray(self.l_real, float), np.asarray(self.l_sim, float)
        if r.ndim != 1 or r.shape != s.shape or r.size < 2:
            raise InputError(f"length table: expected two arrays of shape (n,), n >= 2; got {r.shape} and {s.shape}")
        if not (np.all(np.diff(r) > 0) and np.all(np.diff(s) > 0)):
            raise InputError("length table: real and simulated lengths must both increase strictly",
                             l_real=r, l_sim=s)
        object.__setattr__(self, "l_real", r)
        object.__setattr__(self, "l_sim", s)

    def _forward(self, x):
        from scipy.interpolate import PchipInterpolator

        return PchipInterpolator(self.l_real / self.L, self.l_sim / self.L, extrapolate=False)(x / self.L) * self.L

    def _outside(self, x, xs, ys, inside, what):
        """``inside`` where x lies in [xs[0], xs[-1]], else the end rows continued with slope 1."""
        lo, hi = x < xs[0], x > xs[-1]
        if lo.any() or hi.any():
            log.info("%d %s length(s) outside the calibrated table [%.1f, %.1f] mm: continued with a constant "
                     "end slip", int(lo.sum() + hi.sum()), what, xs[0] * 1e3, xs[-1] * 1e3)
        return np.where(hi, x + (ys[-1] - xs[-1]), np.where(lo, x + (ys[0] - xs[0]), inside))

    def to_simulated(self, l) -> np.ndarray:
        """Simulated rest lengths (m) of real lengths ``l`` (m), any shape, monotone.

        Examples
        --------
        >>> m = CalibratedLengthMap(0.3, np.array([0.1, 0.264]), np.array([0.16, 0.3]), 0.018, 0.07, 0.04, 0.07)
        >>> m.to_simulated([0.1, 0.264, 0.28]).round(4).tolist()
        [0.16, 0.3, 0.316]
        """
        l = np.asarray(l, float)
        return self._outside(l, self.l_real, self.l_sim, self._forward(l), "real")

    def to_real(self, l_sim) -> np.ndarray:
        """Real lengths (m) whose simulated rest length is ``l_sim`` (m): the inverse of :meth:`to_simulated`.

        Examples
        --------
        >>> m = CalibratedLengthMap(0.3, np.array([0.1, 0.264]), np.array([0.16, 0.3]), 0.018, 0.07, 0.04, 0.07)
        >>> bool(np.allclose(m.to_real(m.to_simulated([0.05, 0.2, 0.29])), [0.05, 0.2, 0.29]))
        True
        """
        l_sim = np.asarray(l_sim, float)
        # the exact inverse of the monotone cubic: bisection inside the row interval that holds l_sim
        # (a PCHIP of the swapped rows would differ from the inverse between the rows)
        i = np.clip(np.searchsorted(self.l_sim, l_sim) - 1, 0, self.l_sim.size - 2)
        lo, hi = self.l_real[i], self.l_real[i + 1]
        for _ in range(60):                        # 2^-60 of a row interval: below a nanometre
            mid = 0.5 * (lo + hi)
            below = self._forward(mid) < l_sim
            lo, hi = np.where(below, mid, lo), np.where(below, hi, mid)
        return self._outside(l_sim, self.l_sim, self.l_real, 0.5 * (lo + hi), "simulated")


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
    from airmat.errors import InputError
    from airmat.check.calibrated_map import calibrated_length_map

    if resolution is None or not resolution > 0:
        raise InputError(f"the calibrated length map needs a resolution > 0 m, got {resolution!r}")
    d = float(np.median(calibration.d))
    return calibrated_length_map(L=float(calibration.L), delta=calibration.delta_median, d=d,
                                 thickness=d if thickness is None else float(thickness), resolution=float(resolution),
                                 params=params, workers=workers, cache=cache)
