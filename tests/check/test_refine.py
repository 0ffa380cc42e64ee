"""Refinement through the equilibrium: adjoint gradient vs finite differences, a refinement that lands on Ŝ."""

import dataclasses
import json
import sys
from pathlib import Path

import numpy as np
import pytest

sys.path.insert(0, str(Path(__file__).parent))
from refine_case import RESOLUTION, TRUE_SIM, small_design  # noqa: E402

from airmat.cli import main  # noqa: E402
from airmat.errors import InputError  # noqa: E402
from check.adjoint import adjoint_gradient, factor_equilibrium, rest_derivative  # noqa: E402
from check.inflation_check import check, design_strings  # noqa: E402
from check.length_map import length_map  # noqa: E402
from check.refine_objective import face_fit  # noqa: E402
from check.refinement import refine  # noqa: E402
from check.trial_equilibrium import make_problem  # noqa: E402
from design.design_io import read_design, write_design  # noqa: E402
from inflation.mesh import build_mattress_mesh  # noqa: E402
from inflation.model import Parameters  # noqa: E402
from inflation.simulate import inflate  # noqa: E402

#: open-loop lengths off the true ones (all shorter: every string stays taut)
OFF = np.array([-0.012, -0.006, -0.015])


@pytest.fixture(scope="module")
def case():
    return small_design(TRUE_SIM + OFF)


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
    from check.trial_equilibrium import SOLVE_NEWTON, TRIAL_NEWTON

    prob, s, inf = _problem(case, tol=1e-8)
    assert prob.max_newton == TRIAL_NEWTON < SOLVE_NEWTON
    shaken = inf.xyz + 0.002 * np.random.default_rng(1).normal(size=inf.xyz.shape)
    slow = prob.equilibrium(s.rest, shaken, SOLVE_NEWTON)
    assert slow is not None and slow.n_iter > 2
    assert prob.equilibrium(s.rest, shaken, max_newton=slow.n_iter - 1) is None       # out of its budget


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


@pytest.fixture(scope="module")
def refined(case):
    return refine(case, resolution=RESOLUTION, max_iter=6)


def test_refinement_lowers_the_deviation_and_the_check_reproduces_it(case, refined):
    r = refined
    assert r.iterations == 6 and r.deviation_after.rms < 0.6 * r.deviation_before.rms
    assert r.objective_after < r.objective_before
    # the lengths move toward the ones that made Ŝ (a string's effect is partly taken over by its
    # neighbours', so not each one on its own); measured 0.65 of the start error after 6 iterations
    assert np.linalg.norm(r.l_simulated - TRUE_SIM) < 0.75 * np.linalg.norm(OFF)
    # the check of the refined design (its own flat start and ramp) measures what the refinement promised
    c = check(r.design, resolution=RESOLUTION, envelope=False)
    assert c.surface == r.surface == "top"
    assert c.runs["median"].deviation.rms == pytest.approx(r.deviation_after.rms, rel=1e-9)
    # real lengths through the length map; the tolerance moves with the median
    lm = length_map(case.calibration)
    for old, new, l_sim in zip(case.pattern.strings, r.design.pattern.strings, r.l_simulated):
        assert new.l_median == pytest.approx(float(lm.to_real(l_sim)))
        assert new.l_hi95 - new.l_median == pytest.approx(old.l_hi95 - old.l_median)
        assert new.l_median - new.l_lo95 == pytest.approx(old.l_median - old.l_lo95)
    block = r.design.refine
    assert block["iterations"] == 6 and block["deviation_after"]["rms_mm"] == pytest.approx(
        r.deviation_after.rms * 1e3, abs=1e-3)


def test_the_pull_toward_the_open_loop_lengths_grows_with_alpha(case, refined):
    # the Tikhonov term alpha * mean((l* - l*_open)^2): a strong pull keeps the lengths near the
    # open-loop ones (and so far from the ones that made S-hat), the default lets them go; measured:
    # 2.4 mm moved against 11.0 mm, 3.3 mm RMS left against 1.4 mm (3.9 mm open loop)
    strong = refine(case, resolution=RESOLUTION, max_iter=6, alpha=1.0)
    l_open = design_strings(case).rest
    assert refined.alpha == refined.design.refine["alpha"] == 1e-3 and strong.design.refine["alpha"] == 1.0
    moved, held = (np.linalg.norm(r.l_simulated - l_open) for r in (refined, strong))
    assert held < 0.5 * moved
    assert np.linalg.norm(strong.l_simulated - TRUE_SIM) > np.linalg.norm(refined.l_simulated - TRUE_SIM)
    assert strong.deviation_after.rms > refined.deviation_after.rms


