"""Projected Newton on U_A (paper §3.2, Eq. 4): the second-order solver of the relaxation.

U_A = Σ_edges ½ k_A1 (ε − ε0)² + Σ_vertices ½ k_A2 ‖x − x_closest‖² + Σ_vertices ½ k_A3 ‖L x‖²
is a smooth least-squares energy (the squared distance to S is C¹, its gradient
x − x_closest), so Newton's method with a line search converges where the
local-global iteration (airmat.design.local_global) crawls: that iteration
holds every vertex to its last closest point with the stiffness k_A2 in all
directions, while the true A2 only resists motion across S. Sliding along S,
which a non-developable target needs everywhere (a symmetric saddle), is then
relaxed by a factor k_A2 / (k_A2 + in-plane stiffness) per iteration.

The Hessian H, per block of a vertex's three coordinates:

- A1, per edge: k_A1 (t tᵀ + max(0, 1 − ε0/ε) (I − t tᵀ)), t the unit edge: the
  exact Hessian where the edge is stretched, its positive part where it is
  compressed (projected Newton: H stays positive semi-definite). A Ŝ that
  contracts (a dome, whose rim gathers into folds) then converges only
  linearly. ``exact_after=k`` takes the exact term, 1 − ε0/ε, from iteration
  k + 1 on (the shift μ keeps it definite): the same tolerance in 1.4–3.2× less
  time on the designs that fold or contract, but another of U_A's minima,
  other folds, and the dome preset's refined inflation from 2.58 to 2.46–5.08 %
  of the diagonal as k varies (``bench/bench_ua_hessian.py --refine``;
  docs/decisions.md), so projected Newton stays the default;
- A2, per vertex: k_A2 n nᵀ, n the normal of S at the closest point (the exact
  Hessian of ½ dist² on S, dropping terms of order dist · κ);
- A3: k_A3 LᵀL, constant.

Each iteration solves (H + μ I) p = −∇U_A (H + μ I positive definite: by
construction while H is projected, by the shift μ after) by the sparse Cholesky
the inflation uses (CHOLMOD, ordered and analysed once on the fixed pattern:
:class:`airmat.inflation.cholesky.ShiftedCholesky`; the zoo's egg-crate target's
298 factorizations take 2.5 s where scipy's SuperLU took 12.8 s), and backtracks
along p until U_A, with the closest points projected again at the trial
positions, falls by the Armijo fraction. The shift
μ (a Levenberg–Marquardt damping, ≥ ``MU_MIN`` × k_A1) keeps H + μ I definite
along the motions no term resists (Ω sliding along a cylinder's axis) and,
with the exact A1 term, where H is indefinite; it grows ×10 when a
factorization finds H + μ I indefinite or a step is refused, and shrinks ÷3
when a full step is taken.

Stopping rule: that of airmat.design.local_global (the largest force below ``tol``
× k_A1 × h); or ``"stall"`` when no step along the damped Newton direction lowers
U_A by more than its rounding (the facets of a triangulated S leave a force
floor). Lengths in metres.
"""

from __future__ import annotations

import numpy as np
import scipy.sparse as sp

from airmat.errors import ConvergenceError

__all__ = ["newton", "MU_MIN", "ARMIJO", "MAX_SHIFTS"]

#: smallest Levenberg–Marquardt shift, in units of k_A1 (per edge): far below any edge's stiffness
MU_MIN = 1e-8
#: Armijo fraction of the predicted decrease a step must achieve
ARMIJO = 1e-4
#: a step shorter than this (mean edge lengths, largest vertex move) is no progress
STEP_MIN = 1e-10
#: shifts tried in one iteration (each ×10 the last) before the relaxation gives up: 40 decades, past where any
#: finite step shrinks below STEP_MIN
MAX_SHIFTS = 40


