"""Corrected string lengths from the updated model, the re-tie list and the corrected design.

After :func:`airmat.asbuilt.update.update` the built mattress is known as a world
(Δ̂, d̂) and each string's effective length error ê_i (cut and tie). A string that is
kept keeps its error (its effective length is l_i + ê_i); a string that is re-cut gets a
fresh, zero-mean one. :func:`correct` finds the effective lengths that land the named
face on Ŝ by one linear least-squares step through the update's face Jacobian A (the
aligned face's change per rest length, rigid motions removed), from the update's last
linearisation carried to the posterior mean:

    min over δr   (1/N) ‖E + A δr‖² + (α/k) ‖δr‖²,   lower ≤ rest + δr ≤ span,  |δr| ≤ ρ,

linearised at the design's median run (the update's first point): E its deviation from Ŝ
(N, 3), δr the change of the simulated rest lengths from the design's. The rest lengths the
simulator needs do not depend on the world; the world decides which real lengths give them.
A kept string's δr is fixed at its built one (the rest length of l + ê in (Δ̂, d̂)). ρ is a
trust radius (:data:`TRUST_RADIUS`, at least the string's built δr: undoing the world is
always allowed), α the refinement's weight
(:class:`airmat.check.refinement_result.RefineOptions`) and the bounds the refinement's
(:func:`airmat.check.refine_setup.length_bounds`: the shortest a tie allows, the flat span).
A full :func:`airmat.check.refinement.refine` is about four inflations; this step costs a
least-squares solve on a (3N, k) matrix, plus, optionally, one verification inflation. Each
new rest length is turned into the effective real length that gives it in the world (Δ̂, d̂) by
inverting the chain (:func:`airmat.check.string_world.world_strings`) exactly, string by string:
a string slack in that world (Equation 3 clipped at κ = 0) has no slope to linearise.

Keep or re-cut: a string whose effective length needs to change by at most the workshop's
cut tolerance is kept (δ_i = 0) and the others are solved again, until the set is stable.
The re-tie list (:func:`airmat.design.retie.retie_plan`; strings not tied to a grid are paired one
to one, keep or re-cut) goes from the mattress as built
(the design with each string at its learned effective length l_i + ê_i) to the corrected
design (kept strings as they are, re-cut strings at l_i + ê_i + δ_i, the length to cut).
The corrected :class:`~airmat.design.pipeline.DesignResult` swaps the lengths through
:func:`airmat.check.refined_design.refined_design` (Ŝ unchanged; inflated as the built design
is: from the flat mattress, or a refined design's first open loop) and carries each length's
95 % interval from the updated posterior of (Δ, d): the real length that keeps the rest
length fixed moves by −(∂rest/∂θ)/(∂rest/∂l) per unit of θ. SI units (m).
"""

from __future__ import annotations

import dataclasses
import logging
import time
from dataclasses import dataclass

import numpy as np
from scipy.optimize import lsq_linear

from airmat.asbuilt.chain_slopes import world_slopes
from airmat.check.compare import deviation
from airmat.check.refined_design import refined_design
from airmat.check.refine_setup import length_bounds
from airmat.check.refinement_result import RefineOptions
from airmat.check.string_world import world_strings
from airmat.constants import CUT_TOLERANCE
from airmat.design.retie import ACTIONS, RetiePlan, RetieStep, retie_plan
from airmat.errors import InputError
from airmat.inflation.model import Parameters
from airmat.summary import Summarized, mm

__all__ = ["Correction", "correct", "built_design", "MAX_PASSES"]

log = logging.getLogger(__name__)

#: keep/re-cut passes at most (each a bounded least-squares solve)
MAX_PASSES = 10
#: a string whose rest length moves less than this per metre of real length does not move the face
DEAD_SLOPE = 1e-6
#: how far (m) a rest length may move from the design's beyond undoing the world: the face Jacobian is
#: validated as linear over cut-tolerance-sized changes (airmat.check.tolerance: a few mm); an unbounded
#: single step asks the weakly bending strings for changes of 100 mm and more, where it is not
TRUST_RADIUS = 0.005
#: half-width of a central 95 % interval in standard deviations
Z95 = 1.959963984540054


