"""CHOLMOD's many-right-hand-side solve on cvxopt's factor: the same answer as cvxopt's column-by-column solve."""

import os
import platform
import subprocess
import sys
import textwrap
from pathlib import Path

import numpy as np
import pytest
import scipy.sparse as sp

import airmat.inflation.cholesky as cholesky
from airmat.inflation.cholesky import ShiftedCholesky
from airmat.inflation.cholmod_block import ALIGN, MIN_SPLIT, available, column_blocks, solve_many


def _spd(n_side: int, seed: int):
    """A 3-per-vertex SPD matrix on a grid graph (large enough for a supernodal factor), with its groups."""
    rng = np.random.default_rng(seed)
    lap1 = sp.diags([-np.ones(n_side - 1), 2 * np.ones(n_side), -np.ones(n_side - 1)], [-1, 0, 1])
    block = rng.normal(size=(3, 3))
    h = sp.kron(sp.kronsum(lap1, lap1), block @ block.T + 3 * np.eye(3)).tocsr()
    return ((h + h.T) * 0.5).tocsr(), np.repeat(np.arange(n_side * n_side), 3), rng


def test_the_wheel_of_cvxopt_this_project_installs_is_usable():
    assert available()


@pytest.mark.parametrize("n_side, ordered", [(4, False), (30, True), (30, False)])
def test_solve_many_equals_cvxopts_solve_and_a_dense_one(n_side, ordered):
    h, groups, rng = _spd(n_side, n_side)
    c = ShiftedCholesky(h, groups if ordered else None)
    assert c.factor(h, 0.25)
    b = rng.normal(size=(h.shape[0], 37))
    x = solve_many(c._symbolic, b)
    assert x is not None and x.shape == b.shape and x.flags.c_contiguous
    np.testing.assert_allclose(x, c.solve(b, one_call=False), rtol=0, atol=1e-12 * np.abs(x).max())
    if n_side <= 4:
        np.testing.assert_allclose(x, np.linalg.solve(h.toarray() + 0.25 * np.eye(h.shape[0]), b), rtol=1e-10)
    else:
        np.testing.assert_allclose((h + 0.25 * sp.eye(h.shape[0])) @ x, b, rtol=0, atol=1e-10 * np.abs(b).max())
    np.testing.assert_array_equal(c.solve(b), x)     # what ShiftedCholesky.solve does with several columns


def test_what_it_cannot_solve_is_left_to_cvxopt():
    h, groups, rng = _spd(5, 1)
    c = ShiftedCholesky(h, groups)
    assert c.factor(h)
    n = h.shape[0]
    assert solve_many(c._symbolic, rng.normal(size=n)) is None              # one right-hand side: cvxopt's
    assert solve_many(c._symbolic, rng.normal(size=(n + 1, 3))) is None     # a factor of another size
    assert solve_many(c._symbolic, np.zeros((n, 0))) is None
    assert solve_many(object(), rng.normal(size=(n, 3))) is None            # not a capsule
    assert solve_many(c._a, rng.normal(size=(n, 3))) is None                # a cvxopt object that is no factor


def test_shifted_cholesky_falls_back_to_one_column_at_a_time(monkeypatch):
    h, groups, rng = _spd(6, 2)
    c = ShiftedCholesky(h, groups)
    assert c.factor(h, 1.0)
    b = rng.normal(size=(h.shape[0], 5))
    blocked = c.solve(b)
    monkeypatch.setattr(cholesky, "solve_many", lambda factor, rhs: None)
    fallback = c.solve(b)
    np.testing.assert_allclose(fallback, blocked, rtol=0, atol=1e-12 * np.abs(blocked).max())
    np.testing.assert_array_equal(fallback, c.solve(b, one_call=False))   # cvxopt's own loop


@pytest.mark.parametrize("k", [72, 100, 289])
def test_two_threads_give_the_same_bits_as_one_call(k):
    """A large right-hand side split at a multiple of ALIGN columns and solved on two threads is the
    same bits as one CHOLMOD call on one thread (the refinement's path must not depend on idle cores)."""
    h, groups, rng = _spd(70, 3)                 # 14 700 unknowns: k columns reach MIN_SPLIT
    c = ShiftedCholesky(h, groups)
    assert c.factor(h, 0.25)
    b = rng.normal(size=(h.shape[0], k))
    assert len(column_blocks(*b.shape, threads=2)) == 2
    one = solve_many(c._symbolic, b, threads=1)
    two = solve_many(c._symbolic, b, threads=2)
    assert one is not None and two is not None
    np.testing.assert_array_equal(two, one)
    np.testing.assert_allclose((h + 0.25 * sp.eye(h.shape[0])) @ two, b, rtol=0, atol=1e-10 * np.abs(b).max())


