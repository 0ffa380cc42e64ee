"""The calibration posterior and each string's length error, updated with a scan of the built mattress.

Data: registered scan points in Ŝ's frame (m), reduced to an observed normal displacement y_v
and a weight W_v (points' worth) at each covered vertex v of Ŝ on the predicted aligned named face
(:mod:`airmat.asbuilt.scan_data`).

Model, linearised at the prediction x_j = (θ_j, e_j), θ = (Δ, d):

    y ≈ A_n (R_θ (θ − θ_j) + D_e (e − e_j)) + G r + ε,

- A_n (N, k): the face Jacobian (:func:`airmat.check.face_linearization.face_jacobian`, the aligned
  face's change per simulated rest length, rigid motions removed) projected on the
  predicted face's vertex normals;
- strings are tension-only: string i acts through A_n only up to u_i, the lengthening at which its
  linearised tension vanishes (:func:`~airmat.asbuilt.laplace.slack_reach`), so its term is A_n,i min(δl*_i, u_i). A string the
  world leaves slack is taut in the design's median run; a two-sided linear model would bring it to the
  onset of tension and hold its rest length there as if the scan had measured it (on the zoo's hypar-0.3,
  four such strings pinned 0.7 to 7.5 mm short and (Δ, d) 4.9 and 4.2 posterior sd from the world);
- R_θ = ∂rest/∂(Δ, d) (k, 2) and D_e = ∂rest_i/∂e_i (k,), central differences of
  :func:`airmat.check.string_world.world_strings`, the one chain from a world to the rest lengths;
- e (k,): each string's effective length error (cut and tie, and its own curvature scatter
  expressed as length);
- G r: a rigid motion of the registration (6 columns along the normals, flat prior): the scan
  is registered by another route than the check's Kabsch alignment, so only the non-rigid part
  of the displacement is data;
- prior θ ~ N(mean, covariance of the calibration's posterior samples), e_i ~ N(0, s_i²),
  s_i² = (cut tolerance)²/3 (uniform ±t, as :mod:`airmat.check.length_covariance`) or t²
  (normal) plus the scatter σ converted to length ((∂rest/∂z / ∂rest/∂e)² E[σ²]);
- noise ε_v ~ N(0, τ² + σ_s²/W_v): σ_s the scan points' own scatter about their vertex's
  mean, τ the model's error, estimated from the fit's residual (its weighted mean square
  over the residual degrees of freedom, a few fixed-point rounds).

Why a Laplace (Gaussian) update and not an MCMC: the Jacobian of the face with respect to
every rest length is at hand (one factorization, one back-substitution per string), the
model is linear in (θ, e) to first order and, with thousands of covered vertices and two
parameters plus one per string, the posterior is data-dominated and near-Gaussian; a few
Gauss–Newton relinearisations (each one inflation, made the check's way) take care of the curvature of the map. An MCMC would need an inflation per
sample. The posterior of (θ, e) is the Gaussian with the Gauss–Newton covariance, centred at the mode
of θ's Laplace marginal (:func:`~airmat.asbuilt.laplace.marginal_mode`: the joint MAP's θ, one of k + 2 parameters of which
k are the strings' errors, is biased by the chain's curvature in e) and the errors' conditional mean there.

The linear model, its prior and MAP are :mod:`airmat.asbuilt.laplace`; the chain's slopes
:mod:`airmat.asbuilt.chain_slopes`; this module relinearises: each step one inflation at the MAP, made
the check's way, until the MAP stays within :data:`STEP_TOL` of its linearisation point.

SI units (m, 1/m) throughout.
"""

from __future__ import annotations

import logging
import time
from dataclasses import dataclass, replace

import numpy as np
from scipy.linalg import block_diag

from airmat.asbuilt.chain_slopes import length_prior
from airmat.asbuilt.laplace import TAU_FLOOR, linear_face, map_estimate, map_objective, slack_reach
from airmat.asbuilt.scan_data import MAX_POINTS, ScanData, scan_subset
from airmat.check.compare import deviation
from airmat.check.string_world import world_strings
from airmat.check.face_linearization import linearize
from airmat.errors import InputError
from airmat.inflation.model import Parameters
from airmat.progress import residual_progress
from airmat.summary import Summarized, mm

__all__ = ["Prediction", "Update", "update", "MAX_RELINEARISATIONS", "FLAG_SE", "STEP_TOL", "STATIONARY_FIT"]

log = logging.getLogger(__name__)

