"""Refine a design's string lengths through the equilibrium, so that the inflated named face lands on Ŝ.

The open-loop lengths come from Equation 3 and the curvature under each
dash alone; neighbouring strings interact, so :func:`refine` adjusts all the
simulated rest lengths l* together. Objective: the mean squared distance of
the named face (the check's face, :func:`airmat.check.inflation_check.named_face`)
from Ŝ after rigid alignment (:mod:`airmat.check.refine_objective`) plus a mild
Tikhonov term ``alpha · mean((l* - l*_open)²)``: strings that barely move the
named face (slack ones, or ones whose effect other strings can replace) stay
at their open-loop length instead of drifting, and the Gauss–Newton matrix
stays regular. ``alpha = 1e-3`` (the default) costs a 32 mm change of every
string as much as 1 mm of RMS deviation (refined strings change by tens of
mm: −45 to +12 mm on the saddle). Measured at 20 mm (``docs/benchmarks.md``,
``bench/bench_refine.py --alpha``, with the re-parametrization round): the
saddle 0.87 % of the diagonal (as at 3e-4 and 1e-4; 0.89 % at 3e-3 and 1e-2),
vault1 0.62 % (0.60 % at 3e-4, 0.70–0.72 % at the others).

Method: bounded Gauss–Newton with a Levenberg–Marquardt trust region
(:mod:`airmat.check.gauss_newton`; the trial solves in :mod:`airmat.check.trial_equilibrium`). The
Jacobian of the face is ``P dx/dl*`` with ``dx/dl* = -H⁻¹ ∂g/∂l*``
(:mod:`airmat.check.adjoint`: one factorization of the Newton Hessian at each
accepted equilibrium, one back-substitution per string); each trial step's
equilibrium starts from the last one moved by the first-order predictor
(a few Newton steps, never from the flat mattress; a trial that fails
leaves the Newton shift where the last equilibrium had it). The damped
subproblems of an iteration are solved on the k × k Cholesky factor of the
stacked Jacobian's Gram matrix (:mod:`airmat.check.damped_step`: the same steps as
on the tall matrix, in a fraction of the time on the large mattress), and a
trial's model rebuilds only the strings' term
(:func:`airmat.inflation.model.with_strings`). Bounds: from the
shortest a tie allows (real l = 0, through the length map) to the string's
flat span (no bend). A step is taken only when it realizes more than a
quarter of the decrease its model predicted (ρ > 0.25,
:data:`airmat.check.gauss_newton.ACCEPT`); the damping shrinks only after an
iteration whose first trial was taken. Stopping rule: over an accepted step, a
decrease of the RMS below ``rms_tol`` or a relative decrease of the objective
below ``ftol``; or a step shorter than ``xtol`` × the mean span.

Two levels: a trial equilibrium costs tens of Newton iterations (the
wrinkles rearrange), and at 20 mm that made the refinement 13 inflations
long. So the iterations run on the mesh twice as coarse (a Newton
iteration there is about 6x cheaper), whose face is corrected by the
difference of the two meshes' faces at the open-loop lengths (so that the
coarse objective starts where the fine one is); ``coarsest=0`` runs them
all at the target resolution. The coarse open-loop equilibrium is the first
inflation's own level on that mesh (its continuation passes through it)
carried on to the full tolerance, not a second inflation. That correction
is exact only at the open-loop lengths; ``corrections=n`` re-takes it (a
defect correction) up to n times where the coarse iterations stop early: the
fine mesh is solved at their lengths, from the prolonged coarse equilibrium,
the coarse face is re-corrected there, and the iterations go on. When the
two-level iterations ran without corrections and their lengths inflate
farther from Ŝ than the given ones on the fine mesh (the coarse face misled
them: the symmetric saddle, whose fine mesh wrinkles where the coarse one
does not), the refinement runs again with FALLBACK_CORRECTIONS, then, if
that fails too, with every iteration on the target mesh.

Ŝ re-parametrized (:mod:`airmat.check.reparametrize`): the deviation compares
points through Ω, and Ŝ's points sit where the designer's model of the
named face's metric put them, which the mattress does not follow exactly, so
part of the deviation is a slide along Ŝ (the refined saddle: 13.8 mm RMS
point to point, 9.8 mm to Ŝ's nearest points). After the first stage of
iterations, ``reparametrize`` rounds (default 1) move Ŝ's points along Ŝ's
own surface into the metric the current face realizes, and the iterations
go on against that Ŝ; ``max_iter`` is split evenly between the stages. The
refined design carries that Ŝ (``approx_surface.ply``; its shape is the
designed one: 0.05–0.12 mm RMS off it on the constructible presets), which the check of the
refined design then compares with. ``deviation_before`` stays the open-loop
deviation from the designed Ŝ (the refine block also gives the open loop
against the re-parametrized one). Measured at 20 mm (``docs/benchmarks.md``,
``bench/bench_refine.py --reparametrize 0 1``).

The refined lengths are checked by the check's own inflation of a refined
design (:func:`airmat.check.inflation_check.check`): the open-loop equilibrium (the
first inflation, from the flat mattress) carried on to the refined lengths at
the target resolution (:func:`~airmat.inflation.simulate.inflate_from`), the path
every trial equilibrium took. It gives ``deviation_after``; if that is worse
than the open-loop deviation the open-loop lengths are kept
(``converged=False``). A design refined again starts from its first open loop
(``design.open_loop``), as its check does.

Stages: :func:`~airmat.check.refine_setup.set_up_problem` (the open-loop inflation, the trial equilibria, the
bounds; :mod:`airmat.check.refine_setup`),
:func:`run_iterations` (the Gauss–Newton runs, :class:`~airmat.check.gauss_newton.GaussNewtonResult`
each, on one or two levels, with :func:`reparametrize_rounds`) and :func:`verify` (the verification
inflation and the :class:`Refinement`); :func:`refine` chains them, tuned by a :class:`RefineOptions`.
SI units inside; the ``refine`` block of design.json is in mm.
"""