def test_the_check_takes_the_verification_as_its_median_run_only_when_it_is_that_run(refined):
    r = refined
    reused = check(r.design, resolution=RESOLUTION, envelope=False, known=r.verification)
    fresh = check(r.design, resolution=RESOLUTION, envelope=False)
    assert reused.runs["median"].inflation.xyz is r.verification.inflation.xyz       # not inflated again
    assert fresh.runs["median"].inflation.xyz is not r.verification.inflation.xyz
    np.testing.assert_array_equal(fresh.runs["median"].inflation.xyz, reused.runs["median"].inflation.xyz)
    assert reused.runs["median"].deviation.rms == fresh.runs["median"].deviation.rms == r.deviation_after.rms
    # another run than the known one is inflated: other parameters, another mesh, other lengths
    for kw in ({"params": Parameters(pressure=0.9 * Parameters().pressure)}, {"resolution": 0.03},
               {"known": dataclasses.replace(r.verification, tol=1e-8)}):
        other = check(r.design, **{"resolution": RESOLUTION, "envelope": False, "known": r.verification, **kw})
        assert other.runs["median"].inflation.xyz is not r.verification.inflation.xyz
    shifted = dataclasses.replace(r.verification, strings=dataclasses.replace(
        r.verification.strings, rest=r.verification.strings.rest + 1e-4))
    assert not shifted.stands_for(design_strings(r.design), r.verification.inflation.mesh, Parameters(), 1e-6)
    assert r.verification.stands_for(design_strings(r.design), r.verification.inflation.mesh, Parameters(), 1e-6)


def test_the_refined_design_carries_s_hat_reparametrized_and_none_keeps_it_as_designed(case, refined):
    # by default one round moves Ŝ's points along Ŝ into the metric the face realizes (check.reparametrize);
    # the refined design carries that Ŝ, which the check compared with above (the deviation it reproduces)
    r = refined
    rep = r.reparametrization
    assert r.reparametrize_rounds == 1 and rep is not None
    np.testing.assert_array_equal(r.design.approx.xyz, rep.xyz)
    moved = np.linalg.norm(rep.xyz - case.approx.xyz, axis=1)
    assert rep.moved_max == pytest.approx(moved.max()) and 0 < rep.moved_max < 0.01
    assert rep.off_rms < 0.1 * rep.moved_rms               # along Ŝ, not off it (measured 0.05 against 0.8 mm)
    b = r.design.refine["reparametrization"]
    assert b["rounds"] == 1 and b["moved_max_mm"] == pytest.approx(rep.moved_max * 1e3, abs=1e-3)
    assert b["deviation_before"]["rms_mm"] == pytest.approx(r.deviation_before_reparametrized.rms * 1e3, abs=1e-3)
    # 0 rounds: Ŝ as designed, and nothing about it in the block
    r0 = refine(case, resolution=RESOLUTION, max_iter=6, reparametrize=0)
    np.testing.assert_array_equal(r0.design.approx.xyz, case.approx.xyz)
    assert r0.reparametrization is None and r0.design.refine["reparametrization"] is None
    assert r0.iterations == 6 and r0.deviation_after.rms < r0.deviation_before.rms
    with pytest.raises(InputError, match="reparametrize must be 0 or more"):
        refine(case, resolution=RESOLUTION, reparametrize=-1)


def test_the_checks_tolerance_is_the_inflations_default():
    import inspect

    from inflation.simulate import INFLATE_TOL
    from inflation.simulate import inflate as inflate_fn
    assert inspect.signature(inflate_fn).parameters["tol"].default == INFLATE_TOL
    assert inspect.signature(refine).parameters["tol"].default == INFLATE_TOL   # the verification the check reuses


def test_refine_block_round_trips_through_the_design_folder(refined, tmp_path):
    write_design(refined.design, tmp_path)
    doc = json.loads((tmp_path / "design.json").read_text())
    assert set(doc["refine"]) >= {"converged", "iterations", "seconds", "deviation_before", "deviation_after"}
    assert set(doc["refine"]["deviation_after"]) >= {"rms_mm", "rms_pct_diag"}
    back = read_design(tmp_path)
    assert back.refine == doc["refine"]
    # Ŝ as the refinement left it (re-parametrized), float32 mm in approx_surface.ply
    np.testing.assert_allclose(back.approx.xyz, refined.design.approx.xyz, atol=1e-5)
    got = [s.l_median for s in back.pattern.strings]
    np.testing.assert_allclose(got, [s.l_median for s in refined.design.pattern.strings], atol=1e-5)


def test_a_string_already_right_stays_and_never_worse_than_open_loop():
    r = refine(small_design(TRUE_SIM), resolution=RESOLUTION, max_iter=3)
    assert r.deviation_after.rms <= r.deviation_before.rms
    np.testing.assert_allclose(r.l_simulated, TRUE_SIM, atol=2e-3)


