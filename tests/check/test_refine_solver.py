"""The refinement's pieces: trial equilibria, the adjoint against finite differences, the damped step, two levels."""

import sys
from pathlib import Path
from types import SimpleNamespace

import numpy as np
import pytest

sys.path.insert(0, str(Path(__file__).parent))
from refine_case import RESOLUTION, moves_toward_the_true_lengths, off_case  # noqa: E402

from airmat.check.adjoint import adjoint_gradient, factor_equilibrium, rest_derivative  # noqa: E402
from airmat.check.inflation_check import check, design_strings  # noqa: E402
from airmat.check.refine_objective import face_fit  # noqa: E402
from airmat.check.refinement import refine  # noqa: E402
from airmat.check.trial_equilibrium import make_problem  # noqa: E402
from airmat.inflation.mesh import build_mattress_mesh  # noqa: E402
from airmat.inflation.model import Parameters  # noqa: E402
from airmat.inflation.simulate import inflate  # noqa: E402

#: the small case with a known answer (refine_case.py), once per module
case = pytest.fixture(scope="module", name="case")(off_case)


def _problem(design, tol=1e-11):
    s = design_strings(design)
    m = design.mattress
    mesh = build_mattress_mesh(m.width, m.height, m.thickness, resolution=RESOLUTION)
    prob = make_problem(mesh, s, Parameters(), design, "top", tol)
    return prob, s, inflate(mesh, s, tol=tol)


def test_a_failed_trial_leaves_the_newton_shift_as_it_was(case):
    # a trial from a wild start fails; the shift it needed must not slow the next trial
    prob, s, inf = _problem(case, tol=1e-8)
    prob.system.hint_rel, prob.max_newton = 1e-6, 2
    shaken = inf.xyz + 0.002 * np.random.default_rng(0).normal(size=inf.xyz.shape)
    assert prob.equilibrium(s.rest, shaken) is None         # needs a large shift, and more than 2 iterations
    assert prob.system.hint_rel == 1e-6                     # (the solver itself left it at 1.0)
    assert prob.equilibrium(s.rest, 3.0 * inf.xyz) is None  # edges stretched far beyond 50 %: raises inside
    prob.max_newton = 50
    eq = prob.equilibrium(s.rest, inf.xyz)
    assert eq is not None and eq.n_iter <= 1


def test_a_trial_has_a_smaller_newton_budget_than_the_solves_that_are_not_trials(case):
    from airmat.check.trial_equilibrium import SOLVE_NEWTON, TRIAL_NEWTON

    prob, s, inf = _problem(case, tol=1e-8)
    assert prob.max_newton == TRIAL_NEWTON < SOLVE_NEWTON
    shaken = inf.xyz + 0.002 * np.random.default_rng(1).normal(size=inf.xyz.shape)
    slow = prob.equilibrium(s.rest, shaken, SOLVE_NEWTON)
    assert slow is not None and slow.n_iter > 2
    assert prob.equilibrium(s.rest, shaken, max_newton=slow.n_iter - 1) is None       # out of its budget


def test_a_trial_without_an_equilibrium_is_not_logged_as_a_warning_but_a_plain_solve_is(case, caplog):
    # a trial out of its budget is an answer the Gauss–Newton loop uses (the step shrinks), not a fault:
    # API users would otherwise see one warning per refused step
    import logging

    from airmat.inflation.solver import solve

    prob, s, inf = _problem(case, tol=1e-8)
    shaken = inf.xyz + 0.002 * np.random.default_rng(1).normal(size=inf.xyz.shape)
    with caplog.at_level(logging.DEBUG, logger="airmat.inflation.solver"):
        assert prob.equilibrium(s.rest, shaken, max_newton=1) is None
    unconverged = [r for r in caplog.records if "not converged" in r.getMessage()]
    assert unconverged and all(r.levelno == logging.DEBUG for r in unconverged)
    caplog.clear()
    with caplog.at_level(logging.WARNING, logger="airmat.inflation.solver"):
        r = solve(prob.model(s.rest), shaken, fixed_dofs=prob.fixed, tol=1e-8, max_iter=1)
    assert not r.converged
    assert [rec.levelno for rec in caplog.records] == [logging.WARNING]


