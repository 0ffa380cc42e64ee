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
mm: −45 to +12 mm on the saddle). Measured at 20 mm (README,
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
the coarse face is re-corrected there, and the iterations go on.

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
against the re-parametrized one). Measured at 20 mm (README,
``bench/bench_refine.py --reparametrize 0 1``).

The refined lengths are checked by the check's own inflation of a refined
design (:func:`airmat.check.inflation_check.check`): the open-loop equilibrium (the
first inflation, from the flat mattress) carried on to the refined lengths at
the target resolution (:func:`~airmat.inflation.simulate.inflate_from`), the path
every trial equilibrium took. It gives ``deviation_after``; if that is worse
than the open-loop deviation the open-loop lengths are kept
(``converged=False``). A design refined again starts from its first open loop
(``design.open_loop``), as its check does.
SI units inside; the ``refine`` block of design.json is in mm.
"""

from __future__ import annotations

import dataclasses
import logging
import time
from dataclasses import dataclass

import numpy as np

from airmat.errors import InputError
from airmat.check.compare import Deviation, deviation
from airmat.check.gauss_newton import gauss_newton
from airmat.check.inflation_check import KnownRun, design_strings, named_face, open_loop_strings
from airmat.check.length_map import length_map
from airmat.check.refine_objective import face_fit
from airmat.check.refined_design import REFINE_FLAG, refined_design
from airmat.check.reparametrize import Reparametrization
from airmat.check.reparametrize import reparametrize as reparametrize_approx
from airmat.check.trial_equilibrium import SOLVE_NEWTON, coarse_start, correct, make_problem
from airmat.inflation.mesh import build_mattress_mesh
from airmat.inflation.model import Parameters
from airmat.inflation.prolong import prolong
from airmat.inflation.simulate import INFLATE_TOL, inflate, inflate_from
from airmat.inflation.strings import check_resolution
from airmat.summary import Summarized, mm

__all__ = ["Refinement", "refine", "check_refinable", "refined_design", "REFINE_FLAG"]

log = logging.getLogger(__name__)

#: rounds of Ŝ re-parametrized in the refined face's realized metric (airmat.check.reparametrize)
REPARAM_ROUNDS = 1
#: iterations of a round's relaxation: the slide along Ŝ is done in ~50 (on the saddle 8.33 of the
#: 8.54 mm a converged relaxation moves); what follows drifts off the surface (A1 against A2)
REPARAM_RELAX_ITER = 50


@dataclass(frozen=True, repr=False)
class Refinement(Summarized):
    """The result of :func:`refine`.

    Attributes
    ----------
    design : airmat.design.pipeline.DesignResult
        The refined design: new ``l_median`` (lo95 / hi95 shifted by the same amount),
        dropped strings removed, flagged ones flagged, and its ``refine`` block.
    converged, iterations, seconds, message
        Of the Gauss–Newton loop (seconds: the whole refinement, verification included).
    objective_before, objective_after : float
        Mean squared distance of the named face (m²), before and after (regularization included);
        after: from the re-parametrized Ŝ when there is one (the coarse mesh's, when the iterations ran there).
    deviation_before, deviation_after : airmat.check.compare.Deviation
        Of fresh inflations at the open-loop and the refined lengths (the check's numbers).
    l_real : ndarray of shape (k,)
        Refined real median length of every original string (m).
    l_simulated : ndarray of shape (k,)
        The refined simulated rest lengths l* (m).
    dropped, flagged : tuple of str
        Ids of strings whose refined length reached the flat span (removed) / the shortest.
    inflation_seconds : float
        One inflation of the open-loop design at this resolution (for the time ratio).
    verification_seconds : float
        The inflation of the refined lengths that gives ``deviation_after``: the open-loop
        equilibrium carried on to them (the check's path of a refined design).
    resolution : float
        Mesh edge length (m).
    surface : str
        The named face.
    coarse_resolution : float or None
        Mesh of the Gauss–Newton iterations (m); None: all at ``resolution``.
    corrections : tuple of float
        The RMS distance (m) of the fine face from Ŝ at each defect correction's coarse optimum.
    alpha : float
        Weight of the pull toward the open-loop lengths (dimensionless).
    verification : airmat.check.inflation_check.KnownRun or None
        The inflation that gave ``deviation_after`` (the check's own): :func:`airmat.check.inflation_check.check`
        of ``design`` at this resolution takes it as its median run (``known=``) instead of inflating again.
    open_loop_run : airmat.check.inflation_check.KnownRun or None
        The open-loop inflation from the flat mattress that the verification was carried on from
        (the one ``inflation_seconds`` timed): the check's start for the refined design.
    reparametrization : airmat.check.reparametrize.Reparametrization or None
        The last round's Ŝ in the realized metric (``design.approx.xyz`` is its ``xyz``, and
        ``deviation_after`` is measured against it); None when Ŝ stayed as designed.
    deviation_before_reparametrized : airmat.check.compare.Deviation or None
        The open-loop inflation against that Ŝ (``deviation_before`` is against the designed one).
    reparametrize_rounds : int
        How many rounds were made.
    lengths_before : {"open-loop", "refined"}
        What the given design's lengths were (a refined design can be refined again).
    """

    design: object
    converged: bool
    iterations: int
    seconds: float
    message: str
    objective_before: float
    objective_after: float
    deviation_before: Deviation
    deviation_after: Deviation
    l_real: np.ndarray
    l_simulated: np.ndarray
    dropped: tuple
    flagged: tuple
    inflation_seconds: float
    verification_seconds: float
    resolution: float
    surface: str
    coarse_resolution: float | None = None
    corrections: tuple = ()
    alpha: float = float("nan")
    verification: KnownRun | None = None
    open_loop_run: KnownRun | None = None
    reparametrization: Reparametrization | None = None
    deviation_before_reparametrized: Deviation | None = None
    reparametrize_rounds: int = 0
    lengths_before: str = "open-loop"


    def _summary(self):
        return "Refinement", [("deviation", f"{mm(self.deviation_before.rms)} -> {mm(self.deviation_after.rms)} RMS "
                                            f"({self.deviation_after.rms_pct_diag:.2f} % of the diagonal)"),
                              ("converged", self.converged), ("iterations", self.iterations),
                              ("seconds", f"{self.seconds:.1f}"), ("dropped", len(self.dropped)),
                              ("flagged", len(self.flagged))]

    @property
    def known_runs(self) -> tuple:
        """The verification and the open-loop inflation it started from: what :func:`airmat.check.inflation_check.check`
        of ``design`` at this resolution (``known=``) need not inflate again."""
        return tuple(k for k in (self.verification, self.open_loop_run) if k is not None)

    def block(self) -> dict:
        """The ``refine`` block of design.json (mm, %)."""
        def dev(d):
            return {"rms_mm": round(d.rms * 1e3, 3), "max_mm": round(d.max * 1e3, 3),
                    "rms_pct_diag": round(d.rms_pct_diag, 4)}
        return {"converged": bool(self.converged), "iterations": int(self.iterations),
                "seconds": round(float(self.seconds), 2), "resolution_mm": round(self.resolution * 1e3, 3),
                "coarse_resolution_mm": None if self.coarse_resolution is None
                else round(self.coarse_resolution * 1e3, 3),
                "defect_corrections": len(self.corrections), "alpha": float(self.alpha),
                "surface": self.surface, "lengths_before": self.lengths_before,
                "deviation_before": dev(self.deviation_before),
                "deviation_after": dev(self.deviation_after), "dropped": list(self.dropped),
                "flagged": list(self.flagged), "message": self.message,
                "reparametrization": None if self.reparametrization is None else {
                    "rounds": int(self.reparametrize_rounds), **self.reparametrization.summary_mm(),
                    "deviation_before": dev(self.deviation_before_reparametrized)}}


def _coarse_resolution(resolution: float, span: np.ndarray, coarsest: float):
    """Twice ``resolution`` when that stays <= ``coarsest`` and leaves 4 edges along every string, else None."""
    coarse = 2.0 * resolution
    if coarse > coarsest * (1 + 1e-9) or coarse * 4.0 > float(np.min(span)):
        return None
    return coarse


def _bounds(design, strings) -> tuple:
    span = np.linalg.norm(strings.b - strings.a, axis=1)
    lo = np.minimum(length_map(design.calibration).to_simulated(np.zeros(len(span))), 0.5 * span)
    return lo, span


def check_refinable(design, resolution: float, path=None) -> None:
    """Refuse, before any work, what :func:`refine` cannot refine.

    Parameters
    ----------
    design : airmat.design.pipeline.DesignResult
    resolution : float
        The refinement's mesh edge length (m).
    path : str or PathLike, optional
        The file the design was read from: named by the errors about its content.

    Raises
    ------
    airmat.errors.InputError
        No strings, a resolution too coarse for them (:func:`~airmat.inflation.strings.check_resolution`),
        or no posterior samples in the design's calibration.
    """
    if len(design.pattern.strings) == 0:
        raise InputError("the design has no strings: nothing to refine", path=path)
    if getattr(design.calibration, "n_samples", 0) == 0:
        raise InputError("the design's calibration has no posterior samples: a refined length's "
                         "tolerance cannot be computed", path=path)
    check_resolution(design_strings(design, "median"), resolution)


def _reparametrize_rounds(work, g, design, l_open, lo, hi, rounds, total, kw):
    """Ŝ re-parametrized in the metric of ``work``'s face at ``g``'s optimum, then more iterations; ``rounds`` times.

    ``work.approx_xyz`` takes each new Ŝ. Each round's iterations are an even share of what
    is left of ``total`` (so what an earlier stage did not use is not lost). Returns the last
    Gauss–Newton result (iterations counted over all) and the rounds'
    :class:`~airmat.check.reparametrize.Reparametrization` list.
    """
    reps = []
    if rounds <= 0:
        return g, reps
    from airmat.design.closest_point import MeshProjector

    a = design.approx
    onto = MeshProjector(a.xyz, a.faces)
    for r in range(rounds):
        budget = (total - g["iterations"]) // (rounds - r)
        face = work.p @ g["x"] + (0.0 if work.offset is None else work.offset)
        rep = reparametrize_approx(a.xyz, a.uv, a.faces, face, start=work.approx_xyz, projector=onto,
                            max_iter=REPARAM_RELAX_ITER)
        reps.append(rep)
        work.approx_xyz = rep.xyz
        log.debug("Ŝ re-parametrized in the realized metric: moved %.1f mm RMS (%s), %.2f mm RMS off its surface",
                  rep.moved_rms * 1e3, "converged" if rep.converged else "not converged", rep.off_rms * 1e3)
        if budget > 0:
            g2 = gauss_newton(work, g["l"], l_open, g["x"], lo, hi, max_iter=budget, lam0=g["lam"], **kw)
            g2["iterations"] += g["iterations"]
            g = g2
    return g, reps


def refine(design, *, resolution: float = 0.020, params: Parameters = Parameters(), alpha: float = 1e-3,
           max_iter: int = 20, ftol: float = 2e-3, xtol: float = 1e-5, rms_tol: float = 5e-5,
           tol: float = INFLATE_TOL, trial_tol: float = 1e-4, coarsest: float = 0.04, fine_iter: int = 0,
           corrections: int = 0, surface: str = "auto", reparametrize: int = REPARAM_ROUNDS) -> Refinement:
    """Adjust the strings' lengths so that the inflated named face lands on Ŝ (see the module docstring).

    Parameters
    ----------
    design : airmat.design.pipeline.DesignResult
    resolution : float
        Mesh edge length (m); the check of the refined design at the same resolution
        reproduces ``deviation_after``.
    params : Parameters
    alpha : float
        Weight of the regularization (dimensionless).
    max_iter : int
        Gauss–Newton iterations.
    ftol, xtol, rms_tol : float
        Stopping rule: relative objective decrease, step length / mean span, decrease of
        the RMS (m) over an accepted step.
    tol : float
        Force residual of the inflations (the open-loop one and the verification).
    trial_tol : float
        Force residual of the trial equilibria on the coarse mesh.
    coarsest : float
        Coarsest mesh of the two-level scheme (m): the Gauss–Newton iterations run on
        twice ``resolution`` when that is at most ``coarsest`` (and leaves 4 edges along
        every string); 0 runs them all at ``resolution``.
    fine_iter : int
        Gauss–Newton iterations at ``resolution`` after the coarse ones (two-level only).
    corrections : int
        Defect corrections (two-level only): when the coarse iterations stop before ``max_iter``,
        solve the fine mesh at their lengths, re-correct the coarse face by the fine one there,
        and go on iterating on the coarse mesh; at most this many times.
    surface : {"auto", "top", "bottom", "mid"}
        The face; ``"auto"`` as the check chooses it.
    reparametrize : int
        Rounds of Ŝ re-parametrized in the metric the refined face realizes
        (:mod:`airmat.check.reparametrize`), each followed by Gauss–Newton iterations against
        the new Ŝ; 0: Ŝ as designed. ``max_iter`` is split evenly between the first
        stage and the rounds (the first stage gets the remainder, a round what the stages
        before it left).

    Returns
    -------
    Refinement

    Raises
    ------
    airmat.errors.InputError
        A design without strings, a resolution too coarse for them, or a calibration
        without posterior samples (the tolerance of a refined length comes from them).
    """
    t0 = time.perf_counter()
    check_refinable(design, resolution)
    given = "open-loop" if design.refine is None else "refined"
    if reparametrize < 0:
        raise InputError(f"refinement: reparametrize must be 0 or more rounds, got {reparametrize}")
    strings = design_strings(design, "median")
    start = open_loop_strings(design)      # a refined design is inflated from its open loop on
    mesh = build_mattress_mesh(design.mattress.width, design.mattress.height, design.mattress.thickness,
                               resolution=resolution)
    named = named_face(design, strings) if surface == "auto" else surface
    ti = time.perf_counter()
    base = inflate(mesh, strings if start is None else start, params=params, tol=tol, keep_levels=True)
    t_inflate = time.perf_counter() - ti
    first = base if start is None else inflate_from(base, strings, params=params, tol=tol)
    dev0 = deviation(first, design.approx.xyz, design.approx.uv, named)
    prob = make_problem(mesh, strings, params, design, named, tol)
    lo, hi = _bounds(design, strings)
    l_open = np.clip(strings.rest, lo, hi)
    kw = dict(alpha=alpha, ftol=ftol, xtol=xtol * float(np.mean(hi)), rms_tol=rms_tol)
    coarse = _coarse_resolution(resolution, hi, coarsest) if coarsest > 0 else None
    fine_rms = []
    objective_before = face_fit(prob.p, first.xyz, prob.approx_xyz).objective
    # the iterations split evenly between the first stage and each re-parametrization round
    budget = max_iter - (fine_iter if coarse is not None else 0)
    stage = budget - reparametrize * (budget // (reparametrize + 1))
    if coarse is None:
        gn = gauss_newton(prob, l_open, l_open, first.xyz, lo, hi, max_iter=stage, **kw)
        gn, reps = _reparametrize_rounds(prob, gn, design, l_open, lo, hi, reparametrize, budget, kw)
    else:
        # the iterations on the mesh twice as coarse (a Newton iteration ~6x cheaper), its face corrected
        # by the difference of the two meshes' faces at the open-loop lengths
        cmesh = build_mattress_mesh(mesh.width, mesh.height, mesh.thickness, resolution=coarse)
        cprob = make_problem(cmesh, strings, params, design, named, tol)
        cstart = coarse_start(cprob, base, strings, params, tol)
        cprob.offset = prob.p @ first.xyz - cprob.p @ cstart.xyz     # the face here minus the coarse one
        cprob.tol = trial_tol
        gc = gauss_newton(cprob, l_open, l_open, cstart.xyz, lo, hi, max_iter=stage, **kw)
        for _ in range(corrections):
            if gc["iterations"] >= stage:
                break
            eqf = correct(prob, cprob, gc["l"], gc["x"], trial_tol)
            if eqf is None:
                break
            fine_rms.append(float(np.sqrt(face_fit(prob.p, eqf.xyz, prob.approx_xyz).objective)))
            log.debug("defect correction: the fine face %.2f mm RMS at the coarse optimum (%d Newton iterations)",
                      fine_rms[-1] * 1e3, eqf.n_iter)
            g2 = gauss_newton(cprob, gc["l"], l_open, gc["x"], lo, hi,
                               max_iter=stage - gc["iterations"], lam0=gc["lam"], **kw)
            g2["iterations"] += gc["iterations"]
            gc = g2
        gc, reps = _reparametrize_rounds(cprob, gc, design, l_open, lo, hi, reparametrize, budget, kw)
        prob.approx_xyz = cprob.approx_xyz
        eq = prob.equilibrium(gc["l"], prolong(cmesh, gc["x"], mesh), SOLVE_NEWTON) if fine_iter else None
        log.debug("refinement: %d iterations on the %.0f mm mesh (%s), then here", gc["iterations"],
                  coarse * 1e3, gc["message"])
        if eq is None:
            gn = dict(gc)
        else:
            gn = gauss_newton(prob, gc["l"], l_open, eq.xyz, lo, hi, max_iter=fine_iter, lam0=gc["lam"], **kw)
            gn["iterations"] += gc["iterations"]
    gn["objective_before"] = objective_before
    approx_xyz = design.approx.xyz if not reps else reps[-1].xyz
    l_best, converged, message = gn["l"], gn["converged"], gn["message"]
    if gn["exhausted"]:        # counted over every stage (coarse, corrected, fine), not the last one's share
        message = f"not converged after {gn['iterations']} iterations"
    span_tol = 1e-4 * hi
    dropped = l_best >= hi - span_tol
    flagged = l_best <= lo + span_tol
    lengths = length_map(design.calibration)
    refined = refined_design(design, lengths.to_real(l_best), dropped, flagged)
    if reps:
        refined = dataclasses.replace(refined, approx=dataclasses.replace(refined.approx, xyz=approx_xyz))
    tv = time.perf_counter()
    refined_strings = design_strings(refined, "median")
    # the check's path of a refined design (airmat.check.inflation_check): from the open-loop equilibrium on
    final = inflate_from(base, refined_strings if len(refined_strings) else None, params=params, tol=tol)
    t_verify = time.perf_counter() - tv
    dev1 = deviation(final, approx_xyz, design.approx.uv, named)
    dev0_new = deviation(first, approx_xyz, design.approx.uv, named) if reps else None
    base_strings = strings if start is None else start
    known = KnownRun(refined_strings, final, params, tol, start=base_strings)
    # the design the user gets is never reported worse than the open-loop one (each against its own Ŝ)
    if not final.converged or dev1.rms > dev0.rms:
        message = (f"the refined lengths inflate to {dev1.rms * 1e3:.1f} mm RMS, not better than the "
                   f"{given} {dev0.rms * 1e3:.1f} mm: the {given} lengths are kept")
        converged, l_best, dev1 = False, l_open, dev0
        dropped, flagged = np.zeros(len(l_best), bool), np.zeros(len(l_best), bool)
        refined = dataclasses.replace(design)
        known = KnownRun(strings, first, params, tol, start=start)
        reps, dev0_new = [], None
    ids = strings.ids
    res = Refinement(design=refined, converged=converged, iterations=gn["iterations"],
                     seconds=time.perf_counter() - t0, message=message, objective_before=gn["objective_before"],
                     objective_after=gn["objective_after"], deviation_before=dev0, deviation_after=dev1,
                     l_real=lengths.to_real(l_best), l_simulated=l_best,
                     dropped=tuple(ids[i] for i in np.flatnonzero(dropped)),
                     flagged=tuple(ids[i] for i in np.flatnonzero(flagged)), inflation_seconds=t_inflate,
                     verification_seconds=t_verify, resolution=resolution, surface=named,
                     coarse_resolution=coarse, corrections=tuple(fine_rms), alpha=float(alpha),
                     verification=known, open_loop_run=KnownRun(base_strings, base, params, tol),
                     reparametrization=reps[-1] if reps else None,
                     deviation_before_reparametrized=dev0_new, reparametrize_rounds=len(reps),
                     lengths_before=given)
    log.info("refinement: %s in %d iterations, %.1f s (one inflation %.1f s); %s face RMS %.2f -> %.2f mm",
             "converged" if converged else "not converged", res.iterations, res.seconds, t_inflate, named,
             dev0.rms * 1e3, dev1.rms * 1e3)
    return dataclasses.replace(res, design=dataclasses.replace(res.design, refine=res.block()))
