"""Sparse Cholesky of a shifted Newton matrix ``H + mu I`` on a fixed pattern (CHOLMOD).

The Newton matrix of U_B keeps its sparsity pattern from one iteration to
the next, so the fill-reducing ordering and CHOLMOD's symbolic analysis are
done once and each iteration only refactors numerically. CHOLMOD's
supernodal factorization fails as soon as a pivot is not positive, which is
how the trust-region solver learns that ``H + mu I`` is indefinite and the
shift must grow. CHOLMOD is used through cvxopt, whose wheels ship it; the
ordering is METIS's nested dissection (pymetis) of the *vertex* graph, each
vertex's three coordinates kept together, which CHOLMOD as built in cvxopt
lacks (it falls back to AMD).

Measured on Newton matrices of U_B (``bench/bench_cholesky.py``), per
numeric factorization: vault1 on the small mattress at 20 mm, 10 536
unknowns: 0.054 s (AMD: 0.067 s; scipy's SuperLU: 0.70 s); vault2 on the
large mattress at 20 mm, 64 920 unknowns: 0.83 s (AMD: 1.19 s; SuperLU:
11.7 s), 24 M non-zeros in the factor (AMD: 28 M).

cvxopt is imported by the first factorization, with its bundled OpenBLAS told
which kernels to use (:func:`airmat.inflation.cvxopt_libs.import_cvxopt`, re-exported here).
"""

from __future__ import annotations

import numpy as np
import scipy.sparse as sp

from airmat.inflation.cholmod_block import solve_many
from airmat.inflation.cvxopt_libs import cvxopt_blas_kernels, cvxopt_bundled_library, import_cvxopt, openblas_coretype

__all__ = ["ShiftedCholesky", "nested_dissection", "metis_available", "openblas_coretype", "import_cvxopt", "cvxopt_bundled_library",
           "cvxopt_blas_kernels"]


def metis_available() -> bool:
    """Whether pymetis is installed (it has no Windows wheel: there CHOLMOD's AMD orders the unknowns)."""
    import importlib.util

    return importlib.util.find_spec("pymetis") is not None


def nested_dissection(rows: np.ndarray, cols: np.ndarray, groups: np.ndarray) -> np.ndarray:
    """A fill-reducing order of the unknowns by METIS nested dissection of their groups' graph.

    Parameters
    ----------
    rows, cols : ndarray of shape (k,)
        Non-zero positions of a symmetric matrix (either triangle or both).
    groups : ndarray of shape (n,)
        Group of each unknown (e.g. its vertex); groups are numbered 0..G-1.

    Returns
    -------
    ndarray of shape (n,)
        The unknowns in elimination order (METIS's seed fixed: deterministic).
    """
    import pymetis

    n_groups = int(groups.max()) + 1
    gr, gc = groups[rows], groups[cols]
    off = gr != gc
    g = sp.coo_matrix((np.ones(int(off.sum())), (gr[off], gc[off])), shape=(n_groups, n_groups)).tocsr()
    g = (g + g.T).tocsr()
    g.sum_duplicates()
    order = np.asarray(pymetis.nested_dissection(pymetis.CSRAdjacency(g.indptr, g.indices),
                                                 options=pymetis.Options(seed=0))[0], dtype=np.int64)
    rank = np.empty(n_groups, np.int64)
    rank[order] = np.arange(n_groups)
    return np.lexsort((np.arange(len(groups)), rank[groups]))