#: relinearisations at most (each one inflation). The face is far from linear in the rest lengths (on refined
#: vault1 a 3 mm change of one string moves the face 14 % less than its tangent says), so Gauss–Newton gains
#: about a factor 4 of the scan–prediction mismatch per relinearisation on vault1 (22 -> 2.2 -> 0.41 -> 0.18 ->
#: 0.05 -> 0.035 mm, the scan's noise: converged after 6 linearisations), less where strings go slack and taut
#: on the way: the zoo's hypar-0.3 converges after 8 (21 -> 2.2 -> 1.2 -> 0.75 -> 0.35 -> 0.30 -> 0.06 -> 0.04
#: mm), wave-once after 7 with one step halved (``bench/bench_correct.py``)
MAX_RELINEARISATIONS = 10
#: a string's tie looks wrong when |ê| exceeds this many standard errors (and the cut tolerance)
FLAG_SE = 3.0
#: converged when no parameter moved by more than this fraction of its posterior standard deviation (a
#: shift of a quarter standard deviation moves a central 95 % interval's coverage by under 1 %)
STEP_TOL = 0.25
#: a point from which no step of a quarter posterior sd lowers the objective is a converged update when the scan's
#: misfit from its prediction is at most this many times the scan's own scatter at the vertices (RMS over them):
#: on vault1 at 40 mm, 85 % of the face scanned, 2.9 times where pose and world were found (0.38 against 0.13 mm),
#: 14 times where registration and update stopped together 6 mm off in Δ (2.61 against 0.18 mm)
STATIONARY_FIT = 10.0


@dataclass(frozen=True)
class Prediction:
    """The model's inflated face at one point (θ, e) of the linearisation (SI).

    Attributes
    ----------
    theta : ndarray of shape (2,)
        (Δ, d) (m).
    error : ndarray of shape (k,)
        Each string's effective length error e (m).
    rest : ndarray of shape (k,)
        The simulated rest lengths of that world (m).
    inflation : airmat.inflation.simulate.Inflation
    deviation : airmat.check.compare.Deviation
        Its named face aligned to Ŝ.
    jacobian : ndarray of shape (N, 3, k)
        A at that equilibrium (m/m).
    reach, give : ndarray of shape (k,), (k, k), or None
        The strings' tensions to first order (:func:`~airmat.asbuilt.laplace.slack_reach`) (m, m/m). None: every string
        taut whatever its length.
    """

    theta: np.ndarray
    error: np.ndarray
    rest: np.ndarray
    inflation: object
    deviation: object
    jacobian: np.ndarray
    reach: np.ndarray | None = None
    give: np.ndarray | None = None


@dataclass(frozen=True, repr=False)
class Update(Summarized):
    """The calibration posterior and the strings' length errors after a scan (SI units).

    Attributes
    ----------
    mean, covariance : ndarray of shape (2,), (2, 2)
        Posterior of (Δ, d) (m, m²).
    prior_mean, prior_covariance : ndarray of shape (2,), (2, 2)
        The design's calibration posterior as a Gaussian (m, m²).
    error, error_se : ndarray of shape (k,)
        Each string's effective length error ê (real length, m) and its standard error.
    error_prior_sd : ndarray of shape (k,)
        s_i of the prior on e_i (m).
    joint_covariance : ndarray of shape (k + 2, k + 2)
        Of (Δ, d, e_1 .. e_k) (m²).
    ids : tuple of str
    flagged : tuple of str
        Strings whose tie looks wrong: |ê| > FLAG_SE se and > the cut tolerance.
    samples : ndarray of shape (n, 3)
        Seeded Gaussian draws of (Δ, d) with σ (1/m) carried over from the design's calibration.
    residual : float
        RMS of the fitted normal residual over the covered vertices (m).
    noise_sd : float
        τ: the model-error standard deviation (m).
    rms_before : float
        RMS of the observed displacement from the prediction over the covered vertices (m).
    iterations : int
        Linearisations (the first at the design's median run).
    inflations : int
        Inflations made for the relinearisations.
    converged : bool
    message : str
    history : ndarray of shape (iterations, 2)
        (Δ, d) after each linearisation (m).
    prediction : Prediction
        The last linearisation point.
    median : Prediction
        The first: the design's median run (the check's), where the correction linearises.
    data : ScanData
        The scan reduced at the last linearisation.
    cut_tolerance : float
        t (m).
    surface : str
    seconds : float
    seed : int
    """

    mean: np.ndarray
    covariance: np.ndarray
    prior_mean: np.ndarray
    prior_covariance: np.ndarray
    error: np.ndarray
    error_se: np.ndarray
    error_prior_sd: np.ndarray
    joint_covariance: np.ndarray
    ids: tuple
    flagged: tuple
    samples: np.ndarray
    residual: float
    noise_sd: float
    rms_before: float
    iterations: int
    inflations: int
    converged: bool
    message: str
    history: np.ndarray
    prediction: Prediction
    median: Prediction
    data: ScanData
    cut_tolerance: float
    surface: str
    seconds: float = 0.0
    seed: int = 0

    def _summary(self):
        sd = np.sqrt(np.diag(self.covariance))
        return "Update", [("Δ", f"{mm(self.mean[0], 2)} ± {mm(sd[0], 2)}"), ("d", f"{mm(self.mean[1], 2)} ± "
                                                                               f"{mm(sd[1], 2)}"),
                          ("flagged", len(self.flagged)), ("residual", mm(self.residual, 2)),
                          ("iterations", self.iterations), ("converged", self.converged)]

    @property
    def interval95(self) -> np.ndarray:
        """Central 95 % intervals of Δ and d, shape (2, 2): rows (lo, hi) (m)."""
        half = 1.959963984540054 * np.sqrt(np.diag(self.covariance))
        return np.stack([self.mean - half, self.mean + half])

    @property
    def prior_interval95(self) -> np.ndarray:
        """The same of the prior (the design's calibration as a Gaussian), shape (2, 2) (m)."""
        half = 1.959963984540054 * np.sqrt(np.diag(self.prior_covariance))
        return np.stack([self.prior_mean - half, self.prior_mean + half])


