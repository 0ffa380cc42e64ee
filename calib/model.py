"""Equation 3 of Todo et al. (2024): string length l  <->  induced curvature kappa_1.

A string of length ``l`` tied between two points a geodesic distance ``L``
apart on a mattress of thickness ``d`` bends it by the angle ``theta``
solving

    (l + 2 Delta) / (L - (pi - theta) d) = sin(theta / 2),

where ``Delta`` is how far each string end slips toward the other. With
``L* = L - (pi - theta) d`` the curvature is ``kappa_1 = 2 cos(theta/2) / L*``.
For ``l >= L - 2 Delta`` the mattress stays flat (``theta = pi``,
``kappa_1 = 0``).

Both directions are solved elementwise over arrays of any broadcastable
shape (e.g. a (walkers, specimens) batch in one call) by a safeguarded
Newton iteration inside a bracket that is known in closed form. Both
residuals are monotonic with analytic derivatives, so Newton converges in
a handful of whole-array steps; :func:`scipy.optimize.elementwise.find_root`
gives the same roots but its per-call overhead (about 3 ms) dominated the
MCMC, which calls the model twice per step on a few hundred elements.
All lengths are in metres, curvatures in 1/m.
"""

from __future__ import annotations

import numpy as np

from airmat.errors import InputError

__all__ = ["bend_angle", "polygon_side", "kappa1", "string_length", "kappa_max", "flat_length"]

_MAX_ITER = 80


def _bracketed_newton(f, lo, hi, args=(), *, increasing: bool, x0=None):
    """Root of a monotonic ``f(x, *args) -> (value, derivative)`` in [lo, hi], elementwise.

    Newton steps that would leave the current bracket are replaced by
    bisection, and the bracket shrinks with every evaluation, so each
    element converges (quadratically near its root) to a few ulps of pi.
    """
    lo, hi = np.array(lo, dtype=float), np.array(hi, dtype=float)
    x = 0.5 * (lo + hi) if x0 is None else np.clip(x0, lo, hi)
    for _ in range(_MAX_ITER):
        fx, dfx = f(x, *args)
        below = (fx < 0) == increasing  # the root lies above x
        lo = np.where(below, x, lo)
        hi = np.where(below, hi, x)
        with np.errstate(divide="ignore", invalid="ignore"):
            newton = x - fx / dfx
        inside = (newton >= lo) & (newton <= hi)
        x_new = np.where(inside, newton, 0.5 * (lo + hi))
        step = np.abs(x_new - x)
        # after a Newton step of size h the error is O(h**2): h <= 1e-7 leaves ~1e-14 rad
        if np.all(step <= 4 * np.finfo(float).eps * np.pi) or (np.all(inside) and step.max() <= 1e-7):
            return x_new
        x = x_new
    return x


def _check_params(L, delta, d):
    L, delta, d = (np.asarray(x, dtype=float) for x in (L, delta, d))
    for name, x, bad in (("L", L, ~(L > 0)), ("d", d, ~(d > 0)), ("delta", delta, ~(delta >= 0))):
        if np.any(bad):
            raise InputError(f"non-physical {name}={x[bad].ravel()[0]!r} m: "
                             f"need L > 0, d > 0 and delta >= 0", **{name: x})
    return L, delta, d


def _theta_min(L, d):
    """Smallest admissible bend angle, where L* = L - (pi - theta) d reaches 0."""
    return np.maximum(np.pi - L / d, 0.0)


def _lstar(theta, L, d):
    return L - (np.pi - theta) * d


def _solve_theta(l, L, delta, d):
    """theta of Equation 3 for l + 2 delta < L (caller guarantees); same broadcast shape."""
    lo = _theta_min(L, d)
    lstar = l + 2.0 * delta

    def g(theta, lstar, L, d):  # increasing in theta on (theta_min, pi]
        s = np.sin(0.5 * theta)
        c = np.sqrt(np.maximum(1.0 - s * s, 0.0))  # theta/2 in [0, pi/2]: one sine serves both
        ls = _lstar(theta, L, d)
        return ls * s - lstar, d * s + 0.5 * ls * c

    # start from the bend without wrinkles (L* = L), a close lower estimate of the root
    x0 = 2.0 * np.arcsin(np.minimum(lstar / L, 1.0))
    theta = _bracketed_newton(g, lo, np.full_like(lo, np.pi), (lstar, L, d), increasing=True, x0=x0)
    # l* = 0: the root is the bracket's end theta_min itself
    return np.where(lstar <= 0.0, lo, theta)


def bend_angle(l, L, delta, d):
    """Bend angle theta (rad) of Equation 3; pi where the mattress stays flat.

    Parameters
    ----------
    l, L, delta, d : array_like
        String length, geodesic distance of its ends, end slip and mattress
        thickness, all in metres; broadcast against each other.

    Returns
    -------
    ndarray
        theta in (0, pi], of the broadcast shape.
    """
    L, delta, d = _check_params(L, delta, d)
    l = np.asarray(l, dtype=float)
    if np.any(~(l >= 0)):
        raise InputError("string length l must be >= 0 m", l=l)
    l, L, delta, d = np.broadcast_arrays(l, L, delta, d)
    theta = np.full(l.shape, np.pi)
    bent = l + 2.0 * delta < L
    if bent.all():  # the common case (an MCMC batch): no gather/scatter copies
        return _solve_theta(l, L, delta, d)
    if np.any(bent):
        theta[bent] = _solve_theta(l[bent], L[bent], delta[bent], d[bent])
    return theta