@dataclass(frozen=True, repr=False)
class Correction(Summarized):
    """Corrected lengths, the re-tie list and the corrected design (SI units).

    Attributes
    ----------
    design : airmat.design.pipeline.DesignResult
        The corrected design (write it with :func:`airmat.design.design_io.write_design`).
    built : airmat.design.pipeline.DesignResult
        The mattress as built: each string at its learned effective length l + ê.
    plan : airmat.design.retie.RetiePlan
        From ``built`` to ``design``.
    l_real : ndarray of shape (k,)
        The corrected design's real lengths (m): the length to cut for a re-cut string, the
        learned effective length for a kept one.
    kept : ndarray of shape (k,) of bool
    change : ndarray of shape (k,)
        δ: each string's effective length change (m; 0 for kept strings).
    length_sd : ndarray of shape (k,)
        Standard deviation of each corrected length under the updated posterior of (Δ, d) (m).
    at_bound : ndarray of shape (k,) of bool
        The rest length reached a bound (the shortest a tie allows, or the flat span).
    rms_before : float
        RMS deviation of the named face from Ŝ as built, predicted: the update's last inflation (m).
    rms_linear : float
        Predicted RMS deviation after the correction, to first order (m).
    rms_verified : float or None
        The same from a verification inflation (m); None when not verified.
    verification : airmat.inflation.simulate.Inflation or None
    diagonal : float
        Ŝ's bounding-box diagonal (m).
    passes : int
        Keep/re-cut passes.
    seconds : float
    """

    design: object
    built: object
    plan: RetiePlan
    l_real: np.ndarray
    kept: np.ndarray
    change: np.ndarray
    length_sd: np.ndarray
    at_bound: np.ndarray
    rms_before: float
    rms_linear: float
    rms_verified: float | None
    verification: object
    diagonal: float
    passes: int
    seconds: float = 0.0

    def _summary(self):
        after = self.rms_linear if self.rms_verified is None else self.rms_verified
        return "Correction", [("re-tie", repr(self.plan)[len("<RetiePlan: "):-1]),
                              ("predicted RMS", f"{mm(self.rms_before, 2)} -> {mm(after, 2)} "
                                                f"({100 * after / self.diagonal:.2f} % of the diagonal)"),
                              ("verified", self.rms_verified is not None)]

    def block(self) -> dict:
        """The ``refine`` block of the corrected design.json (mm)."""
        return {"method": "as-built correction: one linear least-squares step through the face Jacobian "
                          "under the updated (delta, d) and string errors (airmat.asbuilt.correction)",
                "rms_before_mm": round(self.rms_before * 1e3, 3), "rms_linear_mm": round(self.rms_linear * 1e3, 3),
                "rms_verified_mm": None if self.rms_verified is None else round(self.rms_verified * 1e3, 3),
                "kept": int(self.kept.sum()), "recut": int((~self.kept).sum()),
                "keep_tolerance_mm": round(self.plan.cut_tolerance * 1e3, 3)}


def built_design(design, error):
    """The design with each string at its effective length l + ê (ê of shape (k,), m): the mattress as built."""
    strings = tuple(dataclasses.replace(s, l_median=s.l_median + float(e), l_lo95=s.l_lo95 + float(e),
                                        l_hi95=s.l_hi95 + float(e))
                    for s, e in zip(design.pattern.strings, np.asarray(error, float)))
    return dataclasses.replace(design, pattern=dataclasses.replace(design.pattern, strings=strings))


def _real_length(design, theta, rest, l_old, iterations: int = 60):
    """The effective real lengths (k,) whose rest lengths in the world θ are ``rest`` (m): the chain
    (:func:`world_strings`) inverted string by string, by bisection over [0, flat span] (all at once).

    The chain is non-decreasing in the length; a rest length beyond what it reaches gives the end of
    the interval (a string slack at its flat span, or the shortest).
    """
    span = np.array([s.eq3_span for s in design.pattern.strings])
    lo, hi = np.zeros_like(span), span.copy()
    for _ in range(iterations):
        mid = 0.5 * (lo + hi)
        below = world_strings(design, theta[0], theta[1], cut_error=mid - l_old).rest < rest
        lo, hi = np.where(below, mid, lo), np.where(below, hi, mid)
    return 0.5 * (lo + hi)


