"""The equilibria of the refinement: what the trial solves on one mesh share, and the coarse level's start and correction.

A :class:`TrialProblem` holds one mesh's pins, sparse assembler, Newton linear
system (its symbolic factorization reused by every trial) and the operator
that reads the named face at Ŝ's points. It solves trial equilibria at other
string rest lengths from a given start (a failed trial leaves the Newton shift
where it was) and gives the adjoint Jacobian of the face with respect to the
rest lengths (:mod:`airmat.check.adjoint`). :func:`coarse_start` and :func:`correct`
are the two-level scheme's coarse open-loop equilibrium and its defect
correction. SI units (m).
"""

from __future__ import annotations

import dataclasses
import logging
from dataclasses import dataclass

import numpy as np

from airmat.errors import AirmatError
from airmat.check.adjoint import equilibrium_jacobian, factor_equilibrium, rest_derivative
from airmat.check.refine_objective import face_fit, face_operator
from airmat.inflation.assembly import build_assembler
from airmat.inflation.energy import block_pattern
from airmat.inflation.model import Parameters, build_model, with_strings
from airmat.inflation.prolong import prolong
from airmat.inflation.simulate import inflate
from airmat.inflation.solver import NewtonSystem, rigid_pins, solve

__all__ = ["TrialProblem", "make_problem", "coarse_start", "correct", "TRIAL_NEWTON", "SOLVE_NEWTON"]

log = logging.getLogger(__name__)

#: Newton iterations a trial equilibrium of a Gauss–Newton step may take before the step counts as
#: failed (the damping then rises and the step shrinks). A trial that needs more has crossed a change
#: of the wrinkles, where the linear model does not hold. Measured at 20 mm (docs/decisions.md, Refinement), 20
#: against 50: vault1 0.78 -> 0.72 % of the diagonal and 5.9x -> 4.7x one inflation, the saddle,
#: vault2 and the roof the same numbers, the dome 3.25 -> 3.62 % (2.9x instead of 4.2x). Against 12 and 15
#: (``bench/bench_refine.py --draws 4 --trial-newton 12 15 20``): vault1 0.70 -> 0.91 % and the dome
#: 3.15 -> 3.88 % for ratios of 4.0-4.4x instead of 4.6-5.2x (vault1), the saddle 0.82 -> 0.79 % at 15.
TRIAL_NEWTON = 20

#: Newton iterations of the equilibria that are not trials of a step (the coarse start, a defect correction)
SOLVE_NEWTON = 50

#: what the Newton method of the refinement's equilibria does with a step that does not lower U_B, and by
#: how much it raises its shift (:func:`airmat.inflation.solver.solve`: ``refused_step``, ``mu_up``); the
#: check's inflations (and so the verification) use the solver's own rule (halve the step, shift x2), which
#: reaches the same equilibria from the flat mattress. Measured (docs/benchmarks.md,
#: ``bench/bench_refine.py --draws 8 --trial-rule shift:4 backtrack:2``): halving with the shift x2
#: took vault1 from 4.5-5.9x one inflation to 3.8-5.5x but from 0.70 % of the diagonal (median of 8
#: draws) to 0.78 %, the saddle, vault2 and the roof the same deviations, the roof still at 4.9x. So the
#: trials refactorize with the shift x4.
TRIAL_REFUSED_STEP = ("shift", 4.0)


