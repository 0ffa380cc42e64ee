"""Sparse assembly of 3 × 3 vertex blocks into a fixed CSR pattern.

The sparsity of the Newton matrix does not change between iterations, so
the COO -> CSR bookkeeping (sorting, summing duplicates, dropping the
pinned degrees of freedom) is done once; each assembly is then a single
``np.bincount`` of all block entries into the CSR data array.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import scipy.sparse as sp

__all__ = ["Assembler", "build_assembler", "reduced_dofs"]


@dataclass(frozen=True)
class Assembler:
    """A fixed CSR pattern over the free degrees of freedom.

    Attributes
    ----------
    n_free : int
        Size of the reduced system.
    free : ndarray of shape (n_free,)
        Flat DOF index (3 * vertex + coordinate) of each row.
    slot : ndarray of shape (total_entries,)
        CSR data position of every block entry (``nnz`` for dropped ones).
    indices, indptr : ndarray
        The CSR structure.
    """

    n_free: int
    free: np.ndarray
    slot: np.ndarray
    indices: np.ndarray
    indptr: np.ndarray

    @property
    def nnz(self) -> int:
        return len(self.indices)

    def pattern(self) -> sp.csr_matrix:
        """The reduced CSR pattern with every entry 1 (what a symbolic factorization needs)."""
        return sp.csr_matrix((np.ones(self.nnz), self.indices, self.indptr), shape=(self.n_free, self.n_free))

    def assemble(self, blocks: list) -> sp.csr_matrix:
        """Sum blocks (list of (b_i, 3, 3), in the pattern's order) into the reduced CSR matrix."""
        vals = np.concatenate([b.reshape(-1) for b in blocks])
        data = np.bincount(self.slot, weights=vals, minlength=self.nnz + 1)[: self.nnz]
        return sp.csr_matrix((data, self.indices, self.indptr), shape=(self.n_free, self.n_free))


def reduced_dofs(n_vertices: int, fixed_dofs=()) -> tuple:
    """The free degrees of freedom: ``(keep, free, red)``, a mask over the 3n flat DOFs, the free
    ones' flat indices (n_free,), and each flat DOF's row in the reduced system (-1 if fixed) (3n,)."""
    n_dof = 3 * n_vertices
    keep = np.ones(n_dof, bool)
    keep[np.asarray(fixed_dofs, dtype=np.int64)] = False
    free = np.flatnonzero(keep)
    red = np.full(n_dof, -1, np.int64)
    red[free] = np.arange(len(free))
    return keep, free, red


def build_assembler(pattern: list, n_vertices: int, fixed_dofs=()) -> Assembler:
    """Precompute the reduced CSR pattern of a list of block positions.

    The duplicates are merged over vertex pairs (one key per 3 × 3 block, nine
    times fewer than per entry), and each block's nine entries are then placed
    by arithmetic: in a row of blocks sorted by column, scalar row ``3 r + i``
    holds the ``j``-th column of its ``m``-th block at ``3 m + j``.

    Parameters
    ----------
    pattern : list of (ndarray, ndarray)
        Row and column vertex indices of the blocks of each term.
    n_vertices : int
    fixed_dofs : sequence of int
        Flat DOF indices (3 * vertex + coordinate) removed from the system
        (to pin the rigid motions).

    Returns
    -------
    Assembler
        Rows and columns in the order of the free DOFs, column indices sorted.
    """
    keep, free, red = reduced_dofs(n_vertices, fixed_dofs)
    rows = np.concatenate([r for r, _ in pattern]).astype(np.int64)
    cols = np.concatenate([c for _, c in pattern]).astype(np.int64)
    uniq, inv = np.unique(rows * n_vertices + cols, return_inverse=True)   # sorted by (row, column)
    r_u, c_u = uniq // n_vertices, uniq % n_vertices
    row_ptr = np.concatenate([[0], np.cumsum(np.bincount(r_u, minlength=n_vertices))])
    first, width = row_ptr[r_u], (row_ptr[1:] - row_ptr[:-1])[r_u]       # per unique block
    comp = np.arange(3)
    # position of entry (i, j) of unique block b in the CSR of all 3n DOFs: (U, 3, 3)
    pos = (9 * first[:, None, None] + 3 * width[:, None, None] * comp[None, :, None]
           + 3 * (np.arange(len(uniq)) - first)[:, None, None] + comp[None, None, :])
    dof_r = np.empty(9 * len(uniq), np.int64)
    dof_c = np.empty(9 * len(uniq), np.int64)
    dof_r[pos] = np.broadcast_to(3 * r_u[:, None, None] + comp[None, :, None], pos.shape)
    dof_c[pos] = np.broadcast_to(3 * c_u[:, None, None] + comp[None, None, :], pos.shape)
    kept = keep[dof_r] & keep[dof_c]
    nnz = int(np.count_nonzero(kept))
    new = np.where(kept, np.cumsum(kept) - 1, nnz)                        # the reduced CSR's data slot
    slot = new[pos[inv].reshape(-1)]
    n_free = len(free)
    indptr = np.concatenate([[0], np.cumsum(np.bincount(red[dof_r[kept]], minlength=n_free))])
    return Assembler(n_free=n_free, free=free, slot=slot, indices=red[dof_c[kept]].astype(np.int32),
                     indptr=indptr.astype(np.int32))