from __future__ import annotations

import dataclasses
import logging
import time
from dataclasses import dataclass

import numpy as np

from airmat.check.compare import deviation
from airmat.check.gauss_newton import GaussNewtonResult, gauss_newton
from airmat.check.inflation_check import KnownRun, design_strings
from airmat.check.length_map import length_map
from airmat.check.refine_objective import face_fit
from airmat.check.refine_setup import (RefineProblem, check_refinable, coarse_resolution, length_bounds,
                                       set_up_problem, solver_options)
from airmat.check.refined_design import REFINE_FLAG, refined_design
from airmat.check.reparametrize import reparametrize as reparametrize_approx
from airmat.check.trial_equilibrium import SOLVE_NEWTON, TrialProblem, coarse_start, correct, make_problem
from airmat.inflation.mesh import build_mattress_mesh
from airmat.inflation.prolong import prolong
from airmat.inflation.simulate import inflate_from
from airmat.check.refinement_result import Refinement, RefineOptions

__all__ = ["refine", "check_refinable", "length_bounds", "refined_design", "REFINE_FLAG"]

log = logging.getLogger(__name__)

#: iterations of a round's relaxation: the slide along Ŝ is done in ~50 (on the saddle 8.33 of the
#: 8.54 mm a converged relaxation moves); what follows drifts off the surface (A1 against A2)
REPARAM_RELAX_ITER = 50


@dataclass(frozen=True)
class Iterations:
    """What the Gauss–Newton stages of :func:`refine` reached (:func:`run_iterations`).

    Attributes
    ----------
    result : airmat.check.gauss_newton.GaussNewtonResult
        The last stage's outcome, its ``iterations`` counted over every stage and its
        ``objective_before`` the target mesh's at the given lengths (m²).
    reparametrizations : tuple of airmat.check.reparametrize.Reparametrization
        Ŝ of each re-parametrization round, in order.
    coarse_resolution : float or None
        Mesh of the iterations (m); None: all at the target resolution.
    corrections : tuple of float
        The RMS distance (m) of the fine face from Ŝ at each defect correction's coarse optimum.
    """

    result: GaussNewtonResult
    reparametrizations: tuple = ()
    coarse_resolution: float | None = None
    corrections: tuple = ()


def _go_on(problem: TrialProblem, previous: GaussNewtonResult, xyz, setup: RefineProblem, max_iter: int,
           solver: dict) -> GaussNewtonResult:
    """More iterations on ``problem`` from ``previous``'s lengths and damping and the equilibrium ``xyz``;
    the iterations counted over both."""
    more = gauss_newton(problem, previous.lengths, setup.l_start, xyz, setup.lower, setup.upper,
                        max_iter=max_iter, lam0=previous.damping, **solver)
    return dataclasses.replace(more, iterations=more.iterations + previous.iterations)


