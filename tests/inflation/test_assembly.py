"""The fixed CSR pattern of the Newton matrix against scipy's own COO -> CSR sum."""

import numpy as np
import pytest
import scipy.sparse as sp

from airmat.inflation.assembly import build_assembler


def _reference(pattern, blocks, n_vertices, fixed):
    """Scipy's sum of duplicates over the scalar entries, then the fixed DOFs removed."""
    rows = np.concatenate([r for r, _ in pattern])
    cols = np.concatenate([c for _, c in pattern])
    comp = np.arange(3)
    dr = (3 * rows[:, None, None] + comp[None, :, None] + 0 * comp[None, None, :]).ravel()
    dc = (3 * cols[:, None, None] + 0 * comp[None, :, None] + comp[None, None, :]).ravel()
    vals = np.concatenate([b.reshape(-1) for b in blocks])
    full = sp.coo_matrix((vals, (dr, dc)), shape=(3 * n_vertices,) * 2).tocsr()
    free = np.setdiff1d(np.arange(3 * n_vertices), fixed)
    return full[free][:, free], free


@pytest.mark.parametrize("fixed", [(), (0, 1, 2, 4, 5, 17, 29)])
def test_assembly_sums_duplicate_blocks_like_scipy_and_drops_the_fixed_dofs(fixed):
    rng = np.random.default_rng(3)
    n = 10
    # three terms with repeated vertex pairs across and within terms (vertex 9 in none: an empty row)
    pattern = [(rng.integers(0, 9, k), rng.integers(0, 9, k)) for k in (40, 25, 7)]
    blocks = [rng.normal(size=(len(r), 3, 3)) for r, _ in pattern]
    asm = build_assembler(pattern, n, fixed)
    got = asm.assemble(blocks)
    want, free = _reference(pattern, blocks, n, fixed)
    np.testing.assert_array_equal(asm.free, free)
    assert asm.n_free == len(free) == 3 * n - len(fixed)
    assert got.has_sorted_indices
    # the pattern holds exactly the pairs some block touches, each once
    touched = want.copy()
    touched.data[:] = 1.0
    assert asm.nnz == touched.nnz
    np.testing.assert_allclose(got.toarray(), want.toarray(), rtol=0, atol=1e-12)
    # entries on a fixed DOF go to the dropped slot, the rest to a slot of the pattern
    assert np.all((asm.slot >= 0) & (asm.slot <= asm.nnz))
    assert np.any(asm.slot == asm.nnz) == (len(fixed) > 0)
