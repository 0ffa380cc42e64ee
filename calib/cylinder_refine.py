"""Full-resolution robust refinement of a cylinder, leaving the string-end grooves out.

Starting from a cylinder fitted to a downsampled cloud, rounds on a random
subset of the full-resolution points select the points near the surface,
drop the groove bands (:mod:`airmat.calib.groove_bands`), and refit
(:func:`airmat.calib.cylinder_irls.polish`) until the selection settles; then one
pass on every point. Also the working residual scale: the local noise, or
how far the whole face departs from a cylinder when that is more (a
simulated or wrinkled face). Lengths in metres.
"""

from __future__ import annotations

import numpy as np

from airmat.errors import NotACylinderError
from airmat.calib.cylinder_irls import polish
from airmat.calib.cylinder_lsq import arc_from_local, distance_from_local, residuals
from airmat.calib.groove_bands import groove_bands

__all__ = ["surface_spread", "full_resolution_fit"]

#: fewest points a refit needs
MIN_POINTS = 50


def surface_spread(points, frame, sigma, band_sigmas, seed) -> float:
    """Robust residual scale (m) of the surface off the groove bands (coarse tolerance).

    Grooves are left out first: they are local and handled by the bands; what
    remains measures how far the whole face departs from the cylinder.
    """
    e = residuals(points, frame)
    near = np.abs(e) < 2 * band_sigmas * sigma
    if near.sum() < MIN_POINTS:
        return sigma
    idx = np.flatnonzero(near)
    near[idx[groove_bands(points[idx], frame, sigma=sigma, seed=seed, tol_sigmas=1.0).excluded]] = False
    return _residual_scale(e[near | (np.abs(e) >= 2 * band_sigmas * sigma)], sigma)


def _residual_scale(e: np.ndarray, sigma: float, n_doublings: int = 8) -> float:
    """Robust scale (1.4826 MAD) of residuals ``e`` (m), in a band widened until it holds them.

    Starts at ten noise levels (far clutter stays out); while the scale fills a
    fifth of the band (the residuals are wider than the noise), the band doubles.
    """
    band = 10.0 * sigma
    scale = sigma
    for _ in range(n_doublings):
        inside = np.abs(e) < band
        if inside.sum() < MIN_POINTS:
            band *= 2.0
            continue
        scale = 1.4826 * float(np.median(np.abs(e[inside])))
        if scale < band / 5.0:
            break
        band *= 2.0
    return scale


def full_resolution_fit(cand, frame, *, sigma, band_sigmas, loss, f_scale, n_subsample, groove_sigmas, rng,
                        hold_axis, n_rounds=5):
    """Robust fit on the full-resolution points near the surface.

    Rounds on a random subset of at most ``n_subsample`` points: select the
    points within the band minus the groove bands
    (:func:`airmat.calib.groove_bands.groove_bands`, coarse to fine: the band
    tolerance shrinks to ``groove_sigmas`` over the first rounds, so that a
    start that followed a groove is pulled off it first) and refit, until
    the selection settles; then the same selection on every point and
    Gauss-Newton steps on all of them (:func:`airmat.calib.cylinder_irls.polish`,
    which starts within the subsample's sampling error of the optimum).
    """
    sub = cand[rng.choice(len(cand), n_subsample, replace=False)] if len(cand) > n_subsample else cand
    seed = int(rng.integers(2**31))
    n_iter, used = 0, None
    tols = [max(groove_sigmas, t) for t in (1.0, 0.5)] + [groove_sigmas] * n_rounds
    for r in range(n_rounds):
        keep, grooves = _select(sub, frame, sigma, band_sigmas, tols[r], seed)
        settled = r >= 2 and np.count_nonzero(keep != used) < 1e-3 * len(sub)
        used = keep
        result = polish(sub[keep], frame, f_scale=f_scale, loss=loss, hold_axis=hold_axis)
        n_iter += result.n_iter
        frame = result.frame
        if settled:
            break
    if sub is not cand:
        X, Z = frame.local(cand)  # one pass gives the residuals and the arc positions
        keep = np.abs(distance_from_local(X, Z, frame.kappa)) < band_sigmas * sigma
        idx = np.flatnonzero(keep)
        keep[idx[grooves.classify_arc(arc_from_local(np.compress(keep, X), np.compress(keep, Z), frame.kappa))]] = False
        # the subset's fit is off by its own sampling error, sqrt(N / n) full-set errors
        trust = 3.0 * np.sqrt(np.count_nonzero(keep) / max(np.count_nonzero(used), 1))
        # np.compress: cand[keep], 4x faster on (N, 3)
        result = polish(np.compress(keep, cand, axis=0), frame, f_scale=f_scale, loss=loss, max_iter=8,
                        hold_axis=hold_axis, trust_one_step=trust)
        n_iter += result.n_iter
        frame = result.frame
    return frame, result, keep, n_iter


def _select(points, frame, sigma, band_sigmas, groove_tol, seed):
    """(N,) bool: points within ``band_sigmas`` noise levels of the surface, outside groove bands."""
    e = residuals(points, frame)
    near = np.abs(e) < band_sigmas * sigma
    if near.sum() < MIN_POINTS:
        raise NotACylinderError(f"only {int(near.sum())} points within {band_sigmas:g} noise "
                                f"levels of the fitted cylinder")
    idx = np.flatnonzero(near)
    grooves = groove_bands(points[idx], frame, sigma=sigma, seed=seed, tol_sigmas=groove_tol)
    near[idx[grooves.excluded]] = False
    return near, grooves