@pytest.mark.parametrize("what, words", [("none", "no strings"), ("coarse", "too coarse"),
                                         ("samples", "posterior samples")])
def test_bad_input_is_refused_before_any_work(case, what, words):
    d, res = case, RESOLUTION
    if what == "none":
        d = dataclasses.replace(case, pattern=dataclasses.replace(case.pattern, strings=()))
    elif what == "coarse":
        res = 0.2
    else:
        cal = dataclasses.replace(case.calibration, delta=np.zeros(0), d=np.zeros(0))
        d = dataclasses.replace(case, calibration=cal)
    with pytest.raises(InputError, match=words):
        refine(d, resolution=res)


def test_cli_refine_writes_the_refined_design_and_bad_input_writes_nothing(case, tmp_path, capsys):
    src = tmp_path / "design"
    write_design(case, src)
    bad = tmp_path / "bad"
    assert main(["refine", str(src), "--out", str(bad), "--resolution-mm", "200"]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "too coarse" in err[0] and not bad.exists()
    out = tmp_path / "refined"
    code = main(["refine", "-q", str(src), "--out", str(out), "--resolution-mm", "40", "--max-iter", "3"])
    assert code in (0, 3)
    doc = json.loads((out / "design.json").read_text())
    assert doc["refine"]["iterations"] == 3 and doc["refine"]["converged"] is (code == 0)
    assert doc["refine"]["alpha"] == 1e-3                   # refine's default
    assert doc["refine"]["deviation_after"]["rms_mm"] < doc["refine"]["deviation_before"]["rms_mm"]
    assert (out / "cutting_list.csv").is_file()
    # 'airmat inflate' on the folder (the re-parametrized Ŝ read back from approx_surface.ply) keeps the promise
    assert doc["refine"]["reparametrization"]["moved_rms_mm"] > 0
    assert "surface points moved" in capsys.readouterr().out
    assert main(["inflate", "-q", str(out), "--out", str(tmp_path / "inf"), "--resolution-mm", "40",
                 "--no-envelope"]) == 0
    inf = json.loads((tmp_path / "inf" / "inflate.json").read_text())
    assert inf["deviation"]["rms_mm"] == pytest.approx(doc["refine"]["deviation_after"]["rms_mm"], abs=0.011)
    # --single-level: every iteration at the target resolution (no coarse mesh in the block)
    one = tmp_path / "one"
    code = main(["refine", "-q", str(src), "--out", str(one), "--resolution-mm", "20", "--max-iter", "2",
                 "--single-level", "--regularization", "0.05"])
    assert code in (0, 3)
    block = json.loads((one / "design.json").read_text())["refine"]
    assert block["coarse_resolution_mm"] is None and block["alpha"] == 0.05


@pytest.mark.parametrize("argv, words", [
    (["--defect-corrections", "-1"], "--defect-corrections must be >= 0, got -1"),
    (["--defect-corrections", "1", "--single-level"], "--single-level has none"),
    (["--regularization", "0"], "--regularization must be a positive number, got 0.0"),
    (["--regularization", "nan"], "--regularization must be a positive number, got nan"),
    (["--regularization=-1e-3"], "--regularization must be a positive number, got -0.001"),
    (["--reparametrize", "-1"], "--reparametrize must be >= 0, got -1"),
])
def test_cli_refine_bad_corrections_exit_2_and_write_nothing(case, tmp_path, capsys, argv, words):
    src = tmp_path / "design"
    write_design(case, src)
    out = tmp_path / "out"
    assert main(["refine", str(src), "--out", str(out)] + argv) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and words in err[0] and not out.exists()


def test_cli_design_refine_bad_corrections_exit_2_and_write_nothing(tmp_path, capsys):
    out = tmp_path / "d"
    code = main(["design", "-q", "--preset", "vault1", "--refine", "--refine-defect-corrections", "-2",
                 "--out", str(out)])
    assert code == 2 and not out.exists()
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "--refine-defect-corrections must be >= 0" in err[0]
    code = main(["design", "-q", "--preset", "vault1", "--refine", "--refine-regularization", "inf",
                 "--out", str(out)])
    assert code == 2 and not out.exists()
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "--refine-regularization must be a positive number, got inf" in err[0]
    code = main(["design", "-q", "--preset", "vault1", "--refine", "--refine-reparametrize", "-1",
                 "--out", str(out)])
    assert code == 2 and not out.exists()
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "--refine-reparametrize must be >= 0, got -1" in err[0]


def test_a_defect_correction_makes_the_coarse_face_fit_the_fine_one(case):
    # after a correction at lengths l, the coarse face fit at its equilibrium is the fine face's at l
    from check.trial_equilibrium import coarse_start, correct
    from check.inflation_check import named_face
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


def test_cli_design_refine_too_coarse_exits_2_and_writes_nothing(tmp_path, capsys):
    out = tmp_path / "d"
    code = main(["design", "-q", "--preset", "vault1", "--refine", "--refine-resolution-mm", "500", "--out", str(out)])
    assert code == 2 and not out.exists()
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "too coarse" in err[0]


def test_two_level_refinement_iterates_on_the_coarse_mesh_and_the_check_reproduces_it(case):
    # at 20 mm the Gauss–Newton iterations run on the 40 mm mesh, its face corrected by the difference of
    # the two meshes' faces at the open-loop lengths; the verification is a fresh inflation at 20 mm
    r = refine(case, resolution=0.02, max_iter=6)
    assert r.coarse_resolution == pytest.approx(0.04) and r.design.refine["coarse_resolution_mm"] == 40.0
    assert r.deviation_after.rms < 0.6 * r.deviation_before.rms
    assert np.linalg.norm(r.l_simulated - TRUE_SIM) < 0.75 * np.linalg.norm(OFF)
    c = check(r.design, resolution=0.02, envelope=False)
    assert c.runs["median"].deviation.rms == pytest.approx(r.deviation_after.rms, rel=1e-9)
    # the same input gives the same lengths (no random step)
    again = refine(case, resolution=0.02, max_iter=6)
    np.testing.assert_array_equal(again.l_simulated, r.l_simulated)


def test_the_reduced_damped_step_is_the_tall_problems_step():
    # the k × k reduction (Cholesky of the Gram matrix) gives the bounded Levenberg–Marquardt step of the
    # (3N + k) × k problem, and the same residual for every step
    from scipy.optimize import lsq_linear

    from check.damped_step import damped_step, reduce_least_squares
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

    from check.damped_step import damped_step, reduce_least_squares
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
    from check.trial_equilibrium import coarse_start
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


def test_dropping_strings_recomputes_the_coverage(tmp_path):
    """A refined pattern that lost strings reports its own coverage (in memory), or says it is not known
    (a design read from its folder keeps no curvature field)."""
    from check.refined_design import refined_design
    from design.pipeline import DesignParams, design
    from design.presets import preset

    target, mattress = preset("vault1")
    d = design(target, mattress, params=DesignParams(spacing=0.04), progress=False)
    strings = d.pattern.strings
    fam = np.array([s.dash.family for s in strings])
    line = np.array([s.dash.line for s in strings])
    # drop every k1 string of the three middle lines: a band with no k1 string
    k1_lines = np.unique(line[fam == "k1"])
    mid = k1_lines[len(k1_lines) // 2 - 1: len(k1_lines) // 2 + 2]
    dropped = (fam == "k1") & np.isin(line, mid)
    assert dropped.any()
    l_real = np.array([s.l_median for s in strings])
    r = refined_design(d, l_real, dropped, np.zeros(len(strings), bool))
    before, after = d.pattern.coverage["k1"], r.pattern.coverage["k1"]
    # the dropped dashes leave a band the design traced but no longer strings (a weak band; measured
    # 57.8 -> 114.5 mm against the 80 mm limit, gap p95 89.9 -> 124.4 mm)
    assert after["gap_p95_mm"] > before["gap_p95_mm"] and after["gap_max_mm"] >= before["gap_max_mm"]
    assert after["weak_band_max_mm"] > after["limit_mm"] >= before["weak_band_max_mm"]
    assert r.pattern.coverage["k2"] == d.pattern.coverage["k2"]      # k2 strings untouched
    assert any(n.startswith("after the refinement:") for n in r.pattern.notes)
    # from the folder: not known, and said
    write_design(d, tmp_path / "d")
    back = read_design(tmp_path / "d")
    rb = refined_design(back, l_real, dropped, np.zeros(len(strings), bool))
    assert rb.pattern.coverage is None and any("coverage of the refined pattern is not known" in n
                                               for n in rb.pattern.notes)
    write_design(rb, tmp_path / "rb")                                 # a null coverage is a valid file
    assert read_design(tmp_path / "rb").pattern.coverage is None


def test_the_refinement_shows_its_iterations_on_a_progress_bar(case, capsys):
    # a bar over the Gauss–Newton iterations with the current RMS, when progress bars are on (a terminal)
    from airmat.progress import set_progress
    set_progress(True)
    try:
        r = refine(case, resolution=0.04, max_iter=2)
    finally:
        set_progress(None)
    err = capsys.readouterr().err
    assert "refine on the 40 mm mesh" in err and f"{r.iterations}/2" in err and "RMS" in err


def test_a_refinement_out_of_iterations_counts_them_all(case):
    # two coarse iterations and one at the resolution: the message counts the three, not the last stage's one
    r = refine(case, resolution=0.02, max_iter=3, fine_iter=1)
    assert r.iterations == 3 and not r.converged
    assert r.message == "not converged after 3 iterations"