def reparametrize_rounds(problem: TrialProblem, result: GaussNewtonResult, setup: RefineProblem, rounds: int,
                         total: int, solver: dict) -> tuple:
    """Ŝ re-parametrized in the metric of ``problem``'s face at ``result``'s optimum, then more iterations;
    ``rounds`` times.

    Parameters
    ----------
    problem : airmat.check.trial_equilibrium.TrialProblem
        The mesh the iterations run on; its ``approx_xyz`` takes each new Ŝ (m).
    result : airmat.check.gauss_newton.GaussNewtonResult
        Where the stage before stopped.
    setup : RefineProblem
    rounds : int
        Rounds to make (0: none).
    total : int
        Iterations of the first stage and the rounds together: each round gets an even
        share of what is left (so what an earlier stage did not use is not lost).
    solver : dict
        The keywords of the stopping rule (:func:`_solver_options`).

    Returns
    -------
    result : airmat.check.gauss_newton.GaussNewtonResult
        The last stage's (iterations counted over all).
    reparametrizations : list of airmat.check.reparametrize.Reparametrization
        Each round's Ŝ.
    """
    reparametrizations = []
    if rounds <= 0:
        return result, reparametrizations
    from airmat.design.closest_point import MeshProjector

    approx = setup.design.approx
    projector = MeshProjector(approx.xyz, approx.faces)
    for done in range(rounds):
        share = (total - result.iterations) // (rounds - done)
        face = problem.p @ result.xyz + (0.0 if problem.offset is None else problem.offset)
        rep = reparametrize_approx(approx.xyz, approx.uv, approx.faces, face, start=problem.approx_xyz,
                                   projector=projector, max_iter=REPARAM_RELAX_ITER)
        reparametrizations.append(rep)
        problem.approx_xyz = rep.xyz
        log.debug("Ŝ re-parametrized in the realized metric: moved %.1f mm RMS (%s), %.2f mm RMS off its surface",
                  rep.moved_rms * 1e3, "converged" if rep.converged else "not converged", rep.off_rms * 1e3)
        if share > 0:
            result = _go_on(problem, result, result.xyz, setup, share, solver)
    return result, reparametrizations


def _two_level(setup: RefineProblem, options: RefineOptions, coarse: float, first_stage: int, budget: int,
               solver: dict) -> Iterations:
    """The iterations on the mesh of edge ``coarse`` (m), its face corrected by the difference of the two
    meshes' faces at the given lengths; defect corrections, the rounds, then ``options.fine_iter`` here."""
    fine, mesh = setup.problem, setup.mesh
    coarse_mesh = build_mattress_mesh(mesh.width, mesh.height, mesh.thickness, resolution=coarse)
    problem = make_problem(coarse_mesh, setup.strings, options.params, setup.design, setup.surface, options.tol)
    coarse_start_eq = coarse_start(problem, setup.flat_inflation, setup.strings, options.params, options.tol)
    problem.offset = fine.p @ setup.start.xyz - problem.p @ coarse_start_eq.xyz   # the face here minus the coarse one
    problem.tol = options.trial_tol
    result = gauss_newton(problem, setup.l_start, setup.l_start, coarse_start_eq.xyz, setup.lower, setup.upper,
                          max_iter=first_stage, **solver)
    fine_rms = []
    for _ in range(options.corrections):
        if result.iterations >= first_stage:
            break
        fine_eq = correct(fine, problem, result.lengths, result.xyz, options.trial_tol)
        if fine_eq is None:
            break
        fine_rms.append(float(np.sqrt(face_fit(fine.p, fine_eq.xyz, fine.approx_xyz).objective)))
        log.debug("defect correction: the fine face %.2f mm RMS at the coarse optimum (%d Newton iterations)",
                  fine_rms[-1] * 1e3, fine_eq.n_iter)
        result = _go_on(problem, result, result.xyz, setup, first_stage - result.iterations, solver)
    result, reparametrizations = reparametrize_rounds(problem, result, setup, options.reparametrize, budget, solver)
    fine.approx_xyz = problem.approx_xyz
    fine_start = (fine.equilibrium(result.lengths, prolong(coarse_mesh, result.xyz, mesh), SOLVE_NEWTON)
                  if options.fine_iter else None)
    log.debug("refinement: %d iterations on the %.0f mm mesh (%s), then here", result.iterations,
              coarse * 1e3, result.message)
    if fine_start is not None:
        result = _go_on(fine, result, fine_start.xyz, setup, options.fine_iter, solver)
    return Iterations(result=result, reparametrizations=tuple(reparametrizations), coarse_resolution=coarse,
                      corrections=tuple(fine_rms))


