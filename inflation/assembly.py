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

__all__ = ["Assembler", "build_assembler"]


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

    def assemble(self, blocks: list) -> sp.csr_matrix:
        """Sum blocks (list of (b_i, 3, 3), in the pattern's order) into the reduced CSR matrix."""
        vals = np.concatenate([b.reshape(-1) for b in blocks])
        data = np.bincount(self.slot, weights=vals, minlength=self.nnz + 1)[: self.nnz]
        return sp.csr_matrix((data, self.indices, self.indptr), shape=(self.n_free, self.n_free))


def build_assembler(pattern: list, n_vertices: int, fixed_dofs=(), order=None) -> Assembler:
    """Precompute the reduced CSR pattern of a list of block positions.

    Parameters
    ----------
    pattern : list of (ndarray, ndarray)
        Row and column vertex indices of the blocks of each term.
    n_vertices : int
    fixed_dofs : sequence of int
        Flat DOF indices (3 * vertex + coordinate) removed from the system
        (to pin the rigid motions).
    order : ndarray of shape (3 * n_vertices,), optional
        A fill-reducing permutation of the flat DOFs (fixed ones are skipped).

    Returns
    -------
    Assembler
    """
    n_dof = 3 * n_vertices
    order = np.arange(n_dof) if order is None else np.asarray(order)
    keep = np.ones(n_dof, bool)
    keep[np.asarray(fixed_dofs, dtype=np.int64)] = False
    free = order[keep[order]]
    red = np.full(n_dof, -1, np.int64)
    red[free] = np.arange(len(free))
    rows = np.concatenate([r for r, _ in pattern])
    cols = np.concatenate([c for _, c in pattern])
    comp = np.arange(3)
    dr = red[(3 * rows[:, None, None] + comp[None, :, None]).repeat(3, axis=2).reshape(-1)]
    dc = red[(3 * cols[:, None, None] + comp[None, None, :]).repeat(3, axis=1).reshape(-1)]
    ok = (dr >= 0) & (dc >= 0)
    n_free = len(free)
    key = dr[ok] * n_free + dc[ok]
    uniq, inv = np.unique(key, return_inverse=True)
    slot = np.full(len(dr), len(uniq), np.int64)
    slot[ok] = inv
    r_u = uniq // n_free
    indptr = np.concatenate([[0], np.cumsum(np.bincount(r_u, minlength=n_free))])
    return Assembler(n_free=n_free, free=free, slot=slot, indices=(uniq % n_free).astype(np.int32),
                     indptr=indptr.astype(np.int32))