def _draws(mean, cov, cal, n: int, seed) -> np.ndarray:
    """(n, 3): seeded Gaussian draws of (Δ, d) (m; Δ >= 0, d > 0) with σ (1/m) resampled from the
    calibration's samples (0 where it measured none: no scatter, as the check reads a missing σ)."""
    rng = np.random.default_rng(seed)
    draws = rng.multivariate_normal(mean, cov, size=int(n), method="eigh")
    draws[:, 0] = np.maximum(draws[:, 0], 0.0)
    draws[:, 1] = np.maximum(draws[:, 1], 1e-6)
    sigma = (np.asarray(cal.sigma, float)[rng.integers(0, cal.n_samples, int(n))]
             if cal.sigma is not None else np.zeros(int(n)))
    return np.column_stack([draws, sigma])


def _predict(design, check, strings, theta, error, surface, params):
    """The inflation at (θ, e) made the check's way, aligned to Ŝ, with its Jacobian.

    The check's way: from the flat mattress, or a refined design's open-loop equilibrium carried on
    (:func:`airmat.check.inflation_check.check`). Carrying an equilibrium on instead is cheaper but can
    keep another arrangement of the wrinkles than the built mattress took: the median run's on the
    two-string test design (2.5 mm RMS apart at the same lengths); the previous relinearisation's on
    refined vault1 (2 s instead of 5 s, but the scan–prediction misfit then stalls at 0.19 mm RMS where
    the check's way reaches the scan's noise, 0.035 mm, and d drifts 6 mm).
    """
    from airmat.inflation.simulate import inflate, inflate_from

    rest = world_strings(design, theta[0], theta[1], cut_error=error).rest
    s = replace(strings, rest=rest)
    if check.open_loop is not None:
        inf = inflate_from(check.open_loop, s, params=params)
    else:
        inf = inflate(check.runs["median"].inflation.mesh, s, params=params)
    if not inf.converged:
        log.warning("the inflation at the updated parameters did not converge: %s", inf.message)
    approx = design.approx
    dev = deviation(inf, approx.xyz, approx.uv, surface)
    return _linearised(design, Prediction(theta, error, rest, inf, dev, None), s, surface, params)


def _linearised(design, point: Prediction, strings, surface, params) -> Prediction:
    """``point`` with its face Jacobian and its strings' slack reach (:func:`~airmat.asbuilt.laplace.slack_reach`)."""
    lin = linearize(design, point, strings, surface, params)
    reach, give = slack_reach(lin, point.inflation.xyz)
    return replace(point, jacobian=lin.face, reach=reach, give=give)


