"""The bounded Levenberg–Marquardt step of the refinement, solved on the thin QR factor of its Jacobian.

The refinement's linearized least squares ``|a s + r|²`` has a tall ``a``
((3N + k) × k: the face's N vertices, k strings). One thin QR per
Gauss–Newton iteration (:func:`qr_reduce`) turns every damped, bounded
subproblem of that iteration (:func:`damped_step`, one per trial damping)
into a k × k one, with the same solution. SI units (m).
"""

from __future__ import annotations

import numpy as np
from scipy.optimize import lsq_linear

__all__ = ["qr_reduce", "damped_step"]


def qr_reduce(a, r):
    """The thin QR reduction of the linearized least squares ``|a s + r|²``: ``(R, Qᵀr)``.

    ``|a s + r|² = |R s + Qᵀr|² + |r|² - |Qᵀr|²`` for ``a = QR``, so every damped subproblem
    of an iteration is solved on the k × k ``R`` instead of the (3N + k) × k ``a`` (on the
    large mattress the tall problem made each ``lsq_linear`` call take seconds).

    Parameters
    ----------
    a : ndarray of shape (m, k)
    r : ndarray of shape (m,)

    Returns
    -------
    tuple of (ndarray of shape (k, k), ndarray of shape (k,))
    """
    q, rr = np.linalg.qr(a)
    return rr, q.T @ r


def damped_step(rr, qtr, scale, lam, lower, upper):
    """The bounded Levenberg–Marquardt step: argmin ``|R s + Qᵀr|² + lam |scale · s|²``, ``lower <= s <= upper``.

    Parameters
    ----------
    rr, qtr : ndarray of shape (k, k), (k,)
        From :func:`qr_reduce`.
    scale : ndarray of shape (k,)
        Column norms of the tall matrix (the damping's scaling).
    lam : float
    lower, upper : ndarray of shape (k,)
        Bounds of the step (m).

    Returns
    -------
    ndarray of shape (k,)
    """
    k = len(scale)
    aug = np.vstack([rr, np.sqrt(lam) * np.diag(scale)])
    return lsq_linear(aug, -np.concatenate([qtr, np.zeros(k)]), bounds=(lower, upper)).x