def test_the_trials_solve_with_their_own_rule_for_a_refused_step(case, monkeypatch):
    import airmat.check.trial_equilibrium as te
    import airmat.inflation.solver as sv

    prob, s, inf = _problem(case, tol=1e-8)
    seen, check_rule = [], (sv.REFUSED_STEP, sv.MU_UP)
    assert te.TRIAL_REFUSED_STEP == ("shift", 4.0) and check_rule == ("backtrack", 2.0)   # the documented rules

    def solve(*args, **kwargs):
        seen.append((kwargs["refused_step"], kwargs["mu_up"]))
        return sv.solve(*args, **kwargs)

    monkeypatch.setattr(te, "solve", solve)
    for rule in (("backtrack", 2.0), ("shift", 4.0)):
        monkeypatch.setattr(te, "TRIAL_REFUSED_STEP", rule)
        eq = prob.equilibrium(s.rest, inf.xyz + 1e-4)
        assert eq is not None and eq.converged
        assert seen[-1] == rule
    assert (sv.REFUSED_STEP, sv.MU_UP) == check_rule        # the check's own inflations keep theirs


def test_adjoint_gradient_and_jacobian_match_finite_differences(case):
    prob, s, inf = _problem(case)
    assert inf.converged
    jac, _ = prob.jacobian(s.rest, inf.xyz)
    fit = face_fit(prob.p, inf.xyz, prob.approx_xyz)
    # the one-back-substitution adjoint gradient of the mean squared distance, Ŝ held at its alignment
    model = prob.model(s.rest)
    fac = factor_equilibrium(model, inf.xyz, prob.asm)
    dj_dx = 2.0 * (prob.p.T @ (prob.p @ inf.xyz - fit.target)) / prob.p.shape[0]
    grad = adjoint_gradient(fac, rest_derivative(model.springs[-1], inf.xyz, case.mattress.thickness), dj_dx)
    assert fac.shift == 0.0
    np.testing.assert_allclose(grad, 2.0 * jac.T @ fit.residual, rtol=1e-9)
    h = 1e-4     # 0.1 mm: the equilibrium map is smooth at this scale (wrinkles switch beyond ~1 mm)
    n = prob.p.shape[0]
    for q in range(len(s.rest)):
        faces, objectives = [], []
        for sign in (1.0, -1.0):
            rest = s.rest.copy()
            rest[q] += sign * h
            x = prob.equilibrium(rest, inf.xyz).xyz
            faces.append(prob.p @ x)
            objectives.append(face_fit(prob.p, x, prob.approx_xyz).objective)   # re-aligned: rigid-invariant
        fd_face = (faces[0] - faces[1]).ravel() / (2 * h) / np.sqrt(n)
        assert np.linalg.norm(fd_face - jac[:, q]) < 1e-3 * np.linalg.norm(fd_face)
        fd_grad = (objectives[0] - objectives[1]) / (2 * h)
        assert abs(grad[q] - fd_grad) < 1e-3 * abs(fd_grad)


