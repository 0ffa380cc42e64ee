"""The refinement's Gauss–Newton loop: bounded Levenberg–Marquardt over the strings' simulated lengths.

Each iteration linearizes the face fit with the adjoint Jacobian, reduces the
least squares to k × k (:mod:`airmat.check.damped_step`) and tries damped, bounded
steps, each judged by a trial equilibrium started from the first-order
predictor, until one realizes more than ``ACCEPT`` (a quarter) of the decrease
its model predicted. The damping shrinks (÷ ``LAM_DOWN``) after a step its model
predicted well (ρ > 0.75), but not in an iteration that had to grow it first: the next
iteration then starts from the damping that worked (the usual Levenberg–Marquardt
memory; shrunk at once, its first trials kept failing again, each a trial equilibrium
run to its Newton budget). Stopping rule: over an accepted step, a decrease of the
RMS below ``rms_tol`` or a relative decrease of the objective below ``ftol``;
or a step shorter than ``xtol``. SI units (m). The outcome is a
:class:`GaussNewtonResult`.
"""

from __future__ import annotations

import logging
from dataclasses import dataclass

import numpy as np

from airmat.progress import progress
from airmat.check.damped_step import damped_step, reduce_least_squares
from airmat.check.trial_equilibrium import TrialProblem
from airmat.summary import Summarized

__all__ = ["gauss_newton", "GaussNewtonResult", "LAM_DOWN", "ACCEPT", "HOLD_AFTER_RETRY"]

log = logging.getLogger(__name__)

#: the damping is divided by this after a step its model predicted well (rho > 0.75), when that step was
#: the iteration's first trial (after an iteration that had to grow the damping, it is held)
LAM_DOWN = 3.0

#: a step is taken when it realizes more than this share of the decrease its model predicted
#: (rho = actual / predicted; the usual trust-region threshold, 1/4); else the damping grows and a
#: shorter step is tried. With 1e-3 (any decrease) the saddle's first iteration took a 50 mm change
#: of its lengths that realized 1 % of the predicted decrease, and the refinement landed anywhere
#: from 0.89 to 1.26 % of the diagonal over lengths jittered by 5 µm; with 1/4, 0.87–0.88 %
#: (docs/decisions.md, Refinement; ``bench/bench_refine.py --draws``).
ACCEPT = 0.25

#: after an iteration that had to grow the damping (a trial refused or without an equilibrium), the
#: damping is not shrunk on its accepted step; False: shrunk whenever rho > 0.75.
#: Measured side by side (docs/decisions.md, Refinement; ``bench/bench_refine.py --damping-hold 0 1``): the dome 2.84 ->
#: 2.35 % of the diagonal, vault1 and the saddle within their draws' spread.
HOLD_AFTER_RETRY = True


@dataclass(frozen=True, repr=False)
class GaussNewtonResult(Summarized):
    """The outcome of :func:`gauss_newton`.

    Attributes
    ----------
    lengths : ndarray of shape (k,)
        The best simulated rest lengths l* found: those of the last accepted step (m).
    xyz : ndarray of shape (n, 3)
        The equilibrium at ``lengths``: the last accepted trial's (m).
    damping : float
        The Levenberg–Marquardt damping when the loop stopped (dimensionless); a run that goes
        on from here starts from it.
    converged : bool
        Stopped by the stopping rule (a small step, or a small decrease over an accepted step).
    message : str
        How the loop stopped.
    iterations : int
        Accepted steps (a caller that chains runs adds the earlier runs' count).
    exhausted : bool
        Stopped by ``max_iter`` (of this run) without converging.
    objective_before, objective_after : float
        The objective (m²: mean squared face fit plus the Tikhonov term) at the start
        lengths and at ``lengths``.
    """

    lengths: np.ndarray
    xyz: np.ndarray
    damping: float
    converged: bool
    message: str
    iterations: int
    exhausted: bool
    objective_before: float
    objective_after: float

    def _summary(self):
        return "GaussNewtonResult", [("converged", self.converged), ("iterations", self.iterations),
                                     ("objective", f"{self.objective_before:.4g} -> {self.objective_after:.4g} m²"),
                                     ("message", self.message)]


