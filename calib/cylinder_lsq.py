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

:func:`refine` runs a Levenberg-Marquardt trust region (robust loss by
iteratively reweighted normal equations, analytic Jacobian; numpy only, as
importing scipy.optimize would cost more than the fit) over 5 parameters:
a rotation vector of the frame (origin fixed), the shift ``rho`` of the origin along the normal, and
kappa, in coordinates centred on the origin and scaled by the points'
spread (so the problem is well conditioned at any position and size).
:mod:`airmat.calib.cylinder_irls` solves the same problem on a million points and
gives the standard error of kappa.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from airmat.errors import ConvergenceError
from airmat.calib.robust_loss import loss_weights, robust_cost

__all__ = ["CylinderFrame", "CylinderProblem", "left_jacobian", "residuals", "residuals_and_jacobian",
           "arc_position", "arc_from_local", "distance_from_local", "refine", "RefineResult",
           "rotation_matrix"]


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
    """Signed distance to the surface, and optionally its partials in X, Z and k.

    Written with in-place operations: on a million points every temporary
    array is a pass over memory.
    """
    kX = k * X
    u = k * Z
    np.subtract(1.0, u, out=u)
    S = u * u
    S += kX * kX
    np.sqrt(S, out=S)
    s = X * X
    s += Z * Z
    D = S + 1.0
    N = 2.0 * Z
    N -= k * s
    e = N / D
    if not derivatives:
        return e
    np.maximum(S, np.finfo(float).tiny, out=S)  # 0 only for a point exactly on the axis
    dX = np.divide(kX, S, out=kX)
    np.negative(dX, out=dX)
    dZ = np.divide(u, S, out=u)
    dk = Z - N  # k s - Z = Z - N
    dk *= N
    dk /= S
    s *= D
    dk += s
    D *= D
    dk /= D
    np.negative(dk, out=dk)
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
    return arc_from_local(X, Z, frame.kappa)


def arc_from_local(X: np.ndarray, Z: np.ndarray, kappa: float) -> np.ndarray:
    """:func:`arc_position` from the coordinates ``X, Z`` (m) of :meth:`CylinderFrame.local` (saves a pass)."""
    k = kappa
    if abs(k) * np.max(np.abs(X), initial=0.0) < 1e-9:
        return X
    return np.arctan2(k * X, 1.0 - k * Z) / k


def distance_from_local(X: np.ndarray, Z: np.ndarray, kappa: float) -> np.ndarray:
    """:func:`residuals` from the coordinates ``X, Z`` (m) of :meth:`CylinderFrame.local` (saves a pass)."""
    return _distance(X, Z, kappa)


def _skew(v: np.ndarray) -> np.ndarray:
    """(3, 3) matrix of ``w -> v x w``."""
    return np.array([[0.0, -v[2], v[1]], [v[2], 0.0, -v[0]], [-v[1], v[0], 0.0]])


def rotation_matrix(w: np.ndarray) -> np.ndarray:
    """Rotation matrix (3, 3) of rotation vector ``w`` (radians), by Rodrigues' formula."""
    th = float(np.linalg.norm(w))
    K = np.array([[0.0, -w[2], w[1]], [w[2], 0.0, -w[0]], [-w[1], w[0], 0.0]])
    if th < 1e-6:  # series: the closed form loses precision at tiny angles
        return np.eye(3) + (1.0 - th**2 / 6.0) * K + (0.5 - th**2 / 24.0) * (K @ K)
    return np.eye(3) + np.sin(th) / th * K + (1.0 - np.cos(th)) / th**2 * (K @ K)


def left_jacobian(w: np.ndarray) -> np.ndarray:
    """Left Jacobian of SO(3) at rotation vector ``w``: d Exp(w) = Exp(J dw) Exp(w)."""
    th = float(np.linalg.norm(w))
    K = np.array([[0.0, -w[2], w[1]], [w[2], 0.0, -w[0]], [-w[1], w[0], 0.0]])
    if th < 1e-6:
        return np.eye(3) + 0.5 * K + K @ K / 6.0
    return np.eye(3) + (1 - np.cos(th)) / th**2 * K + (th - np.sin(th)) / th**3 * (K @ K)


