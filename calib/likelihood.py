"""The statistical model of the calibration: likelihood and priors of (Delta, d, sigma).

See :mod:`airmat.calib.posterior` for the model in words and the priors; this module
holds the pieces the sampler evaluates: the prior bounds (:class:`Priors`),
the checked data (:class:`SpecimenData`) and the vectorized
:func:`log_probability` (one Equation 3 call per batch of walkers).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from airmat.errors import InputError
from airmat.calib.model import kappa1

__all__ = ["PARAM_NAMES", "folded_normal_logpdf", "Priors", "DEFAULT_PRIORS", "SpecimenData", "specimen_data",
           "log_probability"]

#: parameter order in every (..., 3) array: slip (m), thickness (m), scatter (1/m)
PARAM_NAMES = ("delta", "d", "sigma")


@dataclass(frozen=True)
class Priors:
    """Bounds and shapes of the priors (SI units; stated in :mod:`airmat.calib.posterior`).

    Attributes
    ----------
    delta_max_fraction : float
        Upper bound of the uniform prior on Delta as a fraction of the smallest L.
    d_min, d_max : float
        Bounds of the uniform prior on d (m).
    sigma_scale : float
        Scale of the half-Cauchy prior on sigma (1/m).
    sigma_max : float
        Truncation of the sigma prior (1/m).
    """

    delta_max_fraction: float = 0.2
    d_min: float = 0.005
    d_max: float = 0.5
    sigma_scale: float = 1.0
    sigma_max: float = 20.0

    def bounds(self, L_min: float) -> np.ndarray:
        """Lower and upper bounds, shape (3, 2), in the order of :data:`PARAM_NAMES`."""
        return np.array([[0.0, self.delta_max_fraction * L_min],
                         [self.d_min, self.d_max],
                         [0.0, self.sigma_max]])

    def describe(self, L_min: float) -> dict:
        """The priors in words and numbers (mm and 1/m), for reports."""
        b = self.bounds(L_min)
        return {
            "delta_mm": {"distribution": "uniform", "lo": 0.0, "hi": b[0, 1] * 1e3,
                         "note": f"{self.delta_max_fraction} x smallest L"},
            "d_mm": {"distribution": "uniform", "lo": b[1, 0] * 1e3, "hi": b[1, 1] * 1e3},
            "sigma_per_m": {"distribution": "half-cauchy, truncated", "scale": self.sigma_scale,
                            "lo": 0.0, "hi": self.sigma_max},
            "likelihood": "kappa_i ~ |Normal(kappa1(l_i, L_i; delta, d), s_i^2 + sigma^2)| (folded normal)",
        }


DEFAULT_PRIORS = Priors()


@dataclass(frozen=True)
class SpecimenData:
    """Measured curvatures and string geometry of S specimens (SI).

    Attributes
    ----------
    kappa, kappa_se : ndarray of shape (S,)
        Fitted curvature and its standard error (1/m), ``kappa >= 0``, ``kappa_se > 0``.
    l, L : ndarray of shape (S,)
        String length and geodesic distance of its ends (m).
    """

    kappa: np.ndarray
    kappa_se: np.ndarray
    l: np.ndarray
    L: np.ndarray


def specimen_data(kappa, kappa_se, l, L) -> SpecimenData:
    """Check and pack measured curvatures into a :class:`SpecimenData`.

    Parameters
    ----------
    kappa, kappa_se : array_like of shape (S,)
        Curvature and standard error (1/m).
    l, L : array_like of shape (S,) or scalar
        String length and end distance (m); scalars broadcast.

    Raises
    ------
    airmat.errors.InputError
        On shape mismatch, non-finite values, ``kappa < 0``, ``kappa_se <= 0``,
        ``L <= 0``, ``l < 0``, ``l > L`` or fewer specimens than parameters.
    """
    kappa = np.atleast_1d(np.asarray(kappa, dtype=float))
    if kappa.ndim != 1:
        raise InputError(f"kappa must have shape (S,), got {kappa.shape}", kappa=kappa)
    arrays = [np.broadcast_to(np.asarray(x, dtype=float), kappa.shape).copy()
              for x in (kappa, kappa_se, l, L)] if _broadcastable(kappa, kappa_se, l, L) else None
    if arrays is None:
        raise InputError(f"kappa, kappa_se, l and L must have S={kappa.size} entries each")
    kappa, se, l, L = arrays
    for name, x in (("kappa", kappa), ("kappa_se", se), ("l", l), ("L", L)):
        if not np.all(np.isfinite(x)):
            raise InputError(f"{name} has non-finite values", **{name: x})
    checks = (("kappa >= 0 1/m", kappa >= 0), ("kappa_se > 0 1/m", se > 0),
              ("L > 0 m", L > 0), ("0 <= l <= L", (l >= 0) & (l <= L)))
    for what, ok in checks:
        if not np.all(ok):
            i = int(np.flatnonzero(~ok)[0])
            raise InputError(f"specimen {i}: need {what}", index=i)
    if kappa.size < len(PARAM_NAMES):
        raise InputError(f"{kappa.size} specimens cannot determine {len(PARAM_NAMES)} parameters "
                         f"({', '.join(PARAM_NAMES)}): need at least {len(PARAM_NAMES)}")
    return SpecimenData(kappa=kappa, kappa_se=se, l=l, L=L)


def _broadcastable(kappa, *others) -> bool:
    try:
        return np.broadcast_shapes(kappa.shape, *(np.shape(x) for x in others)) == kappa.shape
    except ValueError:
        return False


def folded_normal_logpdf(x, mu, var):
    """log density of |Normal(mu, var)| at x >= 0; arrays broadcast."""
    norm = -0.5 * np.log(2.0 * np.pi * var)
    return norm + np.logaddexp(-0.5 * (x - mu) ** 2 / var, -0.5 * (x + mu) ** 2 / var)


def log_probability(theta, data: SpecimenData, bounds: np.ndarray, sigma_scale: float) -> np.ndarray:
    """Log posterior (up to a constant) of a batch of parameter vectors.

    Parameters
    ----------
    theta : ndarray of shape (W, 3)
        Rows ``(Delta [m], d [m], sigma [1/m])``, e.g. all walkers of an ensemble.
    data : SpecimenData
        S specimens.
    bounds : ndarray of shape (3, 2)
        Prior bounds (:meth:`Priors.bounds`).
    sigma_scale : float
        Half-Cauchy scale of the sigma prior (1/m).

    Returns
    -------
    ndarray of shape (W,)
        ``-inf`` outside the prior bounds; Equation 3 is evaluated once for the
        (W_inside, S) batch.
    """
    theta = np.atleast_2d(np.asarray(theta, dtype=float))
    out = np.full(theta.shape[0], -np.inf)
    inside = np.all((theta >= bounds[:, 0]) & (theta <= bounds[:, 1]), axis=1)
    if not np.any(inside):
        return out
    delta, d, sigma = theta[inside].T
    mu = kappa1(data.l[None, :], data.L[None, :], delta[:, None], d[:, None])  # (W_in, S)
    var = data.kappa_se[None, :] ** 2 + sigma[:, None] ** 2
    loglike = folded_normal_logpdf(data.kappa[None, :], mu, var).sum(axis=1)
    logprior = -np.log1p((sigma / sigma_scale) ** 2)
    out[inside] = loglike + logprior
    return out
