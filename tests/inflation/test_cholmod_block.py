"""CHOLMOD's many-right-hand-side solve on cvxopt's factor: the same answer as cvxopt's column-by-column solve."""

import numpy as np
import pytest
import scipy.sparse as sp

import inflation.cholesky as cholesky
from inflation.cholesky import ShiftedCholesky
from inflation.cholmod_block import available, solve_many


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
