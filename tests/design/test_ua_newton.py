"""Projected Newton on U_A (airmat.design.ua_newton): its gradient, its held place on S, its convergence."""

import numpy as np
import pytest

from airmat.errors import ConvergenceError, InputError
from airmat.synthetic.targets import saddle, sphere_cap
from airmat.design import ua_newton
from airmat.design.closest_point import MeshProjector
from airmat.design.local_global import UAProblem, iterate
from airmat.design.mattress import Mattress, triangulate_mattress
from airmat.design.relax import relax_to_target
from airmat.design.target import Target

MATTRESS = Mattress(0.5, 0.4)


@pytest.fixture(scope="module")
def problem():
    """A symmetric saddle (κ = ±3 1/m): far from developable, Ω has to slide along S everywhere."""
    surf = Target.from_mesh(saddle(a=1 / 3.0, b=1 / 3.0, extent=(0.7, 0.6), spacing=0.01))
    uv, faces = triangulate_mattress(MATTRESS, spacing=0.025)
    prob = UAProblem(uv, faces, MeshProjector(surf.vertices, surf.faces), 1.0, 0.2, 0.02)
    x0 = np.column_stack([uv - uv.mean(axis=0), np.zeros(len(uv))])
    return prob, prob.projector.closest(x0).points


def test_gradient_is_the_derivative_of_U_A(problem):
    prob, x0 = problem
    rng = np.random.default_rng(0)
    x = x0 + 1e-3 * rng.standard_normal(x0.shape)            # off S and strained: every term active
    cp = prob.project(x)
    grad = ua_newton._gradient(prob, x, cp)
    v = rng.standard_normal(x.shape)
    eps = 1e-7                                                # central difference: error O(eps²)
    e = [prob.energy(x + s * eps * v, prob.project(x + s * eps * v))["U_A"] for s in (1, -1)]
    assert (e[0] - e[1]) / (2 * eps) == pytest.approx(np.sum(grad * v), rel=1e-5)


def test_the_exact_hessian_is_the_derivative_of_the_gradient(problem):
    """Without A2 (whose Hessian drops terms of order distance × κ) the exact Hessian is ∇U_A's derivative; the
    projected one, which drops a compressed edge's negative transverse stiffness, is not."""
    prob0, x0 = problem
    uv, faces = triangulate_mattress(MATTRESS, spacing=0.025)
    prob = UAProblem(uv, faces, prob0.projector, 1.0, 0.0, 0.02)
    rng = np.random.default_rng(1)
    x = x0 + 2e-3 * rng.standard_normal(x0.shape)            # edges stretched and compressed
    cp, normal = prob.project(x), np.tile([0.0, 0.0, 1.0], (len(x), 1))
    assert (np.linalg.norm(prob.inc @ x, axis=1) < prob.rest).sum() > 100
    pattern = ua_newton._Pattern(prob)
    v = rng.standard_normal(x.shape)
    eps = 1e-7
    dg = (ua_newton._gradient(prob, x + eps * v, cp) - ua_newton._gradient(prob, x - eps * v, cp)).ravel() / (2 * eps)
    exact = ua_newton._hessian(prob, pattern, x, normal, exact=True) @ v.ravel()
    projected = ua_newton._hessian(prob, pattern, x, normal) @ v.ravel()
    assert np.linalg.norm(exact - dg) < 1e-6 * np.linalg.norm(dg)
    assert np.linalg.norm(projected - dg) > 1e-2 * np.linalg.norm(dg)


