"""The calibrated curve kappa_1(l / L) with posterior confidence bands.

The designer turns curvatures into string lengths with Equation 3; this
module pushes the posterior of (Delta, d) through Equation 3 on a grid of
l / L to give the median curve and its 68% and 95% bands.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from airmat.calib.model import kappa1

__all__ = ["KappaCurve", "kappa_curve", "most_common_L"]


@dataclass(frozen=True)
class KappaCurve:
    """kappa_1 against l / L for one string spacing L.

    Attributes
    ----------
    L : float
        Geodesic distance of the string ends (m).
    l_over_L : ndarray of shape (G,)
        Grid of string length over L, from 0 to 1.
    median, lo68, hi68, lo95, hi95 : ndarray of shape (G,)
        Posterior median and central 68% / 95% bands of kappa_1 (1/m).
    n_draws : int
        Number of posterior draws the bands are computed from.
    """

    L: float
    l_over_L: np.ndarray
    median: np.ndarray
    lo68: np.ndarray
    hi68: np.ndarray
    lo95: np.ndarray
    hi95: np.ndarray
    n_draws: int


def most_common_L(L) -> float:
    """The most frequent value of L (m) among the specimens (the smallest on a tie)."""
    values, counts = np.unique(np.round(np.asarray(L, float), 9), return_counts=True)
    return float(values[np.argmax(counts)])


def kappa_curve(samples, L: float, *, n_grid: int = 101, max_draws: int = 2000,
                seed=0) -> KappaCurve:
    """Posterior median and bands of kappa_1 on an l / L grid over [0, 1].

    Parameters
    ----------
    samples : ndarray of shape (n, >= 2)
        Posterior draws; columns 0 and 1 are Delta and d (m).
    L : float
        String-end distance of the curve (m).
    n_grid : int
        Grid points over l / L in [0, 1].
    max_draws : int
        The posterior is subsampled (without replacement, seeded) to at most
        this many draws; Equation 3 is evaluated once on (draws, grid).
    seed : int or numpy.random.Generator
        Seeds the subsampling.

    Returns
    -------
    KappaCurve
        Bands in 1/m.
    """
    samples = np.asarray(samples, dtype=float)
    rng = np.random.default_rng(seed)
    if samples.shape[0] > max_draws:
        samples = samples[rng.choice(samples.shape[0], size=max_draws, replace=False)]
    grid = np.linspace(0.0, 1.0, n_grid)
    k = kappa1(grid[None, :] * L, L, samples[:, :1], samples[:, 1:2])  # (draws, grid)
    lo95, lo68, med, hi68, hi95 = np.percentile(k, [2.5, 16.0, 50.0, 84.0, 97.5], axis=0)
    return KappaCurve(L=float(L), l_over_L=grid, median=med, lo68=lo68, hi68=hi68,
                      lo95=lo95, hi95=hi95, n_draws=int(samples.shape[0]))
