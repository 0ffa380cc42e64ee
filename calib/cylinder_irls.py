"""Robust Gauss-Newton for the cylinder of :mod:`airmat.calib.cylinder_lsq`, and the error of kappa.

:func:`polish` minimizes the same robust cost as
:func:`airmat.calib.cylinder_lsq.refine` with 5x5 normal equations (Newton's
curvature ``sum psi' J J^T`` near the optimum, the IRLS one elsewhere), so
each iteration is one pass over the points, which matters at a million
points. :func:`kappa_standard_error` gives the M-estimator sandwich
covariance, classical and cluster-robust over bins along the arc, so that
spatially correlated residuals (the string-end grooves) widen the error bar
instead of being counted as independent noise. The losses are scipy's
(``rho(z)``, ``z = (e / f_scale)^2``; :mod:`airmat.calib.robust_loss`, re-exported here).
"""

from __future__ import annotations

import numpy as np

from airmat.errors import ConvergenceError
from airmat.calib.cylinder_lsq import CylinderFrame, CylinderProblem, RefineResult, arc_position, left_jacobian
from airmat.calib.robust_loss import loss_slopes, loss_weights, robust_cost

__all__ = ["polish", "kappa_standard_error", "loss_weights", "loss_slopes", "robust_cost"]


def polish(points: np.ndarray, frame: CylinderFrame, *, f_scale: float, loss: str = "soft_l1",
           max_iter: int = 20, tol: float = 0.05, hold_axis: bool | None = None,
           trust_one_step: float | None = None) -> RefineResult:
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
    hold_axis : bool, optional
        Keep the axis from turning about the normal. For a flat surface
        that direction is undetermined, and letting the fit pick the
        direction of largest apparent curvature would bias ``|kappa|`` up.
        Default: hold it while kappa is within two standard errors of 0.
    trust_one_step : float, optional
        When the first Newton step is within this many standard errors of
        every parameter (the start is a converged fit of a random subset of
        the same points), take it and stop: near the optimum one Newton step
        of this nearly linear problem leaves an error of second order, far
        below the standard error. Saves two passes over a million points.

    Returns
    -------
    RefineResult
    """
    points = np.asarray(points, dtype=float)
    prob = CylinderProblem(points, frame)
    scale = prob.scale
    f = f_scale / scale
    x = prob.x0()
    e, Jt = prob.fun_jac(x)
    n_eval, converged, state = 1, False, None
    cost = None  # needed only to judge a step: not computed when the first step is trusted
    for _ in range(max_iter):
        w = loss_weights(e, f, loss)
        A, newton = _curvature(Jt, e, w, f, loss)
        try:
            A_inv = np.linalg.inv(A)
        except np.linalg.LinAlgError as err:
            raise ConvergenceError("cylinder Gauss-Newton: singular normal equations (no points "
                                   "within the robust loss scale?)", f_scale=f_scale) from err
        grad = Jt @ (w * e)
        step = -A_inv @ grad
        if not np.all(np.isfinite(step)):
            raise ConvergenceError("cylinder Gauss-Newton diverged (non-finite step)", step=step)
        se = np.sqrt(np.abs(np.diag(A_inv)) * np.sum(w * e * e) / max(len(e) - 5, 1))
        if hold_axis or (hold_axis is None and abs(x[4]) < 2 * se[4]):
            step = _frozen_spin_step(A, grad, prob, x)
        if np.all(np.abs(step) <= tol * se) or (
                trust_one_step is not None and n_eval == 1 and np.all(np.abs(step) <= trust_one_step * se)):
            state = (e, Jt, scale, w, newton)  # the curvature and scores barely change over such a step
            x = x + step
            converged = True
            break
        if cost is None:
            cost = robust_cost(e, f, loss)
        for _ in range(12):  # step halving
            new_e = prob.fun(x + step)
            n_eval += 1
            new_cost = robust_cost(new_e, f, loss)
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
    return RefineResult(frame=prob.frame(x), converged=converged, n_iter=n_eval, message=msg,
                        state=state or (e, Jt, scale))


def _curvature(Jt, e, w, f, loss):
    """5x5 curvature of the robust cost: Newton's ``sum psi'(e) J J^T`` where it is positive
    definite (quadratic convergence near the optimum), else the IRLS ``sum w J J^T``; damped.
    Also the undamped Newton matrix (the sandwich covariance's bread)."""
    newton = (Jt * loss_slopes(e, f, loss)) @ Jt.T
    damp = 1e-14 * np.trace(newton) + 1e-9 * np.abs(np.diag(newton))
    A = newton
    try:
        np.linalg.cholesky(A + np.diag(damp))
    except np.linalg.LinAlgError:
        A = (Jt * w) @ Jt.T
        damp = 1e-14 * np.trace(A) + 1e-9 * np.diag(A)
    return A + np.diag(damp), newton


def _frozen_spin_step(A, grad, prob, x):
    """Gauss-Newton step with no rotation about the current normal (the undetermined
    axis direction of a flat surface), by solving in the orthogonal complement."""
    _, n, _ = prob._frame(x)
    c = np.concatenate([left_jacobian(x[:3]).T @ n, [0.0, 0.0]])
    basis = np.linalg.svd(c[None, :])[2][1:]  # (4, 5): orthonormal, orthogonal to c
    y = -np.linalg.solve(basis @ A @ basis.T, basis @ grad)
    return basis.T @ y


def kappa_standard_error(points: np.ndarray, frame: CylinderFrame, *, f_scale: float,
                         loss: str = "soft_l1", n_clusters: int = 24,
                         state: tuple | None = None, arc: np.ndarray | None = None,
                         axial: np.ndarray | None = None) -> tuple[float, float]:
    """Standard error of kappa (1/m): classical and cluster-robust sandwich.

    The M-estimator covariance ``A^-1 B A^-1`` uses ``A = sum psi'(e) J J^T``
    and ``B`` from the scores ``psi(e) J = w e J`` summed within
    ``n_clusters`` equal-count bins of arc position
    (across the whole width, where the string-end grooves correlate the
    residuals). The classical estimate treats every point as independent.

    Parameters
    ----------
    points : ndarray of shape (N, 3) or None
        The inliers the fit used (m); None when ``state`` and ``arc`` are given.
    frame : CylinderFrame
        The fitted cylinder.
    f_scale, loss : float, str
        The robust loss of the fit (m).
    n_clusters : int
        Bins along the arc.
    state : tuple, optional
        ``RefineResult.state`` of a :func:`polish` on the same points with the
        same ``f_scale`` and ``loss`` (saves passes over them).
    arc : ndarray of shape (N,), optional
        The points' arc positions in ``frame`` (m, :func:`airmat.calib.cylinder_lsq.arc_position`;
        saves another).
    axial : ndarray of shape (N,), optional
        The points' positions along the axis (m). With it the cluster-robust
        estimate is also taken over patches of the surface (a grid of arc and
        axial bins), in the numbers of :data:`PATCH_COUNTS`, and the largest
        variance kept: residuals
        correlated over a few centimetres in both directions (a scanner's
        banding, wrinkles) are then one cluster per patch, not independent
        points.

    Returns
    -------
    se_iid, se_cluster : float
        Standard errors of kappa (1/m).
    """
    if state is None:
        prob = CylinderProblem(np.asarray(points, dtype=float), frame)
        e, Jt = prob.fun_jac(prob.x0())
        state = (e, Jt, prob.scale)
    e, Jt, scale = state[:3]
    if len(state) == 5:  # polish's weights and Newton matrix at these residuals
        w, newton = state[3:]
    else:
        w = loss_weights(e, f_scale / scale, loss)
        newton = (Jt * loss_slopes(e, f_scale / scale, loss)) @ Jt.T
    A_inv = np.linalg.pinv(newton, rcond=1e-12, hermitian=True)
    p, n = Jt.shape
    score = Jt * (w * e)
    B_iid = score @ score.T * n / max(n - p, 1)
    s = arc_position(points, frame) if arc is None else arc
    g = min(n_clusters, max(n // 50, 2))
    edges = np.quantile(s[::max(len(s) // 20_000, 1)], np.linspace(0, 1, g + 1)[1:-1])
    bins = np.searchsorted(edges, s)
    var_iid = (A_inv @ B_iid @ A_inv)[4, 4]
    G = _cluster_sums(score, bins, g)
    var_cl = _cluster_variance(G, n, A_inv)
    if axial is not None and n >= 50 * max(PATCH_COUNTS):
        var_cl = max(var_cl, *(_cluster_variance(G, n, A_inv) for G in _patch_sums(score, s, axial)))
    return float(np.sqrt(max(var_iid, 0.0)) / scale), float(np.sqrt(max(var_cl, 0.0)) / scale)


#: numbers of surface patches the cluster-robust variance is also taken over (with ``axial``)
PATCH_COUNTS = (16, 36)
#: arc and axial bins of the fine grid the patches are merged from
_FINE = 72


def _cluster_sums(score, labels, g) -> np.ndarray:
    """(g', p) sums of the scores (p, n) over the clusters ``labels`` in ``range(g)`` that hold points."""
    G = np.stack([np.bincount(labels, score[j], g) for j in range(score.shape[0])], axis=1)
    return G[np.any(G != 0, axis=1)]


def _cluster_variance(G, n, A_inv) -> float:
    """Cluster-robust sandwich variance of kappa (scaled units) from the (g, p) cluster score sums."""
    g, p = G.shape
    g = max(g, 2)
    B = G.T @ G * g / (g - 1) * (n - 1) / max(n - p, 1)
    return float((A_inv @ B @ A_inv)[4, 4])


def _patch_sums(score, arc, axial):
    """Score sums over a grid of about ``count`` patches for each of :data:`PATCH_COUNTS`: arc and axial bins of
    about equal counts, as many rows as columns on a square surface (in proportion to the spans otherwise),
    merged from one fine grid of equal-width bins so that the points are binned once."""
    stride = max(len(arc) // 20_000, 1)
    fine, groups = [], []
    for v in (arc, axial):
        sub = v[::stride]   # bin widths and the points' spread over the bins from a systematic subsample (speed)
        lo, span = float(sub.min()), float(np.ptp(sub)) or 1.0
        b = ((v - lo) * (_FINE / span)).astype(np.intp)
        fine.append(np.clip(b, 0, _FINE - 1, out=b))
        share = np.bincount(np.clip(((sub - lo) * (_FINE / span)).astype(np.intp), 0, _FINE - 1),
                            minlength=_FINE) / len(sub)
        groups.append((np.cumsum(share) - share / 2, span))   # each fine bin's middle, as a share of the points
    cells = fine[0] * _FINE + fine[1]
    sums = np.stack([np.bincount(cells, score[j], _FINE * _FINE) for j in range(score.shape[0])], axis=1)
    c, r = np.divmod(np.arange(_FINE * _FINE), _FINE)
    (mid_s, span_s), (mid_y, span_y) = groups
    for count in PATCH_COUNTS:
        gs = int(np.clip(round(np.sqrt(count * span_s / span_y)), 1, count))
        gy = max(count // gs, 1)
        col = np.minimum((mid_s * gs).astype(np.intp), gs - 1)
        row = np.minimum((mid_y * gy).astype(np.intp), gy - 1)
        labels = col[c] * gy + row[r]
        G = np.stack([np.bincount(labels, sums[:, j], gs * gy) for j in range(sums.shape[1])], axis=1)
        yield G[np.any(G != 0, axis=1)]