def test_a_contracting_sheet_converges_sooner_with_the_exact_hessian_and_a_quick_one_is_unchanged(problem):
    """A sphere cap of R = 250 mm contracts the 500 × 400 mm sheet: projected Newton (the default) converges only
    linearly, the exact A1 Hessian after 15 iterations reaches the same tolerance in fewer than 2/3 of the
    iterations. A relaxation that converges within those 15 iterations (the saddle) is the same to the bit."""
    surf = Target.from_mesh(sphere_cap(radius=0.25, extent=0.7, spacing=0.01))
    uv, faces = triangulate_mattress(MATTRESS, spacing=0.025)
    prob = UAProblem(uv, faces, MeshProjector(surf.vertices, surf.faces), 1.0, 0.2, 0.02)
    x0 = prob.projector.closest(np.column_stack([uv - uv.mean(axis=0), np.zeros(len(uv))])).points
    _, it_p, status_p, residual_p, _, _ = ua_newton.newton(prob, x0, tol=1e-4, max_iter=1000)
    _, it_e, status_e, residual_e, _, _ = ua_newton.newton(prob, x0, tol=1e-4, max_iter=1000, exact_after=15)
    assert status_p == status_e == "force" and residual_e < 1e-4
    assert it_p > 15 and it_e < 2 * it_p / 3
    prob_s, xs = problem
    a = ua_newton.newton(prob_s, xs, tol=1e-4, max_iter=100, exact_after=15)
    b = ua_newton.newton(prob_s, xs, tol=1e-4, max_iter=100)
    assert a[1] <= 15 and np.array_equal(a[0], b[0])


def test_newton_reaches_the_tolerance_and_holds_the_place(problem):
    prob, x0 = problem
    x, it, status, residual, history, slide = ua_newton.newton(prob, x0, tol=1e-4, max_iter=100)
    assert status == "force" and residual < 1e-4
    rows = ua_newton.slide_constraints(x0, prob.projector.closest(x0).normal)
    # the constraints are linear: the held mean tangential position and turn stay those of the start
    assert np.abs(rows @ (x - x0).ravel()).max() < 1e-9 * prob.h * np.sqrt(len(x))
    # the local-global iteration from the same start, given as many iterations, is still short of it
    _, it_lg, status_lg, residual_lg, _ = iterate(prob, x0, tol=1e-4, stall=0.0, max_iter=it, window=5, bar=None)
    assert status_lg == "max_iter" and residual_lg > residual


def test_a_line_search_keeps_U_A_decreasing(problem, monkeypatch):
    prob, x0 = problem
    energies = []
    real = ua_newton._line_search

    def spy(prob_, x, e, p, slope):
        step = real(prob_, x, e, p, slope)
        energies.append(e if step is None else step[-1])
        return step

    monkeypatch.setattr(ua_newton, "_line_search", spy)
    ua_newton.newton(prob, x0, tol=1e-4, max_iter=20)
    assert np.all(np.diff(energies) <= 0)


@pytest.mark.parametrize("entry, match", [(np.nan, "non-finite Newton matrix"), (-1e300, "no descent step")])
def test_a_newton_matrix_no_shift_makes_definite_ends_the_relaxation(problem, monkeypatch, entry, match):
    """A non-finite Hessian, or one no shift of MAX_SHIFTS makes definite, ends the relaxation with a
    ConvergenceError instead of raising the shift forever."""
    prob, x0 = problem
    real = ua_newton._hessian

    def broken(prob_, pattern, x, normal, **kw):
        h = real(prob_, pattern, x, normal, **kw)
        h.data[h.indptr[0] + np.flatnonzero(h.indices[h.indptr[0]:h.indptr[1]] == 0)[0]] = entry
        return h

    monkeypatch.setattr(ua_newton, "_hessian", broken)
    factorizations = []
    real_cholesky = ua_newton._Pattern.cholesky

    def counted(pattern):
        factorizations.append(real_cholesky(pattern))
        return factorizations[-1]

    monkeypatch.setattr(ua_newton._Pattern, "cholesky", counted)
    with pytest.raises(ConvergenceError, match=match) as err:
        ua_newton.newton(prob, x0, tol=1e-4, max_iter=100)
    if np.isfinite(entry):
        assert factorizations[0].n_factorizations == ua_newton.MAX_SHIFTS
        assert err.value.data["mu"] >= 10.0 ** (ua_newton.MAX_SHIFTS - 1) * ua_newton.MU_MIN * prob.k[0]
    else:
        assert factorizations[0].n_factorizations == 0


def test_unknown_solver_is_refused_before_any_work(problem):
    prob, _ = problem
    uv, faces = triangulate_mattress(MATTRESS, spacing=0.05)
    with pytest.raises(InputError, match="solver"):
        relax_to_target(uv, faces, None, solver="gradient", progress=False)