def _solve(a, e, lo, hi, alpha, kept, fixed):
    """The rest-length step (k,) from the design's of the bounded, regularized least squares; the kept
    strings at ``fixed`` (their step as built)."""
    n, k = e.size // 3, a.shape[1]
    free = ~kept
    step = np.where(kept, fixed, 0.0)
    if not free.any():
        return step
    m = np.vstack([a[:, free] / np.sqrt(n), np.sqrt(alpha / k) * np.eye(int(free.sum()))])
    b = np.concatenate([-(e + a[:, kept] @ step[kept]) / np.sqrt(n), np.zeros(int(free.sum()))])
    step[free] = lsq_linear(m, b, bounds=(lo[free], hi[free])).x
    return step


def correct(design, upd, *, check=None, keep_tolerance: float = CUT_TOLERANCE, alpha: float | None = None,
            trust_radius: float = TRUST_RADIUS, verify: bool = True,
            params: Parameters = Parameters()) -> Correction:
    """Corrected lengths that land the face on Ŝ under the updated model, the re-tie list and the design.

    Parameters
    ----------
    design : airmat.design.pipeline.DesignResult
        The design the mattress was built from.
    upd : airmat.asbuilt.update.Update
        Its update with the scan.
    check : airmat.check.inflation_check.DesignCheck, optional
        The design's check (the verification inflation starts as it does); needed only with ``verify``
        for a refined design, else the update's own inflation mesh is used.
    keep_tolerance : float
        A string whose effective length needs to change by at most this much is kept (m); default the
        workshop's :data:`airmat.constants.CUT_TOLERANCE`.
    alpha : float, optional
        Weight of the pull toward the design's rest lengths; default the refinement's.
    trust_radius : float
        Largest change of a rest length from the design's (m) beyond undoing the built world
        (:data:`TRUST_RADIUS`): the step is linear, and trusted only that far.
    verify : bool
        Inflate the corrected lengths in the updated world once (the check's way) and report its RMS.
    params : Parameters

    Returns
    -------
    Correction
    """
    from airmat.check.inflation_check import design_strings

    started = time.perf_counter()
    if not (np.isfinite(keep_tolerance) and keep_tolerance >= 0):
        raise InputError(f"the keep tolerance must be >= 0 m, got {keep_tolerance!r}")
    alpha = RefineOptions().alpha if alpha is None else float(alpha)
    k, point, approx = len(design.pattern.strings), upd.prediction, design.approx
    if upd.error.shape != (k,):
        raise InputError(f"the update has {upd.error.size} strings, the design {k}: not its update")
    theta, err = upd.mean, upd.error
    rest_hat = world_strings(design, theta[0], theta[1], cut_error=err).rest        # the strings as built
    med = upd.median                     # the design's own rest lengths: where the face is near Ŝ
    a, e = med.jacobian.reshape(-1, k), (med.deviation.aligned - approx.xyz).reshape(-1)
    r_theta, slope, _ = world_slopes(design, theta, err)
    lower, upper = length_bounds(design, design_strings(design))
    built_step = rest_hat - med.rest
    trust = np.maximum(np.abs(built_step), trust_radius)    # undoing the built world is always allowed
    lo, hi = np.maximum(lower - med.rest, -trust), np.minimum(upper - med.rest, trust)
    l_old = np.array([s.l_median for s in design.pattern.strings])
    step, l_eff, kept, passes = _keep_or_recut(design, theta, a, e, (lo, hi), alpha, built_step, med.rest,
                                               l_old + err, keep_tolerance)
    delta = l_eff - (l_old + err)
    at_bound = ~kept & ((step <= lo + 1e-9) | (step >= hi - 1e-9))
    n = len(approx.xyz)

    def rms(field):
        return float(np.sqrt(np.sum(field ** 2) / n))
    rms_before, rms_linear = float(point.deviation.rms), rms(e + a @ step)
    l_new = l_old + err + delta
    safe = np.where(slope > DEAD_SLOPE, slope, np.inf)
    g = -r_theta / safe[:, None]                     # dl/dθ at a fixed rest length (0 for a slack string)
    sd = np.sqrt(np.maximum(np.einsum("ki,ij,kj->k", g, upd.covariance, g), 0.0))
    built = built_design(design, err)
    corrected = _corrected_design(design, l_new, at_bound & (delta < 0), sd)
    verified, inf = None, None
    if verify:
        inf = _verify(design, corrected, check, point, theta, params)
        verified = deviation(inf, approx.xyz, approx.uv, upd.surface).rms
    plan = _plan(built, corrected, keep_tolerance)
    out = Correction(design=corrected, built=built, plan=plan, l_real=l_new, kept=kept, change=delta,
                     length_sd=sd, at_bound=at_bound, rms_before=rms_before, rms_linear=rms_linear,
                     rms_verified=verified, verification=inf,
                     diagonal=float(np.linalg.norm(np.ptp(approx.xyz, axis=0))), passes=passes,
                     seconds=time.perf_counter() - started)
    out = dataclasses.replace(out, design=dataclasses.replace(corrected, refine=out.block()))
    log.info("as-built correction: %s; predicted RMS %.2f -> %.2f mm (linear)%s", repr(plan), 1e3 * rms_before,
             1e3 * rms_linear, "" if verified is None else f", {1e3 * verified:.2f} mm inflated")
    return out


