"""Geometric least squares of a cylinder, parametrized so that a plane is kappa = 0.

A cylinder is described by a surface point ``origin``, the unit ``normal``
there (pointing to the axis side when kappa > 0), the unit ``axis`` (normal
to it) and the signed curvature ``kappa``; the axis passes through
``origin + normal / kappa``. With ``t = axis x normal`` and a point's
coordinates ``X = (p - origin) . t`` and ``Z = (p - origin) . normal``, its
signed distance to the surface is

    e = R - |p - axis line| = (2 Z - kappa (X^2 + Z^2)) / (1 + sqrt((1 - kappa Z)^2 + (kappa X)^2)),

exact for every kappa and smooth through kappa = 0 (where it is the
distance ``Z`` to the plane). So a flat specimen is an ordinary fit with
kappa near 0 and an honest error bar, not a singular radius (cf. Lukacs,
Marshall & Martin 1998, "Faithful least-squares fitting of spheres,
cylinders, cones and tori").

The fit runs :func:`scipy.optimize.least_squares` (trust region, robust
``soft_l1`` loss, analytic Jacobian) over 5 parameters: a rotation vector
of the frame (origin fixed), the shift ``rho`` of the origin along the
normal, and kappa, in coordinates centred on the origin and scaled by the
points' spread (so the problem is well conditioned at any position and
size). The covariance is a cluster-robust sandwich over bins along the
arc, so that spatially correlated residuals (the string-end grooves)
widen the error bar instead of being counted as independent noise.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy.optimize import least_squares
from scipy.spatial.transform import Rotation

from airmat.errors import ConvergenceError

__all__ = ["CylinderFrame", "residuals", "residuals_and_jacobian", "refine", "polish", "RefineResult", "kappa_standard_error",
           "arc_position", "loss_weights", "loss_slopes"]


@dataclass(frozen=True)
class CylinderFrame:
    """A cylinder as surface point, normal, axis and signed curvature (SI units).

    Attributes
    ----------
    origin : ndarray of shape (3,)
        A point on the surface (m).
    normal : ndarray of shape (3,)
        Unit surface normal at ``origin``; the axis is on this side when kappa > 0.
    axis : ndarray of shape (3,)
        Unit axis direction, perpendicular to ``normal``.
    kappa : float
        Signed curvature (1/m); 0 is the plane through ``origin``.
    """

    origin: np.ndarray
    normal: np.ndarray
    axis: np.ndarray
    kappa: float

    @property
    def tangent(self) -> np.ndarray:
        """Unit direction along the arc at ``origin`` (``axis x normal``)."""
        return np.cross(self.axis, self.normal)

    def local(self, points: np.ndarray):
        """Arc-plane coordinates ``X`` (along the arc) and ``Z`` (along the normal), (N,) each, m."""
        w = points - self.origin
        return w @ self.tangent, w @ self.normal


def _distance(X, Z, k, derivatives=False):
    """Signed distance to the surface, and optionally its partials in X, Z and k."""
    kX = k * X
    u = 1.0 - k * Z
    S = np.sqrt(u * u + kX * kX)
    s = X * X + Z * Z
    D = 1.0 + S
    N = 2.0 * Z - k * s
    e = N / D
    if not derivatives:
        return e
    dX = -kX / S
    dZ = u / S
    dk = -(s * D + N * (Z - N) / S) / (D * D)  # k s - Z = Z - N
    return e, dX, dZ, dk


def residuals(points: np.ndarray, frame: CylinderFrame) -> np.ndarray:
    """Signed distances (m) of ``points`` (N, 3) to the cylinder (positive inside for kappa > 0)."""
    X, Z = frame.local(np.asarray(points, dtype=float))
    return _distance(X, Z, frame.kappa)


def residuals_and_jacobian(points: np.ndarray, frame: CylinderFrame):
    """Signed distances (N,) and their Jacobian, transposed (5, N), at ``frame``.

    Columns: a small rotation of the frame about the origin (3, per radian,
    rotation vector in world axes), the shift of the origin along the normal
    (per metre) and kappa (per 1/m).
    """
    prob = _Problem(np.asarray(points, dtype=float), frame, 1.0)
    return prob.fun_jac(prob.x0())


def arc_position(points: np.ndarray, frame: CylinderFrame) -> np.ndarray:
    """Arc length (m) of each point's foot along the cross-section, from ``origin``.

    Tends to ``X`` as kappa -> 0, so flat specimens bin the same way.
    """
    X, Z = frame.local(np.asarray(points, dtype=float))
    k = frame.kappa
    if abs(k) * np.max(np.abs(X), initial=0.0) < 1e-9:
        return X
    return np.arctan2(k * X, 1.0 - k * Z) / k


def _left_jacobian(w: np.ndarray) -> np.ndarray:
    """Left Jacobian of SO(3) at rotation vector ``w``: d Exp(w) = Exp(J dw) Exp(w)."""
    th = float(np.linalg.norm(w))
    K = np.array([[0.0, -w[2], w[1]], [w[2], 0.0, -w[0]], [-w[1], w[0], 0.0]])
    if th < 1e-6:
        return np.eye(3) + 0.5 * K + K @ K / 6.0
    return np.eye(3) + (1 - np.cos(th)) / th**2 * K + (th - np.sin(th)) / th**3 * (K @ K)


class _Problem:
    """Normalized coordinates and the residual/Jacobian closures of one fit.

    Coordinates are stored transposed, (3, N), and the Jacobian is built as
    (5, N) rows, so that every pass over the points is contiguous and the
    5x5 normal equations are one BLAS product.
    """

    def __init__(self, points: np.ndarray, frame: CylinderFrame, scale: float):
        self.o0, self.scale = frame.origin, scale
        self.wT = np.ascontiguousarray(((points - frame.origin) / scale).T)
        self.n0, self.a0 = frame.normal, frame.axis
        self.t0 = np.cross(frame.axis, frame.normal)
        self.k0 = frame.kappa * scale

    def _frame(self, x):
        rot = Rotation.from_rotvec(x[:3]).as_matrix()
        return rot @ self.t0, rot @ self.n0, rot @ self.a0

    def fun(self, x):
        t, n, _ = self._frame(x)
        return _distance(t @ self.wT, n @ self.wT - x[3], x[4])

    def jac(self, x):
        """Jacobian (N, 5), for least_squares."""
        return self.fun_jac(x)[1].T

    def fun_jac(self, x):
        """Residuals (N,) and transposed Jacobian (5, N) in one pass."""
        t, n, _ = self._frame(x)
        X, Z = t @ self.wT, n @ self.wT - x[3]
        e, dX, dZ, dk = _distance(X, Z, x[4], derivatives=True)
        # d(X, Z)/d(rotation) = (t x w, n x w)^T J_l, so the rotation rows are
        # J_l^T (a x w) with a = dX t + dZ n per point
        a = np.outer(t, dX)
        a += np.outer(n, dZ)
        w0, w1, w2 = self.wT
        g = np.empty_like(self.wT)
        np.subtract(a[1] * w2, a[2] * w1, out=g[0])
        np.subtract(a[2] * w0, a[0] * w2, out=g[1])
        np.subtract(a[0] * w1, a[1] * w0, out=g[2])
        Jt = np.empty((5, len(e)))
        np.matmul(_left_jacobian(x[:3]).T, g, out=Jt[:3])
        np.negative(dZ, out=Jt[3])
        Jt[4] = dk
        return e, Jt

    def frame(self, x) -> CylinderFrame:
        _, n, a = self._frame(x)
        return CylinderFrame(origin=self.o0 + x[3] * self.scale * n, normal=n, axis=a,
                             kappa=float(x[4] / self.scale))

    def x0(self):
        return np.array([0.0, 0.0, 0.0, 0.0, self.k0])


@dataclass(frozen=True)
class RefineResult:
    """Outcome of :func:`refine`.

    Attributes
    ----------
    frame : CylinderFrame
        The fitted cylinder.
    converged : bool
        Whether least_squares met a tolerance (status > 0).
    n_iter : int
        Function evaluations.
    message : str
        least_squares' message.
    """

    frame: CylinderFrame
    converged: bool
    n_iter: int
    message: str


def refine(points: np.ndarray, frame: CylinderFrame, *, f_scale: float, loss: str = "soft_l1",
           max_nfev: int = 50, tol: float = 1e-10) -> RefineResult:
    """Robust geometric least-squares fit of a cylinder, starting from ``frame``.

    Parameters
    ----------
    points : ndarray of shape (N, 3)
        Points near the cylinder (m); N >= 6.
    frame : CylinderFrame
        Initial cylinder; its origin should lie among the points.
    f_scale : float
        Residual scale of the robust loss (m), about the noise standard deviation.
    loss : str
        A :func:`scipy.optimize.least_squares` loss ("soft_l1", "huber", "cauchy", "linear").
    max_nfev : int
        Most function evaluations.
    tol : float
        ``ftol``, ``xtol`` and ``gtol`` of least_squares (relative).

    Returns
    -------
    RefineResult

    Raises
    ------
    airmat.errors.ConvergenceError
        If the fit produced non-finite parameters.
    """
    points = np.asarray(points, dtype=float)
    scale = float(np.sqrt(np.mean(np.sum((points - frame.origin) ** 2, axis=1)))) or 1.0
    prob = _Problem(points, frame, scale)
    res = least_squares(prob.fun, prob.x0(), jac=prob.jac, loss=loss, f_scale=f_scale / scale,
                        method="trf", x_scale=1.0, ftol=tol, xtol=tol, gtol=tol, max_nfev=max_nfev)
    if not np.all(np.isfinite(res.x)):
        raise ConvergenceError("cylinder least squares diverged (non-finite parameters)", x=res.x)
    return RefineResult(frame=prob.frame(res.x), converged=bool(res.status > 0), n_iter=int(res.nfev),
                        message=str(res.message))


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


def polish(points: np.ndarray, frame: CylinderFrame, *, f_scale: float, loss: str = "soft_l1",
           max_iter: int = 20, tol: float = 0.01) -> RefineResult:
    """Robust Gauss-Newton (IRLS) iterations, for many points.

    The same estimator as :func:`refine` (same loss, same residuals), solved
    with 5x5 normal equations instead of a trust region on the full
    Jacobian, so that each iteration costs one pass over the points (a
    million of them). A small Levenberg damping keeps the direction a flat
    specimen cannot determine (its axis in the plane) from wandering; steps
    that raise the robust cost are halved.

    Parameters
    ----------
    points : ndarray of shape (N, 3)
        Points near the cylinder (m).
    frame : CylinderFrame
        Start.
    f_scale, loss : float, str
        Robust loss as in :func:`refine`.
    max_iter : int
        Most iterations.
    tol : float
        Converged when every parameter's step is below ``tol`` times its
        standard error (so the answer no longer moves on the scale of its
        own uncertainty).

    Returns
    -------
    RefineResult
    """
    points = np.asarray(points, dtype=float)
    scale = float(np.sqrt(np.mean(np.sum((points - frame.origin) ** 2, axis=1)))) or 1.0
    f = f_scale / scale
    prob = _Problem(points, frame, scale)
    x = prob.x0()
    e, Jt = prob.fun_jac(x)
    n_eval, converged = 1, False
    cost = _robust_cost(e, f, loss)
    for _ in range(max_iter):
        w = loss_weights(e, f, loss)
        A = (Jt * w) @ Jt.T
        A[np.diag_indices(5)] += 1e-14 * np.trace(A) + 1e-9 * np.diag(A)
        A_inv = np.linalg.inv(A)
        step = -A_inv @ (Jt @ (w * e))
        if not np.all(np.isfinite(step)):
            raise ConvergenceError("cylinder Gauss-Newton diverged (non-finite step)", step=step)
        se = np.sqrt(np.abs(np.diag(A_inv)) * np.sum(w * e * e) / max(len(e) - 5, 1))
        if np.all(np.abs(step) <= tol * se):  # negligible: take it and stop
            x = x + step
            converged = True
            break
        for _ in range(12):  # step halving
            new_e = prob.fun(x + step)
            n_eval += 1
            new_cost = _robust_cost(new_e, f, loss)
            if new_cost <= cost:
                break
            step = step / 2
        if new_cost > cost:  # no descent along the Gauss-Newton direction: at the minimum
            converged = True
            break
        x, cost = x + step, new_cost
        e, Jt = prob.fun_jac(x)
        n_eval += 1
    msg = "converged" if converged else f"stopped after {max_iter} Gauss-Newton iterations"
    return RefineResult(frame=prob.frame(x), converged=converged, n_iter=n_eval, message=msg)


def _robust_cost(e, f, loss):
    z = (e / f) ** 2
    rho = {"linear": lambda z: z, "soft_l1": lambda z: 2 * (np.sqrt(1 + z) - 1),
           "huber": lambda z: np.where(z <= 1, z, 2 * np.sqrt(np.maximum(z, 1)) - 1),
           "cauchy": np.log1p, "arctan": np.arctan}[loss]
    return float(np.sum(rho(z)))


def kappa_standard_error(points: np.ndarray, frame: CylinderFrame, *, f_scale: float,
                         loss: str = "soft_l1", n_clusters: int = 24) -> tuple[float, float]:
    """Standard error of kappa (1/m): classical and cluster-robust sandwich.

    The M-estimator covariance ``A^-1 B A^-1`` uses ``A = sum psi'(e) J J^T``
    and ``B`` from the scores ``psi(e) J = w e J`` summed within
    ``n_clusters`` equal-count bins of arc position
    (across the whole width, where the string-end grooves correlate the
    residuals). The classical estimate treats every point as independent.

    Parameters
    ----------
    points : ndarray of shape (N, 3)
        The inliers the fit used (m).
    frame : CylinderFrame
        The fitted cylinder.
    f_scale, loss : float, str
        The robust loss of the fit (m).
    n_clusters : int
        Bins along the arc.

    Returns
    -------
    se_iid, se_cluster : float
        Standard errors of kappa (1/m).
    """
    points = np.asarray(points, dtype=float)
    scale = float(np.sqrt(np.mean(np.sum((points - frame.origin) ** 2, axis=1)))) or 1.0
    prob = _Problem(points, frame, scale)
    e, Jt = prob.fun_jac(prob.x0())
    w = loss_weights(e, f_scale / scale, loss)
    slope = loss_slopes(e, f_scale / scale, loss)
    A_inv = np.linalg.pinv((Jt * slope) @ Jt.T, rcond=1e-12, hermitian=True)
    p, n = Jt.shape
    score = Jt * (w * e)
    B_iid = score @ score.T * n / max(n - p, 1)
    s = arc_position(points, frame)
    g = min(n_clusters, max(n // 50, 2))
    edges = np.quantile(s, np.linspace(0, 1, g + 1)[1:-1])
    bins = np.searchsorted(edges, s)
    G = np.stack([np.bincount(bins, score[j], g) for j in range(p)], axis=1)
    B_cl = G.T @ G * g / (g - 1) * (n - 1) / max(n - p, 1)
    var_iid = (A_inv @ B_iid @ A_inv)[4, 4]
    var_cl = (A_inv @ B_cl @ A_inv)[4, 4]
    return float(np.sqrt(max(var_iid, 0.0)) / scale), float(np.sqrt(max(var_cl, 0.0)) / scale)
