"""The shifted sparse Cholesky: solves, tells positive definite from not, orders deterministically."""

import numpy as np
import pytest
import scipy.sparse as sp

from airmat.inflation.cholesky import ShiftedCholesky, nested_dissection


def _laplacian_blocks(n_side: int, rng) -> tuple:
    """A 3-per-vertex SPD matrix on a grid graph, with its vertex groups."""
    lap1 = sp.diags([-np.ones(n_side - 1), 2 * np.ones(n_side), -np.ones(n_side - 1)], [-1, 0, 1])
    lap = sp.kronsum(lap1, lap1).tocsr()                        # 2D grid Laplacian (PD)
    block = rng.normal(size=(3, 3))
    block = block @ block.T + 3 * np.eye(3)
    h = sp.kron(lap, block).tocsr()
    h = (h + h.T) * 0.5
    groups = np.repeat(np.arange(n_side * n_side), 3)
    return h.tocsr(), groups


@pytest.mark.parametrize("ordered, metis", [(False, True), (True, True), (True, False)])
def test_solution_matches_a_dense_solve_and_the_pd_test_matches_eigenvalues(ordered, metis, monkeypatch):
    # metis=False: as on Windows, where pymetis has no wheel and CHOLMOD's AMD orders the unknowns
    import airmat.inflation.cholesky as cholesky

    if not metis:
        monkeypatch.setattr(cholesky, "metis_available", lambda: False)
        monkeypatch.setattr(cholesky, "nested_dissection", None)      # would fail if it were still called
    rng = np.random.default_rng(0)
    h, groups = _laplacian_blocks(7, rng)
    c = ShiftedCholesky(h, groups if ordered else None)
    lam = np.linalg.eigvalsh(h.toarray())
    b = rng.normal(size=h.shape[0])
    for mu in (1e-3, 1.0):
        assert c.factor(h, mu)
        x = c.solve(b)
        np.testing.assert_allclose(x, np.linalg.solve(h.toarray() + mu * np.eye(h.shape[0]), b), rtol=1e-9)
    # positive definite exactly while the shift stays above minus the smallest eigenvalue
    assert not c.factor(h, -1.01 * lam[0])
    with pytest.raises(RuntimeError):
        c.solve(b)
    assert c.factor(h, -0.99 * lam[0])                          # and it recovers
    assert c.n_factorizations == 4


def test_nested_dissection_is_a_group_preserving_deterministic_permutation():
    rng = np.random.default_rng(1)
    h, groups = _laplacian_blocks(12, rng)
    coo = h.tocoo()
    p1 = nested_dissection(coo.row, coo.col, groups)
    p2 = nested_dissection(coo.row, coo.col, groups)
    np.testing.assert_array_equal(p1, p2)
    np.testing.assert_array_equal(np.sort(p1), np.arange(h.shape[0]))
    # a vertex's three unknowns stay consecutive
    g = groups[p1].reshape(-1, 3)
    assert np.all(g == g[:, :1])


def test_pattern_without_its_diagonal_is_refused():
    h = sp.csr_matrix(np.array([[0.0, 1.0], [1.0, 0.0]]))
    with pytest.raises(ValueError, match="diagonal"):
        ShiftedCholesky(h)


@pytest.mark.parametrize("flags, expected", [
    ({"sse2", "avx", "avx2", "fma", "avx512f", "avx512cd", "avx512bw", "avx512dq", "avx512vl"}, "SkylakeX"),
    ({"sse2", "avx", "avx2", "fma", "avx512f"}, "Haswell"),       # AVX-512 F alone: not a SkylakeX
    ({"sse2", "avx", "avx2", "fma"}, "Haswell"),
    ({"sse2", "avx"}, None),
])
def test_openblas_coretype_follows_the_cpu_flags(flags, expected):
    from airmat.inflation.cholesky import openblas_coretype

    assert openblas_coretype(flags) == expected


_CORENAME = """
import os
import airmat.inflation.cholesky as c
print(c.cvxopt_blas_kernels() or "no-bundled-openblas", os.environ.get("OPENBLAS_CORETYPE", "-"),
      c.openblas_coretype())
"""


@pytest.mark.parametrize("user", [None, "Haswell"])
def test_cvxopts_openblas_runs_the_kernels_of_this_cpu(user):
    """The cvxopt wheel's OpenBLAS gets the kernel family of this CPU, a user's choice wins,
    and the variable is not left behind for other libraries."""
    import os
    import subprocess
    import sys

    env = {k: v for k, v in os.environ.items() if k != "OPENBLAS_CORETYPE"}
    if user is not None:
        env["OPENBLAS_CORETYPE"] = user
    out = subprocess.run([sys.executable, "-c", _CORENAME], env=env, capture_output=True, text=True,
                         check=True).stdout.split()
    if out[0] == "no-bundled-openblas":
        pytest.skip("cvxopt has no bundled OpenBLAS here")
    corename, left, detected = out
    assert left == (user or "-")
    want = user or (None if detected == "None" else detected)
    if want is None:
        pytest.skip("no AVX2 on this CPU: OpenBLAS chooses its kernels itself")
    assert corename.lower() == want.lower()


def test_solve_takes_several_right_hand_sides_at_once():
    rng = np.random.default_rng(3)
    a = rng.normal(size=(6, 6))
    h = sp.csr_matrix(a @ a.T + 6 * np.eye(6))
    c = ShiftedCholesky(h)
    assert c.factor(h)
    b = rng.normal(size=(6, 4))
    x = c.solve(b)
    assert x.shape == (6, 4)
    np.testing.assert_allclose(x, np.linalg.solve(h.toarray(), b), rtol=1e-10)
    np.testing.assert_allclose(c.solve(b[:, 1]), x[:, 1], rtol=1e-12)


def test_reading_the_factor_size_leaves_the_factorization_usable():
    rng = np.random.default_rng(4)
    h, groups = _laplacian_blocks(6, rng)
    c = ShiftedCholesky(h, groups)
    assert c.factor_nnz == 0                        # nothing factored yet
    assert c.factor(h, 0.5)
    nnz = c.factor_nnz
    lower = int(sp.tril(h).nnz)
    assert lower <= nnz <= h.shape[0] * (h.shape[0] + 1) // 2   # at least A's lower triangle (fill-in only adds)
    b = rng.normal(size=h.shape[0])
    np.testing.assert_allclose(c.solve(b), np.linalg.solve(h.toarray() + 0.5 * np.eye(h.shape[0]), b), rtol=1e-9)
    assert c.n_factorizations == 1