@dataclass
class TrialProblem:
    """What every trial equilibrium shares: mesh, pins, assembler, linear solver, face operator."""

    mesh: object
    strings: object
    params: Parameters
    fixed: np.ndarray
    asm: object
    system: NewtonSystem
    p: object
    approx_xyz: np.ndarray
    tol: float
    max_newton: int
    base: object
    offset: np.ndarray | None = None

    @property
    def mesh_label(self) -> str:
        return f"the {1e3 * float(np.max(self.mesh.spacing)):.0f} mm mesh"

    def fit(self, x):
        """The face fit of positions ``x`` (with the coarse-mesh correction, if any)."""
        return face_fit(self.p, x, self.approx_xyz, self.offset)

    def model(self, rest):
        return with_strings(self.base, self.mesh, dataclasses.replace(self.strings, rest=rest), self.params)

    def equilibrium(self, rest, x0, max_newton: int | None = None):
        """Solve from ``x0`` on the final mesh, in at most ``max_newton`` Newton iterations (default:
        the problem's ``max_newton``); None when it does not converge."""
        hint = self.system.hint_rel
        try:
            rule, up = TRIAL_REFUSED_STEP
            r = solve(self.model(rest), x0, fixed_dofs=self.fixed, tol=self.tol,
                      max_iter=self.max_newton if max_newton is None else max_newton,
                      max_move=0.5 * float(np.mean(self.mesh.spacing)), assembler=self.asm,
                      linear_system=self.system, desc="trial equilibrium", refused_step=rule, mu_up=up,
                      warn=False)     # a trial without an equilibrium is an answer (the step shrinks), not a fault
        except AirmatError:
            r = None
        log.debug("trial equilibrium: %s", "failed" if r is None else f"{r.n_iter} Newton iterations, {r.message}")
        if r is None or not r.converged:
            self.system.hint_rel = hint      # a failed trial's large shifts must not slow the next one
            return None
        return r

    def jacobian(self, rest, x):
        """The (3N, k) Jacobian of the face fit's residual with respect to l*, and dx/dl* (3n, k)."""
        model = self.model(rest)
        fac = factor_equilibrium(model, x, self.asm, self.system.chol)
        dx = equilibrium_jacobian(fac, rest_derivative(model.springs[-1], x, self.mesh.thickness))
        n, k = len(x), len(rest)
        face = (self.p @ dx.reshape(n, 3 * k)).reshape(-1, 3, k)
        return face.reshape(-1, k) / np.sqrt(self.p.shape[0]), dx


def make_problem(mesh, strings, params, design, named, tol) -> TrialProblem:
    """The shared state of the trial equilibria on ``mesh``: pins, assembler, the strings' model, Ŝ's face operator."""
    fixed = rigid_pins(mesh.uv, mesh.top)
    model0 = build_model(mesh, strings, params)
    asm = build_assembler(block_pattern(model0), model0.n_vertices, fixed)
    return TrialProblem(mesh, strings, params, fixed, asm, NewtonSystem(groups=asm.free // 3),
                    face_operator(mesh, design.approx.uv, named), design.approx.xyz, tol, TRIAL_NEWTON, model0)


def coarse_start(cprob: TrialProblem, first, strings, params, tol):
    """The open-loop equilibrium on ``cprob``'s mesh: the first inflation's level on that mesh (solved
    there to the continuation's looser tolerance) carried on to ``tol``; a fresh inflation when it has none."""
    h = float(np.max(cprob.mesh.spacing))
    for m, x in first.levels:
        if m.n_vertices == cprob.mesh.n_vertices and np.isclose(float(np.max(m.spacing)), h):
            eq = cprob.equilibrium(strings.rest, x, SOLVE_NEWTON)
            if eq is not None:
                return eq
    return inflate(cprob.mesh, strings, params=params, tol=tol)


def correct(prob: TrialProblem, cprob: TrialProblem, l, x_coarse, trial_tol: float):
    """Defect correction: the equilibrium on ``prob``'s (fine) mesh at lengths ``l``, from the prolonged coarse
    one, and ``cprob.offset`` reset so that the coarse face fit at ``x_coarse`` is the fine one's there.
    None (offset unchanged) when the fine solve does not converge."""
    tol, prob.tol = prob.tol, trial_tol
    try:
        eq = prob.equilibrium(l, prolong(cprob.mesh, x_coarse, prob.mesh), SOLVE_NEWTON)
    finally:
        prob.tol = tol
    if eq is not None:
        cprob.offset = prob.p @ eq.xyz - cprob.p @ x_coarse
    return eq
