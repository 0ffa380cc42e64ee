"""Statistics of full samples in antithetic pairs against a linear model: the mean shift, the spread's ratio.

The validation of the linear tolerance (:mod:`airmat.check.tolerance_validation`) draws each length change
δl* with its negative (:func:`antithetic`). A pair's mean change cancels the response's odd part and leaves
its even part, an unbiased sample of the nonlinear mean shift (:func:`pair_statistics`); the changes'
variance about their mean over the model's for the same δl* is a ratio estimator with a standard error from
the pairs (:func:`variance_ratio`), shrunk toward 1 into the spread's scale (:func:`spread_scale`); and the
shift's effect on the RMS has a standard error from the scatter between pairs (:func:`rms_shift_se`). Pure
functions over arrays; lengths in m.
"""

from __future__ import annotations

import numpy as np

__all__ = ["antithetic", "pair_statistics", "variance_ratio", "spread_scale", "rms_shift_se"]


def antithetic(delta: np.ndarray) -> np.ndarray:
    """Each change followed by its negative: rows δ₁, −δ₁, δ₂, −δ₂, ...

    Parameters
    ----------
    delta : ndarray of shape (p, k)

    Returns
    -------
    ndarray of shape (2 p, k)

    Examples
    --------
    >>> antithetic(np.array([[1.0, 2.0]])).tolist()
    [[1.0, 2.0], [-1.0, -2.0]]
    """
    d = np.asarray(delta, float)
    return np.stack([d, -d], axis=1).reshape(-1, d.shape[1])


def pair_statistics(changes: np.ndarray, predicted: np.ndarray) -> tuple:
    """The antithetic pairs' mean shift and the relative error of the predicted spread.

    Parameters
    ----------
    changes : ndarray of shape (2 p, N, 3)
        d_s = e(δ_s) − e₀ of full samples at δ₁, −δ₁, δ₂, −δ₂, ... (m).
    predicted : ndarray of shape (2 p, N, 3)
        A δ_s (m).

    Returns
    -------
    shift : ndarray of shape (N, 3)
        m̂ = the mean of d_s: the odd part of the response cancels in each pair, so m̂ is the
        mean of the even parts q_j = (d(δ_j) + d(−δ_j)) / 2 (m).
    spread_error : float
        sqrt(Σ_s ‖d_s − m̂‖² / Σ_s ‖A δ_s‖²) − 1: how far the spread about the mean is off the
        linear prediction's, relatively (nan without spread).
    pairs_shift : ndarray of shape (p, N, 3)
        q_j − e₀'s change, each pair's own estimate of the shift (m).

    Examples
    --------
    >>> p = np.array([[[1.0, 0, 0]], [[-1.0, 0, 0]]])
    >>> shift, err, _ = pair_statistics(p + [0, 0, 0.5], p)     # linear plus a constant: exact spread
    >>> shift.tolist(), err
    ([[0.0, 0.0, 0.5]], 0.0)
    """
    d = np.asarray(changes, float)
    pairs = d.reshape(-1, 2, *d.shape[1:]).mean(axis=1)
    shift = pairs.mean(axis=0)
    den = float(np.sum(np.asarray(predicted, float) ** 2))
    err = float(np.sqrt(np.sum((d - shift) ** 2) / den) - 1.0) if den > 0 else float("nan")
    return shift, err, pairs


