"""What each string does in a world whose mattress is not the design's median: the one chain from
(Δ, d, a curvature offset, a cut error) to the simulator's rest length.

A string cut to the real length l_i + e_i (its median length and a cut or tie
error e_i) on a mattress whose Equation 3 has (Δ, d) bends it to

    κ_i = κ₁(l_i + e_i; Δ, d) + z_i,

z_i being the string's own scatter (clipped to [0, κ_max] of the design's
median). The simulator is calibrated at the design's median (Δ̄, d̄), so that
string is simulated at the length that bends the median mattress to κ_i, as a
change from the median:

    l'_i = l_i + l(κ_i; Δ̄, d̄) − l(κ₁(l_i; Δ̄, d̄); Δ̄, d̄)     (Equation 3 inverted),

and its rest length is the design's real-to-simulated map of l'_i
(:func:`airmat.check.length_map.length_map`). A world equal to the median gives
the median rest lengths exactly. Used by the Monte-Carlo draws
(:mod:`airmat.check.monte_carlo`: one posterior sample per world) and by the
synthetic as-built mattress (:mod:`airmat.asbuilt.true_world`: one "true" world).
SI units.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from airmat.calib.model import kappa1, kappa_max, string_length
from airmat.check.length_map import length_map

__all__ = ["WorldStrings", "world_strings"]


@dataclass(frozen=True)
class WorldStrings:
    """The strings of a design in one or more worlds.

    Attributes
    ----------
    kappa : ndarray of shape (..., k)
        Curvature each string produces (1/m, unsigned).
    kappa_median : ndarray of shape (k,)
        κ₁ of each string at its median length and the design's median (Δ̄, d̄) (1/m).
    length : ndarray of shape (..., k)
        Real length that produces ``kappa`` on the median mattress (m).
    rest : ndarray of shape (..., k)
        Simulated rest length l* of ``length`` (m).
    """

    kappa: np.ndarray
    kappa_median: np.ndarray
    length: np.ndarray
    rest: np.ndarray


def world_strings(design, delta, d, *, cut_error=0.0, kappa_offset=0.0, lengths=None,
                  strings=None) -> WorldStrings:
    """Each string's curvature, median-equivalent length and rest length in the world(s) (Δ, d).

    Parameters
    ----------
    design : airmat.design.pipeline.DesignResult
    delta, d : float or ndarray of shape (K,)
        Δ and d of Equation 3 in each world (m).
    cut_error : float or ndarray broadcastable to (K, k)
        Real length of each string minus its median length (m): cut and tie errors.
    kappa_offset : float or ndarray broadcastable to (K, k)
        Each string's own curvature scatter z_i (1/m).
    lengths : LengthMap or CalibratedLengthMap, optional
        Real -> simulated map; default ``length_map(design.calibration)``.
    strings : sequence of TensionString, optional
        Default the design's pattern strings.

    Returns
    -------
    WorldStrings
        With a leading axis of K when ``delta``/``d`` are arrays, none for scalars.

    """
    cal = design.calibration
    strings = design.pattern.strings if strings is None else strings
    l_med = np.array([s.l_median for s in strings], float)
    span = np.array([s.eq3_span for s in strings], float)       # the span each length came from
    d_bar, delta_bar = float(np.median(cal.d)), cal.delta_median
    k_bar = kappa1(l_med, span, delta_bar, d_bar)
    k_top = kappa_max(span, delta_bar, d_bar)
    delta, d = np.asarray(delta, float), np.asarray(d, float)
    lead = (slice(None), None) if delta.ndim else (Ellipsis,)
    k = kappa1(l_med + np.asarray(cut_error, float), span, delta[lead], d[lead]) + np.asarray(kappa_offset, float)
    k = np.clip(k, 0.0, k_top)
    change = string_length(k, span, delta_bar, d_bar) - string_length(k_bar, span, delta_bar, d_bar)
    length = np.maximum(l_med + change, 0.0)
    rest = (length_map(cal) if lengths is None else lengths).to_simulated(length)
    return WorldStrings(kappa=k, kappa_median=k_bar, length=length, rest=rest)