def _keep_or_recut(design, theta, a, e, bounds, alpha, built_step, rest0, l_built, tolerance):
    """The bounded step and the effective lengths, keeping every string that needs to change by at most
    ``tolerance`` (m) and solving the others again until the set is stable: (step, l_eff, kept, passes)."""
    k = len(l_built)
    l_old = np.array([s.l_median for s in design.pattern.strings])
    kept = np.zeros(k, bool)
    for passes in range(1, MAX_PASSES + 1):
        step = _solve(a, e, *bounds, alpha, kept, built_step)
        l_eff = _real_length(design, theta, rest0 + step, l_old)
        more = ~kept & (np.abs(l_eff - l_built) <= tolerance)
        if not more.any():
            break
        kept |= more
    return step, np.where(kept, l_built, l_eff), kept, passes


def _corrected_design(design, l_new, flagged, sd):
    """The design with the corrected real lengths (m), each with the 95 % interval ±Z95 ``sd`` (m)."""
    corrected = refined_design(design, l_new, np.zeros(len(l_new), bool), flagged)
    strings = tuple(dataclasses.replace(s, l_lo95=s.l_median - Z95 * v, l_hi95=s.l_median + Z95 * v)
                    for s, v in zip(corrected.pattern.strings, sd))
    # inflated as the built mattress was (from the flat mattress, or a refined design's first open loop)
    return dataclasses.replace(corrected, pattern=dataclasses.replace(corrected.pattern, strings=strings),
                               open_loop=design.open_loop)


def _plan(built, corrected, tolerance: float) -> RetiePlan:
    """The re-tie list from the built to the corrected design: :func:`retie_plan` when the strings are tied
    to grid nodes, else the same strings paired one to one (keep or re-cut only: the dashes do not move)."""
    a, b = built.pattern.strings, corrected.pattern.strings
    if all(s.dash.a_node is not None and s.dash.b_node is not None for s in a + b):
        return retie_plan(built, corrected, cut_tolerance=tolerance)
    limit = tolerance * (1 + 1e-9)
    steps = [RetieStep("keep" if abs(y.l_median - x.l_median) <= limit else "recut", x.side, x, y, 0.0)
             for x, y in zip(a, b)]
    steps.sort(key=lambda st: (ACTIONS.index(st.action), st.face, st.a.dash.id))
    return RetiePlan(steps=tuple(steps), cut_tolerance=float(tolerance))


def _verify(design, corrected, check, point, theta, params):
    """The corrected strings inflated in the updated world, the check's way (flat, or a refined design's
    open loop carried on)."""
    from airmat.check.inflation_check import design_strings
    from airmat.inflation.simulate import inflate, inflate_from

    rest = world_strings(corrected, theta[0], theta[1]).rest
    strings = dataclasses.replace(design_strings(design), rest=rest)
    if check is not None and check.open_loop is not None:
        return inflate_from(check.open_loop, strings, params=params)
    return inflate(point.inflation.mesh, strings, params=params)