def _message(converged: bool, linearisations: int, stationary, raised: bool, step: float) -> str:
    """The update's one-line verdict; ``stationary``: (misfit, scatter) (m) where no step descends, or None."""
    if converged:
        return f"converged after {linearisations} linearisations" + (
            "" if stationary is None else " (no descent beyond a quarter sd from the accepted point)")
    if stationary is not None:
        misfit, scatter = stationary
        return (f"not converged: no descent from a point where the scan lies {1e3 * misfit:.2f} mm RMS from the "
                f"prediction, {misfit / scatter:.0f} times its own scatter at the vertices (another equilibrium "
                "or a wrong registration?)")
    if raised:
        return "not converged: the last step raised the MAP objective (the accepted point's linearisation is kept)"
    if linearisations > 1:
        return f"not converged: the last step was {step:.2f} posterior sd (tolerance {STEP_TOL})"
    return "one linearisation (no relinearisation asked)"


def update(design, points, *, check=None, resolution: float = 0.020, params: Parameters = Parameters(),
           cut_tolerance: float = 0.003, cut_distribution: str = "uniform",
           max_relinearisations: int = 2, max_points: int | None = MAX_POINTS, n_samples: int = 2000, seed: int = 0,
           strict: bool = False, start: Update | None = None) -> Update:
    """Update the calibration posterior and each string's length error with a registered scan.

    Parameters
    ----------
    design : airmat.design.pipeline.DesignResult
        The design the mattress was built from (its calibration is the prior).
    points : ndarray of shape (M, 3)
        Scan points of the built, inflated mattress's named face, registered in Ŝ's frame (m).
    check : airmat.check.inflation_check.DesignCheck, optional
        The design's check (its median run is the prediction); default one made here with
        ``resolution`` and ``params`` (median run only).
    cut_tolerance : float
        t (m) of the strings' cut and tie errors (the prior of e and the flags).
    cut_distribution : {"uniform", "normal"}
        e uniform on ±t (variance t²/3) or normal with standard deviation t.
    max_relinearisations : int
        Gauss–Newton relinearisations after the first (at the median run), 0 to
        :data:`MAX_RELINEARISATIONS`; each costs one inflation.
    max_points : int or None
        Use at most this many scan points, a seeded random subset (:data:`MAX_POINTS`); None: all.
    n_samples : int
        Gaussian draws of (Δ, d) in ``Update.samples``.
    seed : int
        Seed of those draws, of the σ carried over and of the subset of the points.
    strict : bool
        Raise :class:`~airmat.errors.ConvergenceError` when the relinearisations do not converge.
    start : Update, optional
        An update of the same design with the same check whose last linearisation point this one
        starts from (the points re-registered onto its prediction, :func:`airmat.asbuilt.pipeline.correct`);
        it converges without a new inflation when the MAP there lies within :data:`STEP_TOL` of that
        point in every parameter. ``rms_before`` is still the scan's misfit from the design's median run.

    Returns
    -------
    Update
    """
    from airmat.check.inflation_check import check as run_check, design_strings
    from airmat.errors import ConvergenceError

    started = time.perf_counter()
    k = len(design.pattern.strings)
    if k == 0:
        raise InputError("the design has no strings: no string lengths to learn")
    if not 0 <= max_relinearisations <= MAX_RELINEARISATIONS:
        raise InputError(f"max_relinearisations must be 0 .. {MAX_RELINEARISATIONS}, got {max_relinearisations}")
    if not (np.isfinite(cut_tolerance) and cut_tolerance > 0):
        raise InputError(f"the cut tolerance must be > 0 m, got {cut_tolerance!r}")
    points = scan_subset(points, max_points, seed)
    if check is None:
        check = run_check(design, resolution=resolution, params=params, envelope=False)
    surface, med, faces = check.surface, check.runs["median"], design.approx.faces
    strings = design_strings(design, "median", lengths=check.lengths)
    mean0, cov0, s = length_prior(design, cut_tolerance, cut_distribution)
    prior_prec = block_diag(np.linalg.inv(cov0), np.diag(1.0 / s ** 2))
    cal = design.calibration
    theta = np.array([cal.delta_median, float(np.median(cal.d))])
    point = first = _linearised(design, Prediction(theta, np.zeros(k), strings.rest, med.inflation,
                                                   med.deviation, None), strings, surface, params)
    prior_mean = np.concatenate([mean0, np.zeros(k)])
    x = np.concatenate([theta, np.zeros(k)])
    history, converged, inflations, rms_before, tau2 = [], False, 0, None, None
    if start is not None:
        if start.error.shape != (k,):
            raise InputError(f"the start has {start.error.size} strings, the design {k}: not its update")
        rms_before = float(np.sqrt(np.mean(linear_face(first, faces, points)[1].y ** 2)))
        tau2 = max(start.noise_sd ** 2, TAU_FLOOR ** 2)
        point = start.prediction     # converged when the MAP at its linearisation point stays there
        x = np.concatenate([point.theta, point.error])
    names = ("delta", "d") + tuple(f"string {st.dash.id}" for st in design.pattern.strings)
    raised = False                 # the last step raised the objective and was not taken
    stationary = None              # (misfit, scatter) (m) where steps from the accepted point raise the
                                   # objective down to STEP_TOL
    best = None                    # the accepted linearisation: (its point's parameters, LinearFace, ScanData, point)
    sd = None                      # the posterior sd of the last MAP (set with ``best``)
    with residual_progress(STEP_TOL, desc="as-built update (step in posterior sd)") as bar:
        for it in range(max_relinearisations + 1):
            data, lin = linear_face(point, faces, points)
            at = np.concatenate([point.theta, point.error])
            if rms_before is None:
                rms_before = float(np.sqrt(np.mean(lin.y ** 2)))
                tau2 = rms_before ** 2
            elif best is not None and (map_objective(lin, at, prior_mean, prior_prec, tau2)
                                       > map_objective(best[1], best[0], prior_mean, prior_prec, tau2)):
                # the Gauss–Newton step raised the exact objective (the face is not linear that far): halve it
                # from the accepted point, or, with no relinearisation left, take the accepted point's linearisation
                back = 0.5 * (best[0] + at)
                if np.max(np.abs(back - best[0]) / sd) < STEP_TOL:
                    # halved that far the step is within a quarter sd of the accepted point in every parameter
                    # and still raises the objective: no descent left from there, which is where it stops, and
                    # converged if the scan lies there about as near its prediction as the scan's own scatter
                    stationary = (float(np.sqrt(np.mean(best[1].y ** 2))), float(np.sqrt(np.mean(best[1].var_scan))))
                elif it < max_relinearisations:
                    log.info("as-built update, linearisation %d: the step raised the MAP objective, halved", it + 1)
                    point = _predict(design, check, strings, back[:2], back[2:], surface, params)
                    inflations += 1
                    continue
                at, lin, data, point = best
                raised = stationary is None
            best = (at, lin, data, point)
            x_old, x = x, at
            x, joint, resid, tau2, inner = map_estimate(design, lin, x, prior_mean, prior_prec, tau2, k)
            sd = np.sqrt(np.maximum(np.diag(joint), 1e-300))
            if stationary is not None:
                x = at                 # the accepted point, with its linearisation's covariance
            moved = np.abs(x - x_old) / sd
            step, most = float(np.max(moved)), names[int(np.argmax(moved))]
            history.append(x[:2])
            bar.residual(max(step, 1e-12))
            log.info("as-built update, linearisation %d (%d inner steps): scan %.3f mm RMS from the prediction; "
                     "delta %.2f mm, d %.2f mm, step %.2f sd (%s), residual %.3f mm", it + 1, inner,
                     1e3 * np.sqrt(np.mean(lin.y ** 2)), 1e3 * x[0], 1e3 * x[1], step, most,
                     1e3 * np.sqrt(np.mean(resid ** 2)))
            if stationary is not None:
                converged = stationary[0] <= STATIONARY_FIT * stationary[1]
                break
            if (it > 0 or start is not None) and step < STEP_TOL and not raised:
                converged = True
                break
            if it == max_relinearisations:
                break
            point = _predict(design, check, strings, x[:2], x[2:], surface, params)
            inflations += 1
    message = _message(converged, len(history), stationary, raised, step)
    if not converged:
        log.warning("as-built update: %s", message)
        if strict:
            raise ConvergenceError(message, n_iter=len(history))
    err, err_se = x[2:], sd[2:]
    ids = tuple(sd_.dash.id for sd_ in design.pattern.strings)
    flag = (np.abs(err) > FLAG_SE * err_se) & (np.abs(err) > cut_tolerance)
    return Update(mean=x[:2], covariance=joint[:2, :2], prior_mean=mean0, prior_covariance=cov0, error=err,
                  error_se=err_se, error_prior_sd=s, joint_covariance=joint, ids=ids,
                  flagged=tuple(i for i, f in zip(ids, flag) if f), samples=_draws(x[:2], joint[:2, :2], cal, n_samples, seed),
                  residual=float(np.sqrt(np.mean(resid ** 2))), noise_sd=float(np.sqrt(tau2)),
                  rms_before=rms_before, iterations=len(history), inflations=inflations, converged=converged,
                  message=message, history=np.array(history), prediction=point, median=first, data=data,
                  cut_tolerance=float(cut_tolerance), surface=surface, seconds=time.perf_counter() - started,
                  seed=int(seed))