class ShiftedCholesky:
    """Factor ``H + mu I`` for matrices ``H`` that all share one CSR pattern.

    Parameters
    ----------
    pattern : scipy.sparse.csr_matrix of shape (n, n)
        A symmetric matrix with the common pattern, including every diagonal entry.
    groups : ndarray of shape (n,), optional
        Group (vertex) of each unknown: the ordering is computed on the graph
        of the groups and keeps a group's unknowns together (METIS nested dissection,
        where pymetis is installed). Default, and without pymetis: CHOLMOD's AMD.

    Attributes
    ----------
    n_factorizations : int
        Numeric factorizations attempted so far (successful or not).

    Examples
    --------
    >>> import scipy.sparse as sp
    >>> h = sp.csr_matrix([[2.0, -1.0], [-1.0, 2.0]])
    >>> c = ShiftedCholesky(h)
    >>> c.factor(h, 0.0), c.factor(h, -3.0)
    (True, False)
    >>> c.factor(h, 1.0); c.solve(np.array([2.0, 2.0]))
    True
    array([1., 1.])
    """

    def __init__(self, pattern: sp.csr_matrix, groups: np.ndarray | None = None):
        cholmod, matrix, spmatrix = import_cvxopt()
        coo = sp.csr_matrix(pattern).tocoo()
        self.n = int(pattern.shape[0])
        lower = coo.row >= coo.col
        rows, cols = coo.row[lower].astype(np.int64), coo.col[lower].astype(np.int64)
        # CHOLMOD reads the lower triangle in column-major order: pick those entries of CSR ``data``
        # (coo of a csr keeps the data order) in that order, once
        order = np.lexsort((rows, cols))
        self._take = np.flatnonzero(lower)[order]
        rows, cols = rows[order], cols[order]
        self._diag = rows == cols
        if int(self._diag.sum()) != self.n:
            raise ValueError("the pattern must contain every diagonal entry")
        self._a = spmatrix(1.0, matrix(rows, tc="i"), matrix(cols, tc="i"), (self.n, self.n))
        if groups is None or not metis_available():
            self._symbolic = cholmod.symbolic(self._a)
        else:
            perm = nested_dissection(rows, cols, np.asarray(groups, dtype=np.int64))
            self._symbolic = cholmod.symbolic(self._a, p=matrix(perm.tolist(), tc="i"))
        self.n_factorizations = 0
        self._ok = False

    def factor(self, h: sp.csr_matrix, mu: float = 0.0) -> bool:
        """Numerically factor ``h + mu I``; return whether it is positive definite.

        Parameters
        ----------
        h : scipy.sparse.csr_matrix of shape (n, n)
            Symmetric, with exactly the pattern given at construction.
        mu : float
            Diagonal shift.
        """
        cholmod, matrix, _ = import_cvxopt()
        vals = h.data[self._take].astype(float, copy=True)
        vals[self._diag] += mu
        self.n_factorizations += 1
        try:
            self._a.V = matrix(vals)                # same pattern: only the values change
            cholmod.numeric(self._a, self._symbolic)
        except ArithmeticError:
            self._ok = False
            return False
        self._ok = True
        return True

    @property
    def factor_nnz(self) -> int:
        """Non-zeros of the Cholesky factor (after a successful :meth:`factor`; else 0); see :meth:`factor_columns`."""
        return int(self.factor_columns().sum())

    def factor_columns(self) -> np.ndarray:
        """Non-zeros of each column of the Cholesky factor, shape (n,) (after a successful :meth:`factor`;
        else empty). The factorization's floating-point work is about ``sum(c ** 2)`` of them.

        CHOLMOD hands the factor out by converting it (``getfactor`` leaves a symbolic
        factor behind), so the numeric factorization is then redone from the same values:
        :meth:`solve` keeps working. That extra factorization is not counted in
        ``n_factorizations``.
        """
        if not self._ok:
            return np.zeros(0, np.int64)
        cholmod = import_cvxopt()[0]
        col_ptr = np.array(cholmod.getfactor(self._symbolic).CCS[0], dtype=np.int64).ravel()
        cholmod.numeric(self._a, self._symbolic)     # same values (shift included) as the last factor()
        return np.diff(col_ptr)

    def solve(self, b: np.ndarray, one_call: bool = True) -> np.ndarray:
        """Solve ``(h + mu I) x = b`` with the last successful factorization; b of shape (n,) or (n, m).

        With ``one_call`` (the default) several columns are solved together by CHOLMOD
        (:func:`airmat.inflation.cholmod_block.solve_many`), else (or where that cannot solve) one at a
        time by cvxopt's ``cholmod.solve``: the same answer to rounding.
        """
        if not self._ok:
            raise RuntimeError("no positive definite factorization to solve with")
        cholmod, matrix, _ = import_cvxopt()
        b = np.asarray(b, dtype=float)
        if one_call and b.ndim == 2 and b.shape[1] > 1:
            x = solve_many(self._symbolic, b)       # all columns in one CHOLMOD call (airmat.inflation.cholmod_block)
            if x is not None:
                return x
        x = matrix(np.array(b, dtype=float, copy=True, order="F"))
        cholmod.solve(self._symbolic, x)
        return np.array(x).reshape(b.shape)