class CylinderProblem:
    """Normalized coordinates and the residual/Jacobian closures of one fit.

    Shared by :func:`refine` (Levenberg-Marquardt) and
    :func:`airmat.calib.cylinder_irls.polish` (Gauss-Newton on a million points).

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
        rot = rotation_matrix(x[:3])
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
        # d(X, Z)/d(rotation) = (t x w, n x w)^T J_l, so the rotation rows are
        # J_l^T (a x w) = dX J_l^T [t]x w + dZ J_l^T [n]x w with a = dX t + dZ n per
        # point: X, Z and those two 3-vectors are one (8, 3) @ (3, N) product
        lt = left_jacobian(x[:3]).T
        P = np.vstack([t, n, lt @ _skew(t), lt @ _skew(n)]) @ self.wT
        X, Z = P[0], P[1] - x[3]
        e, dX, dZ, dk = _distance(X, Z, x[4], derivatives=True)
        Jt = np.empty((5, len(e)))
        np.multiply(P[2:5], dX, out=Jt[:3])
        P[5:8] *= dZ
        Jt[:3] += P[5:8]
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
        Whether a tolerance was met.
    n_iter : int
        Function evaluations.
    message : str
        Why it stopped.
    """

    frame: CylinderFrame
    converged: bool
    n_iter: int
    message: str
    state: tuple | None = None  # (e, Jt, scale[, w, newton]) at (or within tol of) the solution, from polish


def refine(points: np.ndarray, frame: CylinderFrame, *, f_scale: float, loss: str = "soft_l1",
           max_nfev: int = 50, tol: float = 1e-10) -> RefineResult:
    """Robust geometric least-squares fit of a cylinder, starting from ``frame``.

    Levenberg-Marquardt: the 5x5 normal equations of the robust cost
    (weights ``rho'`` of the loss, as iteratively reweighted least squares),
    damped by ``lam * diag``; a step that lowers the cost is taken and the
    damping relaxed, one that does not is refused and the damping raised.
    The damping keeps a far start (a RANSAC circle) from overshooting, as a
    trust region does.

    Parameters
    ----------
    points : ndarray of shape (N, 3)
        Points near the cylinder (m); N >= 6.
    frame : CylinderFrame
        Initial cylinder; its origin should lie among the points.
    f_scale : float
        Residual scale of the robust loss (m), about the noise standard deviation.
    loss : str
        A loss of :func:`airmat.calib.robust_loss.loss_weights` ("soft_l1", "huber",
        "cauchy", "arctan", "linear"), as scipy's least_squares defines them.
    max_nfev : int
        Most function evaluations.
    tol : float
        Converged when the cost falls by less than ``tol`` relatively, or the
        step is below ``tol`` relative to the parameters.

    Returns
    -------
    RefineResult

    Raises
    ------
    airmat.errors.ConvergenceError
        If the fit produced non-finite parameters.
    """
    prob = CylinderProblem(np.asarray(points, dtype=float), frame)
    f = f_scale / prob.scale
    x = prob.x0()
    e, Jt = prob.fun_jac(x)
    cost, nfev, lam = robust_cost(e, f, loss), 1, 1e-3
    status, message = 0, f"stopped after {max_nfev} function evaluations"
    while nfev < max_nfev:
        w = loss_weights(e, f, loss)
        A = (Jt * w) @ Jt.T
        g = Jt @ (w * e)
        if not np.all(np.isfinite(A)) or not np.all(np.isfinite(g)):
            raise ConvergenceError("cylinder least squares diverged (non-finite parameters)", x=x)
        if np.max(np.abs(g)) <= tol * max(cost, np.finfo(float).tiny):
            status, message = 1, "the gradient vanished"
            break
        d = np.diag(A) + 1e-12 * np.trace(A)
        try:
            step = -np.linalg.solve(A + lam * np.diag(d), g)
        except np.linalg.LinAlgError:
            lam *= 10.0
            continue
        if np.linalg.norm(step) <= tol * (tol + np.linalg.norm(x)):
            status, message = 2, "the step fell below the tolerance"
            break
        new_e, new_Jt = prob.fun_jac(x + step)  # one pass; most steps are taken
        nfev += 1
        new_cost = robust_cost(new_e, f, loss) if np.all(np.isfinite(new_e)) else np.inf
        if new_cost < cost:
            x, drop, cost = x + step, cost - new_cost, new_cost
            lam = max(lam / 3.0, 1e-12)
            if drop <= tol * cost:
                status, message = 3, "the cost fell below the tolerance"
                break
            e, Jt = new_e, new_Jt
        else:
            lam *= 4.0
            if lam > 1e12:  # no step lowers the cost: at the minimum to machine precision
                status, message = 4, "no step lowers the cost"
                break
    if not np.all(np.isfinite(x)):
        raise ConvergenceError("cylinder least squares diverged (non-finite parameters)", x=x)
    return RefineResult(frame=prob.frame(x), converged=status > 0, n_iter=nfev, message=message)