def polygon_side(l, L, delta, d):
    """The side L* = L - (pi - theta) d of Equation 3's polygon (m): the span less what the wrinkles take.

    Parameters
    ----------
    l, L, delta, d : array_like
        As in :func:`bend_angle` (m).

    Returns
    -------
    ndarray
        L* (m); L where the mattress stays flat.
    """
    return _lstar(bend_angle(l, L, delta, d), np.asarray(L, float), np.asarray(d, float))


def kappa1(l, L, delta, d):
    """Curvature induced by a string of length ``l`` (Equation 3).

    Parameters
    ----------
    l : array_like
        String length (m), ``l >= 0``.
    L : array_like
        Geodesic distance between the string's two ends on the mattress (m), > 0.
    delta : array_like
        Slip of each string end toward the other (m), >= 0 (paper: 18 mm).
    d : array_like
        Mattress thickness (m), > 0 (paper: 70 mm).

    Returns
    -------
    ndarray
        kappa_1 (1/m) of the broadcast shape; 0 where ``l >= L - 2 delta``;
        ``inf`` where ``l + 2 delta = 0`` and ``L < pi d`` (the bend closes).

    Raises
    ------
    airmat.errors.InputError
        (a ValueError) for L <= 0, d <= 0, delta < 0 or l < 0.

    Examples
    --------
    >>> round(float(kappa1(0.15, 0.30, 0.018, 0.070)), 3)
    4.873
    """
    theta = bend_angle(l, L, delta, d)
    L = np.broadcast_to(np.asarray(L, float), theta.shape)
    d = np.broadcast_to(np.asarray(d, float), theta.shape)
    # L* -> 0 (l = delta = 0 with L < pi d): the wrinkles eat the whole span, kappa -> inf
    lstar = _lstar(theta, L, d)
    num = 2.0 * np.cos(theta / 2.0)
    k = np.divide(num, lstar, out=np.full(theta.shape, np.inf), where=lstar > 1e-12 * L)
    k[theta >= np.pi] = 0.0
    return k


def kappa_max(L, delta, d):
    """Largest curvature (1/m) a string can produce: the one at ``l = 0``."""
    return kappa1(0.0, L, delta, d)


def flat_length(L, delta):
    """String length (m) from which on the mattress stays flat: ``L - 2 delta``."""
    return np.asarray(L, float) - 2.0 * np.asarray(delta, float)


def string_length(kappa, L, delta, d):
    """String length (m) that induces the curvature ``kappa`` (inverse of :func:`kappa1`).

    Parameters
    ----------
    kappa : array_like
        Target curvature (1/m), ``0 <= kappa <= kappa_max(L, delta, d)``.
    L, delta, d : array_like
        As in :func:`kappa1` (m).

    Returns
    -------
    ndarray
        l (m) of the broadcast shape; ``L - 2 delta`` (the flat threshold) for
        ``kappa = 0``.

    Raises
    ------
    airmat.errors.InputError
        (a ValueError) for non-physical parameters, a negative or non-finite
        kappa, or a kappa beyond what even ``l = 0`` reaches; the message
        gives that largest reachable kappa.

    Examples
    --------
    >>> l = string_length(4.8734217, 0.30, 0.018, 0.070)
    >>> round(float(l), 4)
    0.15
    """
    L, delta, d = _check_params(L, delta, d)
    kappa = np.asarray(kappa, dtype=float)
    if np.any(~(kappa >= 0) | ~np.isfinite(kappa)):
        raise InputError("curvature kappa must be finite and >= 0 1/m "
                         "(the sign is the side the string goes on)", kappa=kappa)
    kappa, L, delta, d = np.broadcast_arrays(kappa, L, delta, d)
    l = np.asarray(flat_length(L, delta), dtype=float).copy()
    bent = (kappa > 0) & (l > 0)
    if np.any(bent):
        kb, Lb, db, deltab = kappa[bent], L[bent], d[bent], delta[bent]

        def h(theta, kb, Lb, db):  # decreasing in theta: >= 0 at theta_min (L* = 0), < 0 at pi
            return (2.0 * np.cos(theta / 2.0) - kb * _lstar(theta, Lb, db),
                    -np.sin(theta / 2.0) - kb * db)

        theta = _bracketed_newton(h, _theta_min(Lb, db), np.full_like(kb, np.pi), (kb, Lb, db),
                                  increasing=False)
        l[bent] = _lstar(theta, Lb, db) * np.sin(theta / 2.0) - 2.0 * deltab
    over = l < 0  # beyond reach, or kappa_max itself up to rounding: compare curvatures to decide
    if np.any(over):
        kmax = np.full(l.shape, np.inf)
        kmax[over] = kappa_max(L[over], delta[over], d[over])
        over &= kappa > kmax * (1 + 1e-10)
    if np.any(over):
        i = np.flatnonzero(over.ravel())[0]
        kmax = kappa_max(L, delta, d)
        raise InputError(f"curvature {kappa.ravel()[i]:.4g} 1/m is beyond reach: even l = 0 gives "
                         f"only {kmax.ravel()[i]:.4g} 1/m (L={L.ravel()[i]:.4g} m, "
                         f"delta={delta.ravel()[i]:.4g} m, d={d.ravel()[i]:.4g} m)",
                         kappa=kappa, kappa_max=kmax)
    np.maximum(l, 0.0, out=l)
    return l