def variance_ratio(changes: np.ndarray, predicted: np.ndarray) -> tuple:
    """The samples' variance about their mean over the linear model's, with its standard error from the pairs.

    Pair j's samples d(±δ_j) split into the odd part o_j = (d(δ_j) − d(−δ_j)) / 2 and the even part
    q_j = (d(δ_j) + d(−δ_j)) / 2. The variance of a full sample about the mean is E‖o‖² + Var q; with p
    pairs it is estimated without bias by Σ_j 2‖o_j‖² + p / (p − 1) · Σ_j 2‖q_j − q̄‖² (the even parts'
    scatter about their own mean is (p − 1) / p of theirs), over the model's Σ_j 2‖A δ_j‖² for the same
    δ_j: R̂ = N / D, a ratio estimator. Paired on the same δ_j, the sampling error of the odd part's
    squared norm largely cancels in it; its standard error comes from the pairs' residuals,
    se = sqrt(Σ_j (N_j − R̂ D_j)² / (p (p − 1))) / D̄ (the delta method).

    Parameters
    ----------
    changes : ndarray of shape (2 p, N, 3)
        d_s = e(δ_s) − e₀ of full samples at δ₁, −δ₁, δ₂, −δ₂, ... (m).
    predicted : ndarray of shape (2 p, N, 3)
        A δ_s (m).

    Returns
    -------
    ratio : float
        R̂ (nan without predicted spread).
    per_pair : ndarray of shape (p,)
        Each pair's influence value R̂ + (N_j − R̂ D_j) / D̄, whose mean is R̂ and whose scatter gives se.
    se : float
        Standard error of R̂ (nan with fewer than 2 pairs).

    Examples
    --------
    >>> p = np.array([[[1.0, 0, 0]], [[-1.0, 0, 0]], [[2.0, 0, 0]], [[-2.0, 0, 0]]])
    >>> r, per, se = variance_ratio(0.9 * p + [0, 0, 0.5], p)     # a spread 0.9 times the model's
    >>> round(r, 6), round(se, 6)
    (0.81, 0.0)
    """
    d = np.asarray(changes, float)
    pr = np.asarray(predicted, float)
    p = len(d) // 2
    dd = d.reshape(p, 2, -1)
    odd, even = 0.5 * (dd[:, 0] - dd[:, 1]), dd.mean(axis=1)
    c = p / (p - 1) if p > 1 else 1.0
    num = 2 * np.sum(odd ** 2, axis=1) + c * 2 * np.sum((even - even.mean(axis=0)) ** 2, axis=1)
    den = np.sum(pr.reshape(p, 2, -1) ** 2, axis=(1, 2))
    if not den.sum() > 0:
        return float("nan"), np.full(p, np.nan), float("nan")
    ratio = float(num.sum() / den.sum())
    per = ratio + (num - ratio * den) / den.mean()
    se = float(np.std(per, ddof=1) / np.sqrt(p)) if p > 1 else float("nan")
    return ratio, per, se


def spread_scale(ratio: float, se: float) -> float:
    """The factor of the model's change: sqrt of the variance ratio shrunk toward 1 by its standard error.

    R̂ − 1 is shrunk by the factor (R̂ − 1)² / ((R̂ − 1)² + se²), the posterior mean of R − 1 under a
    normal prior of variance (R̂ − 1)² (empirical Bayes): a ratio known to within its distance from 1
    is taken almost whole, one within its noise of 1 stays near 1. No correction (1) without a standard
    error (fewer than 2 pairs) or a ratio.

    Examples
    --------
    >>> spread_scale(0.81, 0.0), spread_scale(0.81, float("nan"))
    (0.9, 1.0)
    >>> round(spread_scale(0.81, 0.19), 4)       # one standard error from 1: half the way, sqrt(0.905)
    0.9513
    """
    if not (np.isfinite(ratio) and np.isfinite(se) and ratio > 0):
        return 1.0
    gap = ratio - 1.0
    w = gap ** 2 / (gap ** 2 + se ** 2) if gap != 0 else 0.0
    return float(np.sqrt(1.0 + w * gap))


def rms_shift_se(base: np.ndarray, pairs: np.ndarray, spread: float, ratios: np.ndarray | None = None) -> float:
    """Standard error of the sampled mean shift's (and spread's) effect on the RMS, from the scatter of the pairs.

    Pair j alone moves the RMS of a draw of typical spread by
    Δ_j = sqrt(⟨|e₀ + q_j|²⟩ + r_j v) − sqrt(⟨|e₀|²⟩ + v), v the mean squared change of the model and
    r_j pair j's value of the variance ratio (:func:`variance_ratio`; 1 when not given);
    the standard error of their mean is sd(Δ_j) / sqrt(p).

    Parameters
    ----------
    base : ndarray of shape (N, 3)
        e₀ (m).
    pairs : ndarray of shape (p, N, 3)
        Each pair's shift estimate (:func:`pair_statistics`) (m).
    spread : float
        v = tr(A Σ Aᵀ) / N (m²).
    ratios : ndarray of shape (p,), optional
        r_j, each pair's influence value of the variance ratio.

    Returns
    -------
    float
        (m); nan with fewer than 2 pairs.

    Examples
    --------
    >>> e0 = np.zeros((4, 3))
    >>> round(rms_shift_se(e0, np.stack([e0 + [0, 0, 1.0], e0 + [0, 0, 3.0]]), 0.0), 6)
    1.0
    """
    if len(pairs) < 2:
        return float("nan")
    e0 = np.asarray(base, float)
    r = np.ones(len(pairs)) if ratios is None else np.asarray(ratios, float)
    moved = np.sqrt(np.maximum(np.mean(np.sum((e0 + pairs) ** 2, axis=2), axis=1) + r * spread, 0.0))
    at = np.sqrt(np.mean(np.sum(e0 ** 2, axis=1)) + spread)
    return float(np.std(moved - at, ddof=1) / np.sqrt(len(pairs)))