def test_column_blocks_split_only_large_right_hand_sides_at_aligned_columns():
    for n, k in [(17112, 289), (17112, 221), (14700, 72), (10536, 100), (200_000, 17)]:
        blocks = column_blocks(n, k, threads=2)
        assert len(blocks) == 2 and blocks[0][0] == 0 and blocks[-1][1] == k and blocks[0][1] == blocks[1][0]
        assert blocks[0][1] % ALIGN == 0 and min(b - a for a, b in blocks) >= ALIGN
        assert abs(blocks[0][1] - k / 2) <= ALIGN / 2
    assert column_blocks(17112, 289, threads=1) == [(0, 289)]                # no idle core: one call
    assert column_blocks(3144, 41, threads=2) == [(0, 41)]                   # vault1: under MIN_SPLIT
    assert column_blocks(10 * MIN_SPLIT, ALIGN + 3, threads=2) == [(0, ALIGN + 3)]   # too few columns to split


@pytest.mark.skipif(platform.machine() not in ("x86_64", "AMD64"), reason="OpenBLAS's x86 kernel families")
@pytest.mark.parametrize("coretype", ["Haswell", "Prescott"])
def test_the_split_is_the_same_bits_with_other_kernel_families(coretype):
    """The same check in a fresh process whose cvxopt runs another OpenBLAS kernel family (OPENBLAS_CORETYPE):
    Prescott's kernels round a column otherwise when a block starts at a column that is not a multiple of 4
    (so this test fails with ALIGN = 1), Haswell's of 2; this machine's own kernels may not show it."""
    script = textwrap.dedent("""
        import sys
        import numpy as np
        sys.path[:0] = [sys.argv[1], sys.argv[2]]
        from test_cholmod_block import _spd
        from airmat.inflation.cholesky import ShiftedCholesky, cvxopt_blas_kernels
        from airmat.inflation.cholmod_block import column_blocks, solve_many
        h, groups, rng = _spd(70, 3)
        c = ShiftedCholesky(h, groups)
        assert c.factor(h, 0.25)
        for k in (75, 77, 100, 289):
            b = rng.normal(size=(h.shape[0], k))
            assert len(column_blocks(*b.shape, threads=2)) == 2
            assert np.array_equal(solve_many(c._symbolic, b, threads=1), solve_many(c._symbolic, b, threads=2)), k
        print(cvxopt_blas_kernels())
    """)
    root = Path(__file__).resolve().parents[2]
    env = dict(os.environ, OPENBLAS_CORETYPE=coretype)
    run = subprocess.run([sys.executable, "-c", script, str(root), str(Path(__file__).parent)], env=env,
                         capture_output=True, text=True, timeout=120)
    assert run.returncode == 0, run.stderr[-2000:]
    assert run.stdout.strip().lower() == coretype.lower()


_FORKED = {}


def _solve_in_child():
    c, b = _FORKED["factor"], _FORKED["b"]
    return solve_many(c._symbolic, b, threads=2)


@pytest.mark.skipif(not hasattr(os, "fork"), reason="fork")
def test_a_forked_child_splits_on_threads_of_its_own():
    """A child forked after a split solve inherits the parent's thread pool but not its thread: it
    must make its own (and its own CHOLMOD workspaces) rather than wait for that thread forever."""
    import multiprocessing

    h, groups, rng = _spd(70, 4)
    c = ShiftedCholesky(h, groups)
    assert c.factor(h, 0.25)
    b = rng.normal(size=(h.shape[0], 100))
    parent = solve_many(c._symbolic, b, threads=2)
    _FORKED.update(factor=c, b=b)
    try:
        with multiprocessing.get_context("fork").Pool(1) as pool:
            child = pool.apply_async(_solve_in_child).get(timeout=60)
    finally:
        _FORKED.clear()
    np.testing.assert_array_equal(child, parent)
