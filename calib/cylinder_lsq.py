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

:func:`refine` runs :func:`scipy.optimize.least_squares` (trust region,
robust loss, analytic Jacobian) over 5 parameters: a rotation vector of the
frame (origin fixed), the shift ``rho`` of the origin along the normal, and
kappa, in coordinates centred on the origin and scaled by the points'
spread (so the problem is well conditioned at any position and size).
:mod:`calib.cylinder_irls` solves the same problem on a million points and
gives the standard error of kappa.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy.optimize import least_squares
from scipy.spatial.transform import Rotation

from airmat.errors import ConvergenceError

__all__ = ["CylinderFrame", "CylinderProblem", "left_jacobian", "residuals", "residuals_and_jacobian",
           "arc_position", "refine", "RefineResult"]


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
        t, n = self.tangent, self.normal
        return points @ t - self.origin @ t, points @ n - self.origin @ n


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
    S = np.maximum(S, np.finfo(float).tiny)  # 0 only for a point exactly on the axis
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
    prob = CylinderProblem(np.asarray(points, dtype=float), frame, 1.0)
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


def left_jacobian(w: np.ndarray) -> np.ndarray:
    """Left Jacobian of SO(3) at rotation vector ``w``: d Exp(w) = Exp(J dw) Exp(w)."""
    th = float(np.linalg.norm(w))
    K = np.array([[0.0, -w[2], w[1]], [w[2], 0.0, -w[0]], [-w[1], w[0], 0.0]])
    if th < 1e-6:
        return np.eye(3) + 0.5 * K + K @ K / 6.0
    return np.eye(3) + (1 - np.cos(th)) / th**2 * K + (th - np.sin(th)) / th**3 * (K @ K)


class CylinderProblem:
    """Normalized coordinates and the residual/Jacobian closures of one fit.

    Shared by :func:`refine` (scipy's least_squares) and
    :func:`calib.cylinder_irls.polish` (Gauss-Newton on a million points).

    Coordinates are stored transposed, (3, N), and the Jacobian is built as
    (5, N) rows, so that every pass over the points is contiguous and the
    5x5 normal equations are one BLAS product.
    """

    def __init__(self, points: np.ndarray, frame: CylinderFrame, scale: float | None = None):
        self.o0 = frame.origin
        self.wT = np.subtract(points.T, frame.origin[:, None], out=np.empty((3, len(points))))
        if scale is None:  # RMS distance to the origin
            scale = float(np.sqrt(np.einsum("ij,ij->", self.wT, self.wT) / max(len(points), 1))) or 1.0
        self.scale = scale
        self.wT /= scale
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
        np.matmul(left_jacobian(x[:3]).T, g, out=Jt[:3])
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
    state: tuple | None = None  # (e, Jt, scale) at (or within tol of) the solution, from polish


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
    prob = CylinderProblem(np.asarray(points, dtype=float), frame)
    scale = prob.scale
    res = least_squares(prob.fun, prob.x0(), jac=prob.jac, loss=loss, f_scale=f_scale / scale,
                        method="trf", x_scale=1.0, ftol=tol, xtol=tol, gtol=tol, max_nfev=max_nfev)
    if not np.all(np.isfinite(res.x)):
        raise ConvergenceError("cylinder least squares diverged (non-finite parameters)", x=res.x)
    return RefineResult(frame=prob.frame(res.x), converged=bool(res.status > 0), n_iter=int(res.nfev),
                        message=str(res.message))
