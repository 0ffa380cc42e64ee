"""The covariance of the strings' simulated rest lengths: what a built mattress's strings differ by.

Three independent sources, each pushed to the simulated rest length l* the
inflation takes (:mod:`airmat.check.length_map`):

1. **Posterior** (correlated between strings): every posterior sample (Δ_s, d_s)
   of the calibration bends each string to κ₁(l_i; Δ_s, d_s) (Equation 3, clipped
   to [0, κ_max] of the median), and the length that makes that curvature at the
   design's median (Δ̄, d̄) is l_i + l(κ_s,i; Δ̄, d̄) − l(κ̄_i; Δ̄, d̄): the chain of
   :func:`airmat.check.monte_carlo.draw` without its per-string scatter. The
   sample covariance of those lengths over the posterior samples (all of them, or
   :data:`MAX_POSTERIOR` evenly spaced) is this part. A calibration with one
   sample (a design folder without ``calibration_samples.npz``) has none.
2. **Scatter σ** (independent per string): a string bends σ z off κ₁, z ~ N(0, 1);
   to first order its length is off by (dl/dκ) σ z, variance (dl/dκ)² E[σ²] over
   the posterior's σ samples (0 when the calibration measured no σ).
3. **Cut and tie** (independent per string): each real length is cut and tied within
   ±t of its design length. ``distribution="uniform"`` (the default): uniform on
   [−t, t], variance t²/3 (a crew that keeps every string within t, as
   ``airmat retie --cut-tolerance-mm`` says); ``"normal"``: N(0, t²), t one
   standard deviation.

Each real-length variance becomes an l* variance through the length map's slope
(1 for l + 2Δ). SI units (m, m²).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from airmat.calib.model import kappa1, kappa_max, string_length
from airmat.check.length_map import length_map
from airmat.errors import InputError

__all__ = ["LengthCovariance", "length_covariance", "CUT_DISTRIBUTIONS", "MAX_POSTERIOR"]

#: the laws of a cut-and-tie error of half-width (uniform) or standard deviation (normal) t
CUT_DISTRIBUTIONS = ("uniform", "normal")
#: posterior samples the covariance is taken over at most (its relative standard error is about
#: sqrt(2 / n): 2 % at 4000)
MAX_POSTERIOR = 4000


@dataclass(frozen=True)
class LengthCovariance:
    """Covariance of the simulated rest lengths l*, by source (m²).

    Attributes
    ----------
    posterior : ndarray of shape (k, k)
        From the posterior of (Δ, d) through Equation 3 (correlated between strings).
    scatter : ndarray of shape (k,)
        Variance from the per-string scatter σ (independent).
    cut : ndarray of shape (k,)
        Variance from the cut-and-tie error (independent).
    cut_tolerance : float
        t (m).
    cut_distribution : str
        ``"uniform"`` (±t) or ``"normal"`` (σ = t).
    sigma_source : str
        ``"posterior"`` or ``"none"`` (the calibration measured no σ).
    """

    posterior: np.ndarray
    scatter: np.ndarray
    cut: np.ndarray
    cut_tolerance: float = 0.0
    cut_distribution: str = "uniform"
    sigma_source: str = "none"

    @property
    def total(self) -> np.ndarray:
        """The whole covariance, shape (k, k) (m²)."""
        return self.posterior + np.diag(self.scatter + self.cut)

    @property
    def sd(self) -> np.ndarray:
        """Standard deviation of each string's l*, shape (k,) (m)."""
        return np.sqrt(np.maximum(np.diag(self.total), 0.0))


def _slope(fn, x, h):
    """Central difference of a vectorized ``fn`` at ``x`` with step ``h`` (same shapes)."""
    return (fn(x + h) - fn(x - h)) / (2.0 * h)


def length_covariance(design, *, lengths=None, cut_tolerance: float = 0.0,
                      cut_distribution: str = "uniform") -> LengthCovariance:
    """The covariance of a design's simulated string lengths (see the module's three sources).

    Parameters
    ----------
    design : airmat.design.pipeline.DesignResult
    lengths : LengthMap or CalibratedLengthMap, optional
        Real -> simulated length; default ``length_map(design.calibration)``.
    cut_tolerance : float
        t (m) of the cut-and-tie error, >= 0.
    cut_distribution : {"uniform", "normal"}

    Returns
    -------
    LengthCovariance
    """
    if cut_distribution not in CUT_DISTRIBUTIONS:
        raise InputError(f"cut_distribution {cut_distribution!r}: expected one of {CUT_DISTRIBUTIONS}")
    if not (np.isfinite(cut_tolerance) and cut_tolerance >= 0):
        raise InputError(f"the cut tolerance must be >= 0 m, got {cut_tolerance!r}")
    cal, strings = design.calibration, design.pattern.strings
    lengths = length_map(cal) if lengths is None else lengths
    l_med = np.array([s.l_median for s in strings], float)
    span = np.array([s.eq3_span for s in strings], float)
    d_bar, delta_bar = float(np.median(cal.d)), cal.delta_median
    k_bar = kappa1(l_med, span, delta_bar, d_bar)
    k_top = kappa_max(span, delta_bar, d_bar)

    def length_of(kappa):          # Equation 3 inverted at the median, as a change from l_med (monte_carlo.draw)
        k = np.clip(kappa, 0.0, k_top)
        return np.maximum(l_med + string_length(k, span, delta_bar, d_bar)
                          - string_length(k_bar, span, delta_bar, d_bar), 0.0)

    pick = np.unique(np.linspace(0, cal.n_samples - 1, min(cal.n_samples, MAX_POSTERIOR)).round().astype(int))
    post = np.zeros((len(strings), len(strings)))
    if pick.size >= 2 and len(strings):
        k = kappa1(l_med[None, :], span[None, :], cal.delta[pick, None], cal.d[pick, None])
        post = np.atleast_2d(np.cov(lengths.to_simulated(length_of(k)), rowvar=False))
    h_l = 1e-4 * np.maximum(l_med, 1e-3)
    map_slope = _slope(lengths.to_simulated, l_med, h_l) if len(strings) else np.zeros(0)
    has_sigma = cal.sigma is not None and len(strings) > 0
    scatter = np.zeros(len(strings))
    if has_sigma:
        h_k = 1e-3 * np.maximum(k_top, 1.0)
        lo, hi = np.clip(k_bar - h_k, 0.0, k_top), np.clip(k_bar + h_k, 0.0, k_top)
        dl_dk = np.divide(length_of(hi) - length_of(lo), hi - lo, out=np.zeros_like(lo), where=hi > lo)
        scatter = (map_slope * dl_dk) ** 2 * float(np.mean(np.asarray(cal.sigma, float) ** 2))
    var_cut = cut_tolerance ** 2 / 3.0 if cut_distribution == "uniform" else cut_tolerance ** 2
    return LengthCovariance(posterior=post, scatter=scatter, cut=map_slope ** 2 * var_cut,
                            cut_tolerance=float(cut_tolerance), cut_distribution=cut_distribution,
                            sigma_source="posterior" if has_sigma else "none")
