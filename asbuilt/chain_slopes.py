"""The chain from a world to the simulated rest lengths, differentiated, and the prior of (Δ, d, e) it induces.

A world is θ = (Δ, d) of Equation 3, each string's effective length error e_i (cut and tie) and
its curvature offset z_i (the string-to-string scatter σ); :func:`airmat.check.string_world.world_strings`
carries it to the rest lengths the simulator uses. The as-built update (:mod:`airmat.asbuilt.update`)
and the correction (:mod:`airmat.asbuilt.correction`) need that chain's slopes: R_θ = ∂rest/∂(Δ, d),
D_e = ∂rest_i/∂e_i and ∂rest_i/∂z_i, by central differences of one batched call; and the prior the
calibration and the cut tolerance put on (θ, e) (:func:`length_prior`).

SI units (m, 1/m) throughout.
"""

from __future__ import annotations

import numpy as np

from airmat.check.string_world import world_strings
from airmat.errors import InputError

__all__ = ["world_slopes", "error_slope", "length_prior", "CLIPPED_SLOPE"]

#: ∂rest/∂e below this: the string is clipped by Equation 3 (slack, or at its largest curvature)
CLIPPED_SLOPE = 1e-6


def world_slopes(design, theta, error, *, strings=None) -> tuple:
    """∂rest/∂(Δ, d) (k, 2), ∂rest_i/∂e_i (k,) and ∂rest_i/∂z_i (k,) at one world (central differences).

    Parameters
    ----------
    design : airmat.design.pipeline.DesignResult
    theta : ndarray of shape (2,)
        (Δ, d) (m).
    error : ndarray of shape (k,)
        Effective length errors (m).
    strings : sequence of TensionString, optional
        Default the design's.

    Returns
    -------
    tuple of ndarray
        Unitless (m/m) for Δ, d and e; m per 1/m for the curvature offset z.
    """
    theta, error = np.asarray(theta, float), np.asarray(error, float)
    h = 1e-5 * max(float(np.max(np.abs(theta))), 1e-3)
    hk = 1e-3
    # the eight worlds of the central differences in one batched chain: Δ ± h, d ± h, e ± h, z ± hk
    delta = theta[0] + h * np.array([1.0, -1.0, 0, 0, 0, 0, 0, 0])
    d = theta[1] + h * np.array([0, 0, 1.0, -1.0, 0, 0, 0, 0])
    e = error[None, :] + h * np.array([0, 0, 0, 0, 1.0, -1.0, 0, 0])[:, None]
    z = hk * np.array([0, 0, 0, 0, 0, 0, 1.0, -1.0])[:, None]
    r = world_strings(design, delta, d, cut_error=e, kappa_offset=z, strings=strings).rest
    r_theta = np.column_stack([(r[0] - r[1]) / (2 * h), (r[2] - r[3]) / (2 * h)])
    return r_theta, (r[4] - r[5]) / (2 * h), (r[6] - r[7]) / (2 * hk)


def error_slope(design, theta, error, *, strings=None) -> np.ndarray:
    """∂rest_i/∂e_i (k,) at one world: :func:`world_slopes`'s second part alone (two worlds of the chain).

    Parameters are those of :func:`world_slopes`.
    """
    theta, error = np.asarray(theta, float), np.asarray(error, float)
    h = 1e-5 * max(float(np.max(np.abs(theta))), 1e-3)
    r = world_strings(design, np.full(2, theta[0]), np.full(2, theta[1]),
                      cut_error=error[None, :] + h * np.array([1.0, -1.0])[:, None], strings=strings).rest
    return (r[0] - r[1]) / (2 * h)


def length_prior(design, cut_tolerance: float, cut_distribution: str):
    """(θ mean (2,), θ covariance (2, 2), s (k,)) of the prior (m, m², m)."""
    cal = design.calibration
    if cal.n_samples < 2:
        raise InputError("the design's calibration has fewer than 2 posterior samples: no prior covariance of "
                         "(delta, d) to update", n_samples=cal.n_samples)
    mean = np.array([np.mean(cal.delta), np.mean(cal.d)])
    cov = np.atleast_2d(np.cov(np.column_stack([cal.delta, cal.d]), rowvar=False))
    k = len(design.pattern.strings)
    median = np.array([cal.delta_median, float(np.median(cal.d))])
    _, d_e, d_z = world_slopes(design, median, np.zeros(k))
    var = np.full(k, cut_tolerance ** 2 / 3.0 if cut_distribution == "uniform" else cut_tolerance ** 2)
    if cal.sigma is not None:
        ratio = np.divide(d_z, d_e, out=np.zeros(k), where=np.abs(d_e) > 1e-9)
        var = var + ratio ** 2 * float(np.mean(np.asarray(cal.sigma, float) ** 2))
    return mean, cov, np.sqrt(var)