def test_a_defect_correction_makes_the_coarse_face_fit_the_fine_one(case):
    # after a correction at lengths l, the coarse face fit at its equilibrium is the fine face's at l
    from airmat.check.trial_equilibrium import coarse_start, correct
    from airmat.check.inflation_check import named_face
    s = design_strings(case)
    m = case.mattress
    mesh = build_mattress_mesh(m.width, m.height, m.thickness, resolution=0.02)
    cmesh = build_mattress_mesh(m.width, m.height, m.thickness, resolution=0.04)
    named = named_face(case, s)
    prob = make_problem(mesh, s, Parameters(), case, named, 1e-6)
    cprob = make_problem(cmesh, s, Parameters(), case, named, 1e-6)
    first = inflate(mesh, s, tol=1e-6, keep_levels=True)
    cstart = coarse_start(cprob, first, s, Parameters(), 1e-6)
    cprob.offset = prob.p @ first.xyz - cprob.p @ cstart.xyz
    l = s.rest - 0.004                                        # other lengths: the open-loop offset is off there
    ceq = cprob.equilibrium(l, cstart.xyz)
    fine = correct(prob, cprob, l, ceq.xyz, 1e-8)
    assert fine is not None and fine.converged
    assert prob.tol == 1e-6                                   # the fine problem keeps its own tolerance
    want = face_fit(prob.p, fine.xyz, prob.approx_xyz).objective
    assert cprob.fit(ceq.xyz).objective == pytest.approx(want, rel=1e-9)
    # a loose stopping rule stops the coarse iterations early; one correction lets them go on, closer
    plain = refine(case, resolution=0.02, max_iter=8, rms_tol=5e-4)
    r = refine(case, resolution=0.02, max_iter=8, rms_tol=5e-4, corrections=1)
    assert plain.corrections == () and plain.iterations < 8
    assert r.design.refine["defect_corrections"] == len(r.corrections) == 1
    assert r.iterations > plain.iterations and r.deviation_after.rms < plain.deviation_after.rms
    c = check(r.design, resolution=0.02, envelope=False)     # and the check reproduces what it promised
    assert c.runs["median"].deviation.rms == pytest.approx(r.deviation_after.rms, rel=1e-9)


def test_two_level_refinement_iterates_on_the_coarse_mesh_and_the_check_reproduces_it(case):
    # at 20 mm the Gauss–Newton iterations run on the 40 mm mesh, its face corrected by the difference of
    # the two meshes' faces at the open-loop lengths; the verification is a fresh inflation at 20 mm
    r = refine(case, resolution=0.02, max_iter=6)
    assert r.coarse_resolution == pytest.approx(0.04) and r.design.refine["coarse_resolution_mm"] == 40.0
    assert r.deviation_after.rms < 0.6 * r.deviation_before.rms
    moves_toward_the_true_lengths(r.l_simulated)                   # closer to the lengths that made Ŝ
    c = check(r.design, resolution=0.02, envelope=False)
    assert c.runs["median"].deviation.rms == pytest.approx(r.deviation_after.rms, rel=1e-9)
    # the same input gives the same lengths (no random step)
    again = refine(case, resolution=0.02, max_iter=6)
    np.testing.assert_array_equal(again.l_simulated, r.l_simulated)


def test_the_reduced_damped_step_is_the_tall_problems_step():
    # the k × k reduction (Cholesky of the Gram matrix) gives the bounded Levenberg–Marquardt step of the
    # (3N + k) × k problem, and the same residual for every step
    from scipy.optimize import lsq_linear

    from airmat.check.damped_step import damped_step, reduce_least_squares
    rng = np.random.default_rng(3)
    a, r = rng.normal(size=(400, 15)), rng.normal(size=400)
    scale = np.linalg.norm(a, axis=0)
    lower, upper = -0.04 * np.ones(15), 0.05 * np.ones(15)
    for lam in (1e-3, 0.3, 30.0):
        got = damped_step(*reduce_least_squares(a, r), scale, lam, lower, upper)
        tall = lsq_linear(np.vstack([a, np.sqrt(lam) * np.diag(scale)]), -np.concatenate([r, np.zeros(15)]),
                          bounds=(lower, upper)).x
        np.testing.assert_allclose(got, tall, atol=1e-9)
        if lam == 1e-3:      # the bounds bind here
            assert np.sum(np.isclose(got, lower) | np.isclose(got, upper)) >= 2
    rr, c = reduce_least_squares(a, r)
    assert np.allclose(np.tril(rr, -1), 0.0)
    for s in rng.normal(size=(3, 15)):
        assert np.sum((a @ s + r) ** 2) == pytest.approx(np.sum((rr @ s + c) ** 2) + r @ r - c @ c, rel=1e-12)


