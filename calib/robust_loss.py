"""The robust losses of the cylinder fit, as scipy's least_squares defines them: weights, slopes, cost.

``rho(z)`` with ``z = (e / f_scale)^2`` for ``loss`` in "linear", "soft_l1",
"huber", "cauchy" and "arctan". :func:`airmat.calib.cylinder_lsq.refine`
(Levenberg-Marquardt) and :func:`airmat.calib.cylinder_irls.polish`
(Gauss-Newton on a million points) minimize the same robust cost with them.
"""

from __future__ import annotations

import numpy as np

__all__ = ["loss_weights", "loss_slopes", "robust_cost"]


def loss_weights(e: np.ndarray, f_scale: float, loss: str) -> np.ndarray:
    """IRLS weights ``rho'(z)``, ``z = (e / f_scale)^2``, of a least_squares loss (same rho as scipy)."""
    z = (np.asarray(e) / f_scale) ** 2
    if loss == "linear":
        return np.ones_like(z)
    if loss == "soft_l1":
        return 1.0 / np.sqrt(1.0 + z)
    if loss == "huber":
        return np.where(z <= 1.0, 1.0, 1.0 / np.sqrt(np.maximum(z, 1.0)))
    if loss == "cauchy":
        return 1.0 / (1.0 + z)
    if loss == "arctan":
        return 1.0 / (1.0 + z * z)
    raise ValueError(f"unknown loss {loss!r}")


def loss_slopes(e: np.ndarray, f_scale: float, loss: str) -> np.ndarray:
    """Derivative of the influence function, ``psi'(e) = rho'(z) + 2 z rho''(z)``, of a loss."""
    z = (np.asarray(e) / f_scale) ** 2
    if loss == "linear":
        return np.ones_like(z)
    if loss == "soft_l1":
        return (1.0 + z) ** -1.5
    if loss == "huber":
        return np.where(z <= 1.0, 1.0, 0.0)
    if loss == "cauchy":
        return (1.0 - z) / (1.0 + z) ** 2
    if loss == "arctan":
        return (1.0 - 3.0 * z * z) / (1.0 + z * z) ** 2
    raise ValueError(f"unknown loss {loss!r}")


def robust_cost(e: np.ndarray, f: float, loss: str) -> float:
    """Sum of ``rho((e / f)^2)`` (scipy's least_squares cost without the factor f^2 / 2)."""
    z = (e / f) ** 2
    rho = {"linear": lambda z: z, "soft_l1": lambda z: 2 * (np.sqrt(1 + z) - 1),
           "huber": lambda z: np.where(z <= 1, z, 2 * np.sqrt(np.maximum(z, 1)) - 1),
           "cauchy": np.log1p, "arctan": np.arctan}[loss]
    return float(np.sum(rho(z)))
