"""Newton steps on large meshes by conjugate gradients, preconditioned by a Cholesky factor without U_B5's far couplings.

U_B5 (the smoothing, ``k5 AᵀA`` with ``A x = x - x_avg``) couples every vertex with its
neighbours' neighbours, the only term that does: the Newton matrix's other terms couple a
vertex with its own neighbours, its partner on the other face and a string's other end.
Those second-ring couplings widen every separator of the nested dissection, and the
Cholesky factor with them: on the large mattress at 20 mm (64 920 unknowns) the factor
holds 27 M non-zeros and takes 25 GF per factorization, about 0.8 s on one core at 30 GF/s,
against 12 M and 5.6 GF (0.25 s) without them (``bench/bench_preconditioned.py``). No
exact reformulation escapes them: an auxiliary unknown per row of ``A`` joins the same
vertices and needs separators as wide.

:class:`PreconditionedSystem` solves ``(H + mu I) dx = -g`` with ``H``'s own values by
preconditioned conjugate gradients (PCG), the preconditioner the Cholesky factor of
``M + mu I``: ``M`` is ``H`` without the second-ring entries of U_B5, each row's dropped
entries added to its diagonal (their absolute sum: ``M - H`` is then a graph Laplacian of
the dropped couplings, positive semi-definite, so ``M + mu I`` is definite wherever
``H + mu I`` is). The conjugate gradients stop at a relative residual of ``rtol`` (an
inexact Newton step: the trust region of :func:`airmat.inflation.solver.solve` judges it
by the decrease of U_B it brings, as any step); a direction of non-positive curvature of
``H + mu I``, or a preconditioner that does not factorize, raises the shift as an
indefinite factorization does in :class:`~airmat.inflation.solver.NewtonSystem`. The
stopping rule of the Newton iterations is unchanged, so the equilibrium is the same to
its tolerance.

The preconditioned steps pay off where a factorization costs far more than a
conjugate-gradient iteration (a forward and back substitution and a product with ``H``):
on the large mattress's 20 mm mesh (:data:`MIN_UNKNOWNS`), not on its 40 mm one nor on the
small mattress, and in an inflation from the flat mattress (:func:`~airmat.inflation.simulate.inflate`),
not in an equilibrium carried on to other lengths (:func:`~airmat.inflation.simulate.inflate_from`),
whose steps take about twice the conjugate-gradient iterations: 0.82–1.44× on four large refined designs,
two of them slower (``bench/bench_preconditioned.py``, docs/benchmarks.md: vault2 19.7 → 15.7 s, the roof
15.9 → 14.3 s, the same vertices within 1e-5 mm). SI units.
"""

from __future__ import annotations

import numpy as np
import scipy.sparse as sp

from airmat.inflation.cholesky import ShiftedCholesky
from airmat.inflation.solver import NewtonSystem

__all__ = ["PreconditionedSystem", "far_couplings", "pcg", "MIN_UNKNOWNS", "RTOL", "MAX_CG"]

#: systems with at least this many unknowns take preconditioned steps in :func:`~airmat.inflation.simulate.inflate`
#: (the large mattress at 20 mm has 64 920; at 40 mm, 17 112, where they do not pay)
MIN_UNKNOWNS = 40_000

#: relative residual at which the conjugate gradients stop (an inexact Newton step)
RTOL = 0.1

#: conjugate-gradient iterations per Newton step at most (the last iterate is then the step)
MAX_CG = 60


def far_couplings(pattern: list, smoothing: sp.spmatrix, free: np.ndarray, indices: np.ndarray,
                  indptr: np.ndarray) -> tuple:
    """Which entries of the Newton matrix only U_B5 couples, and what dropping them adds to the diagonal.

    Parameters
    ----------
    pattern : list of (ndarray, ndarray)
        :func:`~airmat.inflation.energy.block_pattern`'s vertex pairs, the smoothing's last.
    smoothing : scipy.sparse matrix of shape (n, n)
        U_B5's Hessian per coordinate (N/m).
    free : ndarray of shape (n_free,)
        Flat DOF index of each row of the reduced system.
    indices, indptr : ndarray
        The reduced system's CSR structure (:class:`~airmat.inflation.assembly.Assembler`).

    Returns
    -------
    keep : ndarray of shape (nnz,) bool
        The CSR entries another term couples too (the diagonal always).
    added : ndarray of shape (n_free,)
        Each row's absolute sum of the U_B5 entries dropped (N/m), to add to its diagonal.
    """
    n = smoothing.shape[0]
    near = np.unique(np.concatenate([r.astype(np.int64) * n + c for r, c in pattern[:-1]]))
    vertex = free // 3
    rows = np.repeat(np.arange(len(free)), np.diff(indptr))
    keep = np.isin(vertex[rows] * n + vertex[indices], near) | (rows == indices)
    q = smoothing.tocoo()
    far = ~np.isin(q.row.astype(np.int64) * n + q.col, near)
    lost = np.bincount(q.row[far], weights=np.abs(q.data[far]), minlength=n)
    return keep, lost[vertex]