class _Pattern:
    """The Hessian's fixed CSR pattern (vertex-major unknowns: x0 y0 z0 x1 ...) and where each term adds."""

    def __init__(self, prob):
        n, e = prob.inc.shape[1], prob.edges
        self.n = n
        i, j = e[:, 0], e[:, 1]
        # A1: the blocks (i,i), (j,j), (i,j), (j,i) of every edge
        bi, bj = np.concatenate([i, j, i, j]), np.concatenate([i, j, j, i])
        a1_r, a1_c = _block_entries(bi, bj)
        a2_r, a2_c = _block_entries(np.arange(n), np.arange(n))
        llt = (prob.lap.T @ prob.lap).tocoo()
        a3_r = np.concatenate([3 * llt.row + c for c in range(3)])
        a3_c = np.concatenate([3 * llt.col + c for c in range(3)])
        rows = np.concatenate([a1_r, a2_r, a3_r])
        cols = np.concatenate([a1_c, a2_c, a3_c])
        keys, inverse = np.unique(rows * (3 * n) + cols, return_inverse=True)
        self.nnz = len(keys)
        self.indices = (keys % (3 * n)).astype(np.int32)
        self.indptr = np.searchsorted(keys // (3 * n), np.arange(3 * n + 1)).astype(np.int32)
        k1, _, k3 = prob.k
        s1, s2 = len(a1_r), len(a2_r)
        self._a1, self._a2 = inverse[:s1], inverse[s1:s1 + s2]
        self.const = np.bincount(inverse[s1 + s2:], weights=k3 * np.tile(llt.data, 3), minlength=self.nnz)
        self.n_edges = len(e)

    def cholesky(self):
        """The sparse Cholesky of ``H + μ I`` on this pattern (:class:`airmat.inflation.cholesky.ShiftedCholesky`:
        its ordering and symbolic analysis once, each iteration a numeric factorization), a vertex's three
        unknowns ordered together."""
        from airmat.inflation.cholesky import ShiftedCholesky

        shape = (3 * self.n, 3 * self.n)
        return ShiftedCholesky(sp.csr_matrix((np.ones(self.nnz), self.indices, self.indptr), shape=shape),
                               groups=np.repeat(np.arange(self.n), 3))

    def matrix(self, a1_blocks, a2_blocks):
        """H (3n, 3n) CSR from the edges' (m, 3, 3) and the vertices' (n, 3, 3) blocks."""
        a1 = np.concatenate([a1_blocks, a1_blocks, -a1_blocks, -a1_blocks]).ravel()
        data = (self.const + np.bincount(self._a1, weights=a1, minlength=self.nnz)
                + np.bincount(self._a2, weights=a2_blocks.ravel(), minlength=self.nnz))
        return sp.csr_matrix((data, self.indices, self.indptr), shape=(3 * self.n, 3 * self.n))


def _block_entries(bi, bj):
    """Row and column indices of the 3×3 blocks (bi, bj), each block row-major, blocks in order."""
    r = (3 * bi[:, None, None] + np.arange(3)[None, :, None]).repeat(3, axis=2)
    c = (3 * bj[:, None, None] + np.arange(3)[None, None, :]).repeat(3, axis=1)
    return r.ravel(), c.ravel()


def _gradient(prob, x, cp):
    """∇U_A (n, 3) at x with the closest points cp."""
    k1, k2, k3 = prob.k
    d = prob.inc @ x
    length = np.linalg.norm(d, axis=1)
    pull = (1.0 - prob.rest / np.maximum(length, 1e-12 * prob.h))[:, None] * d
    return k1 * (prob.inc.T @ pull) + k2 * (x - cp) + k3 * (prob.lap.T @ (prob.lap @ x))


def _hessian(prob, pattern, x, normal, exact: bool = False):
    """H (3n, 3n) at x: A1's exact Hessian per edge (``exact``) or with a compressed edge's negative transverse
    stiffness dropped, A2's k_A2 n nᵀ, A3's constant k_A3 LᵀL."""
    k1, k2, _ = prob.k
    d = prob.inc @ x
    length = np.maximum(np.linalg.norm(d, axis=1), 1e-12 * prob.h)
    t = d / length[:, None]
    tt = t[:, :, None] * t[:, None, :]
    c = 1.0 - prob.rest / length
    c = (c if exact else np.maximum(c, 0.0))[:, None, None]
    a1 = k1 * (tt + c * (np.eye(3) - tt))
    a2 = k2 * normal[:, :, None] * normal[:, None, :]
    return pattern.matrix(a1, a2)


def _closest(prob, x):
    near = (prob.projector.closest_extended(x) if prob.extend_rim else prob.projector.closest(x))
    return near.points, near.normal


def slide_constraints(x, normal) -> np.ndarray:
    """Rows G (3, 3n) of the linear constraints that hold Ω's place on S: G x = G x_start.

    The mean position of the vertices along two tangents of S at their centre, and
    the mean turn about S's normal there (linearised at ``x``).

    Parameters
    ----------
    x : ndarray of shape (n, 3)
        The start positions (m).
    normal : ndarray of shape (n, 3)
        S's unit normals at their closest points.
    """
    n_avg = normal.sum(axis=0)
    n_avg /= max(np.linalg.norm(n_avg), 1e-300)
    t1 = np.cross(n_avg, np.eye(3)[np.argmin(np.abs(n_avg))])
    t1 /= np.linalg.norm(t1)
    t2 = np.cross(n_avg, t1)
    arm = np.cross(n_avg, x - x.mean(axis=0))                  # velocity of a unit turn about the normal
    rows = np.stack([np.tile(t1, (len(x), 1)), np.tile(t2, (len(x), 1)), arm])
    rows /= np.linalg.norm(rows.reshape(3, -1), axis=1)[:, None, None]
    return rows.reshape(3, -1)


def newton(prob, x, *, tol: float, max_iter: int, bar=None, hold: bool = True, exact_after: int | None = None):
    """Minimise U_A from x by damped projected Newton with a line search.

    Parameters
    ----------
    prob : airmat.design.local_global.UAProblem
        Rest lengths, weights, A3 operator and the target's projector.
    x : ndarray of shape (n, 3)
        Start positions (m); not modified.
    tol : float
        Converged when the largest force on a vertex (less the constraints' reaction,
        with ``hold``) is below ``tol`` × k_A1 × h.
    max_iter : int
        Newton iterations at most.
    bar : airmat.progress residual bar, optional
    hold : bool, default True
        Hold Ω's place on S (:func:`slide_constraints` at ``x``): the mean tangential
        position and the mean turn about the normal stay those of the start.
    exact_after : int, optional
        Iterations with the projected A1 Hessian before the exact one (the shift μ keeping it definite);
        default None: projected throughout.

    Returns
    -------
    x : ndarray of shape (n, 3)
    n_iter : int
    status : str
        ``"force"``, ``"stall"`` or ``"max_iter"``.
    residual : float
        The largest force in units of k_A1 × h.
    history : list of float
        The residual at every iteration.
    slide : float
        The largest force per vertex (k_A1 × h) with which the held sheet pushes to
        slide or turn along S (0 without ``hold``).

    Raises
    ------
    airmat.errors.ConvergenceError
        When positions, U_A or the Newton matrix become non-finite, or when no shift of
        :data:`MAX_SHIFTS` tried in one iteration gives a definite ``H + μ I`` and a descent step.
    """
    k1 = prob.k[0]
    x = np.array(x, dtype=float)
    pattern = _Pattern(prob)
    chol = pattern.cholesky()
    cp, normal = _closest(prob, x)
    e = prob.energy(x, cp)["U_A"]
    if not np.isfinite(e):
        raise ConvergenceError("U_A relaxation diverged: non-finite start", n_iter=0)
    g_rows = slide_constraints(x, normal) if hold else np.zeros((0, x.size))
    mu = MU_MIN * k1
    history, status, residual, slide, it = [], "max_iter", np.inf, 0.0, 0
    for it in range(1, max_iter + 1):
        grad = _gradient(prob, x, cp).ravel()
        lam = np.linalg.lstsq(g_rows.T, grad, rcond=None)[0] if len(g_rows) else np.zeros(0)
        force = (grad - g_rows.T @ lam).reshape(x.shape)
        residual = float(np.linalg.norm(force, axis=1).max() / (k1 * prob.h))
        slide = float(np.abs(lam).max() / np.sqrt(len(x)) / (k1 * prob.h)) if len(lam) else 0.0
        history.append(residual)
        if bar is not None:
            bar.residual(residual)
        if residual < tol:
            status = "force"
            break
        hess = _hessian(prob, pattern, x, normal, exact=exact_after is not None and it > exact_after)
        if not np.isfinite(hess.data).all():
            raise ConvergenceError("U_A relaxation diverged: non-finite Newton matrix", n_iter=it)
        step = None
        for _ in range(MAX_SHIFTS):
            if not chol.factor(hess, mu):       # definite only to rounding at this shift: a larger one
                mu *= 10.0
                continue
            p = _constrained_step(chol, grad, g_rows).reshape(x.shape)
            step = _line_search(prob, x, e, p, float(grad @ p.ravel()))
            if step is not None:
                if step[0] == 1.0:
                    mu = max(mu / 3.0, MU_MIN * k1)
                break
            if np.abs(p).max() < STEP_MIN * prob.h:
                break
            mu *= 10.0
        else:
            raise ConvergenceError(f"U_A relaxation: no descent step even with the shift {mu / k1:.3g} k_A1 "
                                   f"(the Newton matrix indefinite or the step non-finite)", n_iter=it, mu=mu)
        if step is None:
            status = "stall"
            break
        _, x, cp, normal, e = step
    return x, it, status, residual, history, slide


def _constrained_step(factor, grad, g_rows):
    """p minimising ½ pᵀ(H + μI)p + gradᵀp with g_rows p = 0 (the factor's Schur complement); ``factor`` solves
    with H + μI."""
    if not len(g_rows):
        return -factor.solve(grad)
    sol = factor.solve(np.column_stack([grad, g_rows.T]))
    hg, hc = sol[:, 0], sol[:, 1:]
    lam = np.linalg.solve(g_rows @ hc, -(g_rows @ hg))
    return -(hg + hc @ lam)


def _line_search(prob, x, e, p, slope):
    """Backtrack along p: (alpha, x, cp, normal, U_A) with an Armijo decrease, or None."""
    if not slope < 0:
        return None
    alpha = 1.0
    while alpha * np.abs(p).max() >= STEP_MIN * prob.h:
        xt = x + alpha * p
        cp, normal = _closest(prob, xt)
        et = prob.energy(xt, cp)["U_A"]
        if not (np.isfinite(et) and np.isfinite(xt).all()):
            raise ConvergenceError("U_A relaxation diverged (non-finite energy)", n_iter=0)
        if et <= e + ARMIJO * alpha * slope:
            return alpha, xt, cp, normal, et
        alpha *= 0.5
    return None
