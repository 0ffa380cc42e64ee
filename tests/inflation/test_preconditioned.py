"""Newton steps by conjugate gradients with a factor that leaves out U_B5's far couplings."""

import numpy as np
import pytest

from airmat.inflation.assembly import build_assembler
from airmat.inflation.cholesky import ShiftedCholesky
from airmat.inflation.energy import block_pattern, hessian_blocks, smoothing_blocks
from airmat.inflation.mesh import build_mattress_mesh
from airmat.inflation.model import Parameters, build_model
from airmat.inflation.preconditioned import PreconditionedSystem, far_couplings, pcg
from airmat.inflation.simulate import inflate
from airmat.inflation.solver import NewtonSystem, rigid_pins
from airmat.inflation.strings import StringSet

W, H, D = 0.5, 0.3, 0.07


@pytest.fixture(scope="module")
def system():
    """A small mattress's model with two strings, its assembler and a Newton matrix away from rest."""
    mesh = build_mattress_mesh(W, H, D, resolution=0.025)
    strings = StringSet(np.array([[0.1, 0.15], [0.25, 0.05]]), np.array([[0.4, 0.15], [0.25, 0.25]]),
                        np.array([True, False]), np.array([0.27, 0.18]))
    model = build_model(mesh, strings, Parameters())
    pattern = block_pattern(model)
    asm = build_assembler(pattern, model.n_vertices, rigid_pins(mesh.uv, mesh.top))
    x = mesh.vertices * 1.01 + np.random.default_rng(0).normal(scale=2e-4, size=mesh.vertices.shape)
    h = asm.assemble(hessian_blocks(model, x) + [smoothing_blocks(model)])
    return mesh, strings, model, pattern, asm, h


def test_pcg_solves_a_definite_system_and_stops_at_negative_curvature():
    rng = np.random.default_rng(1)
    b = rng.normal(size=(40, 40))
    a = b @ b.T + 40 * np.eye(40)
    rhs = rng.normal(size=40)
    x, k, status = pcg(lambda v: a @ v, rhs, lambda r: r / np.diag(a), 1e-12, 200)
    assert status == "converged" and k <= 40
    np.testing.assert_allclose(x, np.linalg.solve(a, rhs), rtol=1e-9)
    x, k, status = pcg(lambda v: a @ v, rhs, lambda r: r, 1e-12, 3)
    assert status == "max_iter" and k == 3 and rhs @ x > 0            # a descent direction all the same
    indefinite = np.diag([1.0, 2.0, -1.0])
    _, _, status = pcg(lambda v: indefinite @ v, np.ones(3), lambda r: r, 1e-12, 10)
    assert status == "negative curvature"


def test_the_far_couplings_are_the_smoothings_own_and_their_compensation_keeps_m_above_h(system):
    mesh, strings, model, pattern, asm, h = system
    keep, added = far_couplings(pattern, model.smoothing, asm.free, asm.indices, asm.indptr)
    n = model.n_vertices
    vertex = asm.free // 3
    rows = np.repeat(np.arange(asm.n_free), np.diff(asm.indptr))
    pair = vertex[rows] * n + vertex[asm.indices]
    near = np.unique(np.concatenate([r.astype(np.int64) * n + c for r, c in pattern[:-1]]))
    q = model.smoothing.tocoo()
    smooth = np.unique(q.row.astype(np.int64) * n + q.col)
    assert np.array_equal(keep, np.isin(pair, near))                 # every other term's entry kept ...
    assert np.all(np.isin(pair[~keep], smooth)) and (~keep).sum() > 0   # ... and only the smoothing's dropped
    ps = PreconditionedSystem(pattern, model.smoothing, asm)
    m = ps.preconditioner(h)
    dense_h, dense_m = h.toarray(), m.toarray()
    assert m.nnz == int(keep.sum())
    gap = dense_m - dense_h                                           # a Laplacian of the dropped couplings
    np.testing.assert_allclose(gap.sum(axis=1)[added == 0], 0.0, atol=1e-9 * np.abs(dense_h).max())
    assert np.linalg.eigvalsh(gap).min() > -1e-9 * np.abs(dense_h).max()
    np.testing.assert_allclose(np.diag(gap), added, rtol=1e-12)
    # the point of it: a sparser factor
    full, sparse = ShiftedCholesky(h, asm.free // 3), ShiftedCholesky(m, asm.free // 3)
    mu = 10 * np.abs(h.diagonal()).max()
    assert full.factor(h, mu) and sparse.factor(m, mu)
    assert sparse.factor_nnz < 0.8 * full.factor_nnz


def test_a_preconditioned_step_is_the_newton_step_to_its_tolerance(system):
    mesh, strings, model, pattern, asm, h = system
    g = np.random.default_rng(2).normal(size=asm.n_free)
    exact = NewtonSystem(groups=asm.free // 3, mu_min=1e-9)
    inexact = PreconditionedSystem(pattern, model.smoothing, asm, rtol=1e-10, max_cg=500, mu_min=1e-9)
    mu = 1e-3 * float(np.mean(np.abs(h.diagonal())))
    dx, mu_exact = exact.step(h, g, mu)
    dy, mu_inexact = inexact.step(h, g, mu)
    assert mu_inexact == mu_exact
    np.testing.assert_allclose(dy, dx, rtol=0, atol=1e-7 * np.abs(dx).max())
    assert inexact.cg_iterations > 1 and inexact.n_factorizations == 1


def test_an_indefinite_matrix_raises_the_shift_as_a_factorization_does(system):
    mesh, strings, model, pattern, asm, h = system
    shifted = h.copy()                                                # H - 2 max|h_ii| I: indefinite, same pattern
    shifted.data[np.repeat(np.arange(h.shape[0]), np.diff(h.indptr)) == h.indices] -= 2 * np.abs(h.diagonal()).max()
    g = np.ones(asm.n_free)
    exact = NewtonSystem(groups=asm.free // 3, mu_min=1e-9)
    inexact = PreconditionedSystem(pattern, model.smoothing, asm, rtol=1e-8, max_cg=500, mu_min=1e-9)
    _, mu_exact = exact.step(shifted, g, 1.0)
    dy, mu_inexact = inexact.step(shifted, g, 1.0)
    assert mu_exact > 1.0 and mu_inexact > 1.0
    assert g @ dy < 0                                                  # a descent direction of -g


def test_an_inflation_by_preconditioned_steps_lands_on_the_same_equilibrium(system):
    mesh, strings, *_ = system
    runs = [inflate(mesh, strings, pcg_min=p) for p in (10 ** 9, 0)]     # by factorizations; PCG on every mesh
    assert all(r.converged and r.residual < 1e-6 for r in runs)
    # within 0.01 mm (the 0.1 mm / 10); the wrinkled membrane's flat valley holds equilibria micrometres
    # apart (here 1.5 µm, the same at a residual of 1e-10), which inexact steps may end on
    assert np.max(np.linalg.norm(runs[1].xyz - runs[0].xyz, axis=1)) < 1e-5