def pcg(matvec, b: np.ndarray, precondition, rtol: float, max_iter: int) -> tuple:
    """Preconditioned conjugate gradients for ``A x = b`` from ``x = 0``.

    Not :func:`scipy.sparse.linalg.cg`: the Newton step needs to know when ``A`` is not definite
    (a search direction of non-positive curvature), which scipy's does not report.

    Parameters
    ----------
    matvec, precondition : callable
        ``v -> A v`` and ``r -> M⁻¹ r`` (M symmetric positive definite).
    b : ndarray of shape (n,)
    rtol : float
        Stop when ``|b - A x| <= rtol |b|``.
    max_iter : int

    Returns
    -------
    x : ndarray of shape (n,)
    iterations : int
    status : {"converged", "max_iter", "negative curvature"}
        "negative curvature": a search direction p with ``pᵀ A p <= 0`` (A is not definite;
        ``x`` is then the last iterate before it).

    Examples
    --------
    >>> a = np.array([[4.0, 1.0], [1.0, 3.0]])
    >>> x, k, status = pcg(lambda v: a @ v, np.array([1.0, 2.0]), lambda r: r / np.diag(a), 1e-12, 10)
    >>> np.allclose(a @ x, [1.0, 2.0]), status
    (True, 'converged')
    """
    x = np.zeros_like(b)
    r = b.copy()
    z = precondition(r)
    p = z.copy()
    rz = float(r @ z)
    stop = rtol * float(np.linalg.norm(b))
    for k in range(max_iter):
        ap = matvec(p)
        curvature = float(p @ ap)
        if not curvature > 0.0:
            return x, k, "negative curvature"
        alpha = rz / curvature
        x += alpha * p
        r -= alpha * ap
        if float(np.linalg.norm(r)) <= stop:
            return x, k + 1, "converged"
        z = precondition(r)
        rz_next = float(r @ z)
        p = z + (rz_next / rz) * p
        rz = rz_next
    return x, max_iter, "max_iter"


class PreconditionedSystem(NewtonSystem):
    """Solves ``(H + mu I) dx = -g`` by PCG with the Cholesky factor of ``M + mu I`` (the module docstring).

    A :class:`~airmat.inflation.solver.NewtonSystem` (the same shift rule, ``mu_min``, ``hint_rel``,
    ``n_factorizations``) whose :meth:`attempt` solves by conjugate gradients, so
    :func:`~airmat.inflation.solver.solve` takes either.

    Parameters
    ----------
    pattern : list of (ndarray, ndarray)
        The model's :func:`~airmat.inflation.energy.block_pattern`.
    smoothing : scipy.sparse matrix of shape (n, n)
        The model's U_B5 Hessian per coordinate.
    assembler : airmat.inflation.assembly.Assembler
        The reduced CSR pattern the Newton matrices come in.
    hint_rel : float
        Seed of the shift (as NewtonSystem's).
    rtol, max_cg : float, int
        Stopping rule of the conjugate gradients.

    Attributes
    ----------
    cg_iterations : int
        Conjugate-gradient iterations so far.
    """

    def __init__(self, pattern: list, smoothing, assembler, *, hint_rel: float = 0.0, rtol: float = RTOL,
                 max_cg: int = MAX_CG, mu_min: float | None = None):
        super().__init__(mu_min=mu_min, groups=assembler.free // 3, hint_rel=hint_rel)
        keep, added = far_couplings(pattern, smoothing, assembler.free, assembler.indices, assembler.indptr)
        n = assembler.n_free
        rows = np.repeat(np.arange(n), np.diff(assembler.indptr))[keep]
        self._keep = np.flatnonzero(keep)
        self._indices = assembler.indices[keep]
        self._indptr = np.concatenate([[0], np.cumsum(np.bincount(rows, minlength=n))]).astype(assembler.indptr.dtype)
        self._diag = np.flatnonzero(rows == self._indices)
        self._added = added
        self.n = n
        self.rtol, self.max_cg = float(rtol), int(max_cg)
        self.cg_iterations = 0

    def preconditioner(self, h: sp.csr_matrix) -> sp.csr_matrix:
        """M of ``h``: its entries but U_B5's far ones, their absolute row sums on the diagonal."""
        data = h.data[self._keep]
        data[self._diag] += self._added
        return sp.csr_matrix((data, self._indices, self._indptr), shape=(self.n, self.n))

    def attempt(self, h: sp.csr_matrix, g: np.ndarray, mu: float) -> np.ndarray | None:
        """dx with ``(h + mu I) dx ≈ -g`` to ``rtol``, or None when the preconditioner does not factorize or
        the conjugate gradients meet a direction of non-positive curvature."""
        m = self.preconditioner(h)
        if self.chol is None:
            self.chol = ShiftedCholesky(m, self.groups)
        if not self.chol.factor(m, mu):
            return None
        dx, k, status = pcg(lambda v: h @ v + mu * v, -g, lambda r: self.chol.solve(r, one_call=False),
                            self.rtol, self.max_cg)
        self.cg_iterations += k
        return dx if status != "negative curvature" and np.all(np.isfinite(dx)) else None