def test_the_reduction_keeps_an_ill_conditioned_jacobians_steps():
    # the refinement's matrix: a face Jacobian with nearly dependent columns (strings with almost the same
    # effect) over the Tikhonov rows w I; the Gram matrix squares its condition number (~1e9 here)
    from scipy.optimize import lsq_linear

    from airmat.check.damped_step import damped_step, reduce_least_squares
    rng = np.random.default_rng(5)
    base = rng.normal(size=(600, 8))
    jac = np.hstack([base, base + 1e-3 * rng.normal(size=(600, 8))])     # pairs of near-twins
    k, w = jac.shape[1], np.sqrt(1e-2 / 16)
    a, r = np.vstack([jac, w * np.eye(k)]), rng.normal(size=600 + k)
    assert np.linalg.cond(a.T @ a) > 1e6
    scale = np.linalg.norm(a, axis=0)
    for lam in (0.0, 1e-6, 1e-2):
        got = damped_step(*reduce_least_squares(a, r), scale, lam, -np.inf * np.ones(k), np.inf * np.ones(k))
        tall = lsq_linear(np.vstack([a, np.sqrt(lam) * np.diag(scale)]), -np.concatenate([r, np.zeros(k)])).x
        np.testing.assert_allclose(got, tall, atol=1e-8 * np.max(np.abs(tall)))


def test_the_coarse_start_is_the_coarse_meshs_own_inflation(case):
    # the first inflation keeps its coarser levels (without changing its result); the open-loop equilibrium
    # on the 40 mm mesh carried on from its level is the one a fresh inflation on that mesh finds
    from airmat.check.trial_equilibrium import coarse_start
    s = design_strings(case)
    m = case.mattress
    mesh = build_mattress_mesh(m.width, m.height, m.thickness, resolution=0.02)
    kept = inflate(mesh, s, keep_levels=True)
    plain = inflate(mesh, s)
    np.testing.assert_array_equal(kept.xyz, plain.xyz)
    cmesh = build_mattress_mesh(m.width, m.height, m.thickness, resolution=0.04)
    coarser = build_mattress_mesh(m.width, m.height, m.thickness, resolution=0.08)
    assert plain.levels == ()
    assert [(lm.n_vertices, len(x)) for lm, x in kept.levels] == [(cmesh.n_vertices,) * 2, (coarser.n_vertices,) * 2]
    cprob = make_problem(cmesh, s, Parameters(), case, "top", 1e-6)
    start = coarse_start(cprob, kept, s, Parameters(), 1e-6)
    fresh = inflate(cmesh, s)
    assert start.converged and start.n_iter < fresh.n_iter
    assert np.max(np.abs(start.xyz - fresh.xyz)) < 1e-6     # m: the same equilibrium


class _Overshoot:
    """A one-string stand-in for a TrialProblem: the face's residual r(l) = l + a l² - c, the equilibrium x = l.

    From l = 0 the Gauss–Newton step is c, where r = a c²: it realizes 1 - a²c² of the decrease its
    linear model predicts (0.0975 for a = 0.95, c = 1), a little gain for a long step."""

    mesh_label = "a stand-in"

    def __init__(self, a=0.95, c=1.0):
        self.a, self.c, self.trials = a, c, []

    def fit(self, x):
        l = x[0, 0]
        r = np.array([l + self.a * l * l - self.c])
        return SimpleNamespace(objective=float(r @ r), residual=r)

    def jacobian(self, rest, x):
        return np.array([[1.0 + 2.0 * self.a * rest[0]]]), np.array([[1.0], [0.0], [0.0]])

    def equilibrium(self, rest, x0, max_newton=None):
        self.trials.append(float(rest[0]))
        return SimpleNamespace(xyz=np.array([[rest[0], 0.0, 0.0]]), n_iter=1)