def run_iterations(setup: RefineProblem, options: RefineOptions) -> Iterations:
    """The Gauss–Newton stages: the first one, the defect corrections and the re-parametrization rounds.

    On the mesh twice as coarse when :func:`coarse_resolution` allows it (``options.coarsest > 0``),
    else at the target resolution. ``options.max_iter`` (less ``options.fine_iter`` on two levels) is
    split evenly between the first stage and the rounds; the first stage gets the remainder.

    Parameters
    ----------
    setup : RefineProblem
    options : RefineOptions

    Returns
    -------
    Iterations
    """
    solver = solver_options(setup, options)
    coarse = (coarse_resolution(options.resolution, setup.upper, options.coarsest)
              if options.coarsest > 0 else None)
    fine = setup.problem
    objective_before = face_fit(fine.p, setup.start.xyz, fine.approx_xyz).objective
    budget = options.max_iter - (options.fine_iter if coarse is not None else 0)
    first_stage = budget - options.reparametrize * (budget // (options.reparametrize + 1))
    if coarse is None:
        result = gauss_newton(fine, setup.l_start, setup.l_start, setup.start.xyz, setup.lower, setup.upper,
                              max_iter=first_stage, **solver)
        result, reparametrizations = reparametrize_rounds(fine, result, setup, options.reparametrize, budget,
                                                          solver)
        done = Iterations(result=result, reparametrizations=tuple(reparametrizations))
    else:
        done = _two_level(setup, options, coarse, first_stage, budget, solver)
    return dataclasses.replace(done, result=dataclasses.replace(done.result, objective_before=objective_before))


def verify(setup: RefineProblem, iterations: Iterations, options: RefineOptions, started: float) -> Refinement:
    """Inflate the refined lengths as the check does and assemble the :class:`Refinement`.

    The verification is the open-loop equilibrium carried on to the refined lengths at the target
    resolution (the check's path of a refined design). When it does not converge or lands farther
    from Ŝ than the given lengths did, those are kept (``converged=False``).

    Parameters
    ----------
    setup : RefineProblem
    iterations : Iterations
    options : RefineOptions
    started : float
        ``time.perf_counter()`` when the refinement began (s).

    Returns
    -------
    Refinement
    """
    design, result = setup.design, iterations.result
    reps = iterations.reparametrizations
    approx_xyz = design.approx.xyz if not reps else reps[-1].xyz
    l_best, converged, message = result.lengths, result.converged, result.message
    if result.exhausted:        # counted over every stage (coarse, corrected, fine), not the last one's share
        message = f"not converged after {result.iterations} iterations"
    span_tol = 1e-4 * setup.upper
    dropped = l_best >= setup.upper - span_tol
    flagged = l_best <= setup.lower + span_tol
    lengths = length_map(design.calibration)
    refined = refined_design(design, lengths.to_real(l_best), dropped, flagged)
    if reps:
        refined = dataclasses.replace(refined, approx=dataclasses.replace(refined.approx, xyz=approx_xyz))
    verify_started = time.perf_counter()
    refined_strings = design_strings(refined, "median")
    # the check's path of a refined design (airmat.check.inflation_check): from the open-loop equilibrium on
    final = inflate_from(setup.flat_inflation, refined_strings if len(refined_strings) else None,
                         params=options.params, tol=options.tol)
    verification_seconds = time.perf_counter() - verify_started
    deviation_before, surface = setup.deviation_before, setup.surface
    deviation_after = deviation(final, approx_xyz, design.approx.uv, surface)
    deviation_before_reparametrized = deviation(setup.start, approx_xyz, design.approx.uv, surface) if reps else None
    known = KnownRun(refined_strings, final, options.params, options.tol, start=setup.flat_strings)
    # the design the user gets is never reported worse than the open-loop one (each against its own Ŝ)
    if not final.converged or deviation_after.rms > deviation_before.rms:
        given = setup.lengths_before
        message = (f"the refined lengths inflate to {deviation_after.rms * 1e3:.1f} mm RMS, not better than the "
                   f"{given} {deviation_before.rms * 1e3:.1f} mm: the {given} lengths are kept")
        converged, l_best, deviation_after = False, setup.l_start, deviation_before
        dropped, flagged = np.zeros(len(l_best), bool), np.zeros(len(l_best), bool)
        refined = dataclasses.replace(design)
        known = KnownRun(setup.strings, setup.start, options.params, options.tol, start=setup.open_loop)
        reps, deviation_before_reparametrized = (), None
    ids = setup.strings.ids
    return Refinement(design=refined, converged=converged, iterations=result.iterations,
                      seconds=time.perf_counter() - started, message=message,
                      objective_before=result.objective_before, objective_after=result.objective_after,
                      deviation_before=deviation_before, deviation_after=deviation_after,
                      l_real=lengths.to_real(l_best), l_simulated=l_best,
                      dropped=tuple(ids[i] for i in np.flatnonzero(dropped)),
                      flagged=tuple(ids[i] for i in np.flatnonzero(flagged)),
                      inflation_seconds=setup.inflation_seconds, verification_seconds=verification_seconds,
                      resolution=options.resolution, surface=surface,
                      coarse_resolution=iterations.coarse_resolution, corrections=iterations.corrections,
                      alpha=float(options.alpha), verification=known,
                      open_loop_run=KnownRun(setup.flat_strings, setup.flat_inflation, options.params, options.tol),
                      reparametrization=reps[-1] if reps else None,
                      deviation_before_reparametrized=deviation_before_reparametrized,
                      reparametrize_rounds=len(reps), lengths_before=setup.lengths_before)


#: defect corrections of the second try when the coarse mesh's optimum inflates worse than the given lengths
FALLBACK_CORRECTIONS = 2


def _kept_the_given_lengths(refinement: Refinement) -> bool:
    """The refined lengths, inflated on the target mesh, landed farther from Ŝ than the given ones (or did not
    converge), so :func:`verify` kept the given ones."""
    return refinement.deviation_after is refinement.deviation_before and not refinement.converged


def refine(design, options: RefineOptions | None = None, **overrides) -> Refinement:
    """Adjust the strings' lengths so that the inflated named face lands on Ŝ (see the module docstring).

    Parameters
    ----------
    design : airmat.design.pipeline.DesignResult
    options : RefineOptions, optional
        The tuning; None: the defaults.
    **overrides
        Fields of :class:`RefineOptions` set on top of ``options``, by keyword
        (``resolution=0.02, max_iter=6``, ...; SI units).

    Returns
    -------
    Refinement

    Raises
    ------
    airmat.errors.InputError
        A design without strings, a resolution too coarse for them, or a calibration
        without posterior samples (the tolerance of a refined length comes from them).
    TypeError
        A keyword that is no field of :class:`RefineOptions`.
    """
    started = time.perf_counter()
    options = dataclasses.replace(options if options is not None else RefineOptions(), **overrides)
    setup = set_up_problem(design, options)
    iterations = run_iterations(setup, options)
    refinement = verify(setup, iterations, options, started)
    if iterations.coarse_resolution is not None and options.corrections == 0:
        for how, retry in ((f"{FALLBACK_CORRECTIONS} defect corrections",
                            dataclasses.replace(options, corrections=FALLBACK_CORRECTIONS)),
                           ("every iteration on the target mesh", dataclasses.replace(options, coarsest=0.0))):
            if not _kept_the_given_lengths(refinement):
                break
            log.info("refinement: %s; again with %s", refinement.message, how)
            # the stages move the trial problem's Ŝ (re-parametrized) and face offset: start again from a fresh one
            fresh = dataclasses.replace(setup, problem=make_problem(setup.mesh, setup.strings, retry.params, design,
                                                                    setup.surface, retry.tol))
            refinement = verify(fresh, run_iterations(fresh, retry), retry, started)
    log.info("refinement: %s in %d iterations, %.1f s (one inflation %.1f s); %s face RMS %.2f -> %.2f mm",
             "converged" if refinement.converged else "not converged", refinement.iterations, refinement.seconds,
             refinement.inflation_seconds, refinement.surface, refinement.deviation_before.rms * 1e3,
             refinement.deviation_after.rms * 1e3)
    return dataclasses.replace(refinement, design=dataclasses.replace(refinement.design, refine=refinement.block()))