def gauss_newton(prob: TrialProblem, l0, l_reg, x0, lo, hi, *, alpha, max_iter, ftol, xtol, rms_tol,
                  lam0=1e-3) -> GaussNewtonResult:
    """Bounded Levenberg–Marquardt over l* from ``l0`` (regularized toward ``l_reg``); the best lengths and how it went.

    Parameters
    ----------
    prob : airmat.check.trial_equilibrium.TrialProblem
        Its face fit is the objective; its trial equilibria evaluate a step.
    l0, l_reg : ndarray of shape (k,)
        Start lengths and the lengths the Tikhonov term pulls toward (m).
    x0 : ndarray of shape (n, 3)
        The equilibrium at ``l0`` (m).
    lo, hi : ndarray of shape (k,)
        Bounds of the lengths (m).
    alpha : float
        Weight of the Tikhonov term (``alpha · mean((l - l_reg)²)``; dimensionless).
    max_iter : int
        Accepted steps at most.
    ftol, xtol, rms_tol : float
        Stopping rule (see :class:`airmat.check.refinement_result.RefineOptions`): relative decrease of
        the objective (dimensionless), step length (m), decrease of the RMS (m).
    lam0 : float
        Start damping (dimensionless).

    Returns
    -------
    GaussNewtonResult
    """
    k = len(l0)
    w = np.sqrt(alpha / k)

    def total(fit, l):
        return fit.objective + w * w * float(np.sum((l - l_reg) ** 2))

    l, x = np.array(l0, float), x0
    fit = prob.fit(x)
    f = f_start = total(fit, l)
    lam, it, converged, message = lam0, 0, False, f"not converged after {max_iter} iterations"
    with progress(total=max_iter, desc=f"refine on {prob.mesh_label}", unit="it") as bar:
        while it < max_iter:
            jac, dx = prob.jacobian(l, x)
            a = np.vstack([jac, w * np.eye(k)])
            r = np.concatenate([fit.residual, w * (l - l_reg)])
            scale = np.sqrt(np.maximum(np.sum(a * a, axis=0), 1e-30))
            reduced = reduce_least_squares(a, r)
            accepted, retried = False, False
            for _ in range(8):
                step = damped_step(*reduced, scale, lam, lo - l, hi - l)
                predicted = float(r @ r - np.sum((r + a @ step) ** 2))
                if np.max(np.abs(step)) < xtol or predicted <= 0:
                    converged, message = True, f"converged: step below {xtol * 1e3:.3g} mm"
                    break
                # first-order predictor: the equilibrium moves by dx/dl* step, then a few Newton steps
                eq = prob.equilibrium(l + step, x + (dx @ step).reshape(x.shape))
                log.debug("step of %.2f mm (max), predicted %.3g mm², lam %.2g: %s", 1e3 * np.max(np.abs(step)),
                          predicted * 1e6, lam, "no equilibrium" if eq is None else f"{eq.n_iter} Newton iterations")
                if eq is not None:
                    fit_new = prob.fit(eq.xyz)
                    f_new = total(fit_new, l + step)
                    rho = (f - f_new) / predicted
                    if rho > ACCEPT:
                        decrease, drms = (f - f_new) / f, np.sqrt(f) - np.sqrt(f_new)
                        l, x, fit, f, accepted = l + step, eq.xyz, fit_new, f_new, True
                        lam = lam / LAM_DOWN if rho > 0.75 and not (retried and HOLD_AFTER_RETRY) else lam
                        log.debug("refine iteration %d: objective %.4g mm², RMS %.2f mm, rho %.2f", it + 1,
                                  f * 1e6, np.sqrt(fit.objective) * 1e3, rho)
                        bar.update(1)
                        bar.set_postfix_str(f"RMS {np.sqrt(fit.objective) * 1e3:.2f} mm")
                        if decrease < ftol or drms < rms_tol:   # a small decrease, which the model foresaw (rho > ACCEPT)
                            converged, message = True, (f"converged: the RMS fell by {drms * 1e3:.3g} mm "
                                                        f"(< {rms_tol * 1e3:.3g}) or relatively by {decrease:.2g}")
                        break
                lam *= 4.0
                retried = True
            if converged:
                it += int(accepted)
                break
            if not accepted:
                message = "stalled: no step lowers the objective"
                break
            it += 1
    return GaussNewtonResult(lengths=l, xyz=x, damping=lam, converged=converged, message=message, iterations=it,
                             exhausted=not converged and it >= max_iter, objective_before=f_start,
                             objective_after=f)