def test_a_step_that_realizes_under_a_quarter_of_its_predicted_decrease_is_not_taken():
    # a step is taken only when rho > ACCEPT (0.25): accepting any decrease lets the saddle's first iteration
    # take a 50 mm change of its lengths that realizes 1 % of the predicted decrease (rho 0.01), and the
    # refinement then lands anywhere between 0.89 and 1.26 % of the diagonal over lengths jittered by 5 µm
    # (docs/decisions.md, Refinement)
    from airmat.check.gauss_newton import ACCEPT, gauss_newton
    prob = _Overshoot()
    kw = dict(alpha=1e-12, ftol=1e-12, xtol=1e-12, rms_tol=0.0)
    lo, hi, x0 = np.array([-10.0]), np.array([10.0]), np.zeros((1, 3))
    one = gauss_newton(prob, np.zeros(1), np.zeros(1), x0, lo, hi, max_iter=1, **kw)
    first = prob.trials[0]
    rho_first = (prob.c ** 2 - prob.fit(np.array([[first, 0, 0]])).objective) / prob.c ** 2
    assert first == pytest.approx(prob.c, rel=1e-2) and 1e-3 < rho_first < ACCEPT   # the near-GN step, poor
    assert len(prob.trials) > 1 and one.lengths[0] < prob.trials[1] < first             # refused, shorter ones tried
    assert one.iterations == 1 and one.lengths[0] == prob.trials[-1]
    # the step taken is shorter and gains more than the refused one
    assert one.objective_after < 0.75 * prob.fit(np.array([[first, 0, 0]])).objective
    root = (-1.0 + np.sqrt(1.0 + 4.0 * prob.a * prob.c)) / (2.0 * prob.a)
    done = gauss_newton(_Overshoot(), np.zeros(1), np.zeros(1), x0, lo, hi, max_iter=30, **kw)
    assert done.converged and done.lengths[0] == pytest.approx(root, abs=1e-6)


class _OutOfReach(_Overshoot):
    """The linear stand-in (r = l - c) whose trial equilibria fail beyond l = ``reach``, as a trial that runs
    out of Newton iterations does: the steps that are taken realize what their model predicted (rho = 1)."""

    def __init__(self, reach):
        super().__init__(a=0.0)
        self.reach = reach

    def equilibrium(self, rest, x0, max_newton=None):
        eq = super().equilibrium(rest, x0, max_newton)
        return eq if rest[0] <= self.reach else None


def test_the_damping_shrinks_only_after_an_iteration_whose_first_step_was_taken():
    # after an iteration that had to grow the damping (a trial without an equilibrium, or refused), the next
    # one starts from the damping that worked, not a third of it: on the dome the shrunk damping's first
    # trials fail again and again (docs/decisions.md, Refinement; the rule: docs/method.md, The refinement)
    from airmat.check.gauss_newton import LAM_DOWN, gauss_newton
    kw = dict(alpha=1e-12, ftol=1e-12, xtol=1e-12, rms_tol=0.0)
    lo, hi, x0 = np.array([-10.0]), np.array([10.0]), np.zeros((1, 3))
    prob = _OutOfReach(reach=0.9)
    one = gauss_newton(prob, np.zeros(1), np.zeros(1), x0, lo, hi, max_iter=1, lam0=1e-3, **kw)
    assert len(prob.trials) > 1 and max(prob.trials[:-1]) > 0.9 and one.lengths[0] == prob.trials[-1] <= 0.9
    assert one.damping == pytest.approx(1e-3 * 4.0 ** (len(prob.trials) - 1))   # held where the step was taken
    free = _OutOfReach(reach=np.inf)                    # the first step is taken (rho = 1): the damping shrinks
    first = gauss_newton(free, np.zeros(1), np.zeros(1), x0, lo, hi, max_iter=1, lam0=1e-3, **kw)
    assert len(free.trials) == 1 and first.damping == pytest.approx(1e-3 / LAM_DOWN)


def test_the_default_rms_step_of_the_stopping_rule_is_a_share_of_the_mattress_diagonal():
    """0.05 mm on the small mattress, in proportion on the large one; an explicit rms_tol is kept."""
    from airmat.check.refine_setup import solver_options
    from airmat.check.refinement_result import RefineOptions
    from airmat.design.mattress import Mattress

    def tol(width, height, **kw):
        setup = SimpleNamespace(upper=np.array([0.3]), design=SimpleNamespace(mattress=Mattress(width, height)))
        return solver_options(setup, RefineOptions(**kw))["rms_tol"]

    small, large = tol(0.83, 0.74), tol(2.6, 1.6)
    assert small == pytest.approx(5.0e-5, rel=1e-3)
    assert large / small == pytest.approx(np.hypot(2.6, 1.6) / np.hypot(0.83, 0.74), rel=1e-12)
    assert tol(2.6, 1.6, rms_tol=2e-5) == 2e-5
