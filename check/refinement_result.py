"""What a refinement takes and gives: its options (:class:`RefineOptions`) and its result (:class:`Refinement`).

The algorithm is :func:`airmat.check.refinement.refine`. SI units (m, 1/m).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from airmat.check.compare import Deviation, distance_to_target
from airmat.check.inflation_check import KnownRun
from airmat.check.reparametrize import Reparametrization
from airmat.inflation.model import Parameters
from airmat.inflation.simulate import INFLATE_TOL
from airmat.summary import Summarized, mm

__all__ = ["Refinement", "RefineOptions", "REPARAM_ROUNDS", "RMS_TOL_PER_DIAGONAL"]

#: the default ``rms_tol`` as a share of the mattress's diagonal: 0.05 mm on the small mattress (1112 mm),
#: 0.14 mm on the large one (3053 mm). Deviations are judged in % of the diagonal, so is the last
#: step's worth: an absolute 0.05 mm kept ``freeform-large-irregular`` iterating at 0.003 % of its
#: diagonal a step until its 20 iterations ran out (``bench/bench_zoo.py``, docs/decisions.md).
RMS_TOL_PER_DIAGONAL = 4.5e-5

#: rounds of Ŝ re-parametrized in the refined face's realized metric (airmat.check.reparametrize)
REPARAM_ROUNDS = 1


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

    def _to_target(self) -> dict:
        """``deviation_after_to_target``: the refined face's distance to the user's target S, when the design keeps S."""
        a = self.design.approx
        if a.target is None:
            return {}
        diag = float(np.linalg.norm(np.ptp(a.xyz, axis=0)))
        return {"deviation_after_to_target": distance_to_target(self.deviation_after.aligned, a.target,
                                                                diagonal=diag).summary_mm()}

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
                "deviation_after": dev(self.deviation_after), **self._to_target(),
                "dropped": list(self.dropped),
                "flagged": list(self.flagged), "message": self.message,
                "reparametrization": None if self.reparametrization is None else {
                    "rounds": int(self.reparametrize_rounds), **self.reparametrization.summary_mm(),
                    "deviation_before": dev(self.deviation_before_reparametrized)}}


@dataclass(frozen=True)
class RefineOptions:
    """The tuning of :func:`refine` (SI units).

    Attributes
    ----------
    resolution : float
        Mesh edge length (m); the check of the refined design at the same resolution
        reproduces ``deviation_after``.
    params : airmat.inflation.model.Parameters
        Pressure (Pa) and stiffnesses of the inflations.
    alpha : float
        Weight of the pull toward the open-loop lengths, ``alpha · mean((l* - l*_open)²)``
        beside the mean squared deviation (dimensionless).
    max_iter : int
        Gauss–Newton iterations (accepted steps), over every stage.
    ftol : float
        Stopping rule: relative decrease of the objective over an accepted step (dimensionless).
    xtol : float
        Stopping rule: step length / mean flat span of the strings (dimensionless).
    rms_tol : float or None
        Stopping rule: decrease of the RMS distance over an accepted step (m); None:
        :data:`RMS_TOL_PER_DIAGONAL` times the mattress's diagonal.
    tol : float
        Relative force residual of the inflations (the open-loop one and the verification).
    trial_tol : float
        Relative force residual of the trial equilibria on the coarse mesh.
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
    """

    resolution: float = 0.020
    params: Parameters = Parameters()
    alpha: float = 1e-3
    max_iter: int = 20
    ftol: float = 2e-3
    xtol: float = 1e-5
    rms_tol: float | None = None
    tol: float = INFLATE_TOL
    trial_tol: float = 1e-4
    coarsest: float = 0.04
    fine_iter: int = 0
    corrections: int = 0
    surface: str = "auto"
    reparametrize: int = REPARAM_ROUNDS
