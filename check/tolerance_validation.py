"""The linear tolerance's full samples: its mean shift and its check.

The linear tolerance (:mod:`airmat.check.tolerance`) is a Gaussian of the deviation about the
median run's face e₀ with covariance A Σ Aᵀ. The mean shift: a nonlinear response moves the mean: E[e] = e₀ + m with m = ½ tr(Σ ∂²e/∂l*²) + O(Σ²). The bands hardly notice (m is a
few millimetres against bands of tens), the RMS does: RMS² = ⟨|e₀ + δe|²⟩ over the vertices holds
2⟨e₀·m⟩, first order in m and scaled by e₀, while the RMS spread comes from 2⟨e₀·A δl*⟩ alone. Where
e₀ dominates and the change is nearly orthogonal to it (the saddle at 20 mm: e₀ 21 mm RMS, changes
11 mm, RMS spread 2.9 mm) the second-order shift moves the RMS median by a sizeable part of its spread
(2⟨e₀·m⟩ = −28 mm², −0.6 mm of the first-order model's +0.9 mm offset from 64 full samples at the
same lengths; the rest is a 9 % smaller variance, a third-order effect). The second derivative at the
median does not give m: a central difference of the forces along the Jacobian's directions gives a
step-dependent 13–18 mm RMS against the samples' 2 mm (the wrinkles' and the tension-only strings'
energy is far from quadratic over one standard deviation). So m is sampled, without bias:

Validation and mean shift (:func:`sample_validation`): the tolerance's ``validate`` full samples
in antithetic pairs, δl*_j and −δl*_j
(:func:`airmat.check.monte_carlo.draw` plus the cut error; the Gaussian model is symmetric), each the
equilibrium carried on from the median run's (Newton from the linear prediction, the mesh's model
and symbolic factorization shared). The response splits into its odd part (A δl* plus third order)
and its even part; within a pair the odd part cancels, so m̂, the mean change of the samples, is an
unbiased estimate of m whose error is the even part's scatter alone.

Spread (:func:`~airmat.check.pair_statistics.variance_ratio`, :func:`~airmat.check.pair_statistics.spread_scale`;
the pairs' statistics are :mod:`airmat.check.pair_statistics`): the same pairs give the samples' variance about
their mean over the model's for the same δl*, R̂, with the standard error of a ratio estimator from the
pairs. A third-order response makes R differ from 1: on the saddle at 20 mm a 256-sample Monte-Carlo
spreads 0.92 times the model's variance (its draws' own covariance divided out), and the pairs measure
0.85–0.93 over seeds 1–8 (standard errors 0.013–0.030). The mean squared change enters every draw's
RMS², so that deficit holds the first-order RMS median above the Monte-Carlo's (0.16 of the saddle's
0.39 mm). So the model's change is scaled by s = sqrt(1 + w (R̂ − 1)),
w = (R̂ − 1)² / ((R̂ − 1)² + se²), R̂ shrunk toward 1 by its standard error (a ratio within its noise
of 1, as on vault1, leaves the model nearly as it is). The model draws e = e₀ + m̂ + s A δl*. The
standard error of P(RMS <= T) below counts the pairs' scatter of the ratio with that of the shift.
Its checks:

- ``spread_error`` = sqrt(Σ_s ‖δe_s − m̂‖² / Σ_s ‖A δl*_s‖²) − 1, the relative error of the spread
  about the mean that the bands scale with. Paired on the same δl*, its sampling error is small
  (0.025 with 2 pairs on the saddle). Above :data:`RELIABLE_ERROR` (15 %, the accuracy the bands
  claim against a Monte-Carlo) the result says unreliable: a string that goes slack in half the
  samples, a wrinkle that snaps, halve or double the spread.
- with T, ``p_within_se``: the model's RMS density at T times the standard error of the shift's
  (and the spread's) effect on the RMS, from the scatter between the pairs. Above :data:`RELIABLE_P` (0.05) the result
  says unreliable: the sampled shift leaves P(RMS <= T) open. That standard error is judged by its
  upper 95 % confidence bound (:attr:`Validation.p_within_bound`): with p pairs the scatter has p − 1
  degrees of freedom: with 2 pairs the bound is 15.9 times the estimate, with 4 pairs 2.9, with the
  default 8 pairs 1.8. On the saddle at 20 mm the estimate from 2 pairs reads 0.04 while P over 8
  validation seeds scatters by 0.11.
- any sample that does not converge.

The per-sample relative error ‖δe − A δl*‖ / ‖δe‖ is reported but is not the verdict: on 64 full
samples of vault1 and the saddle it is 26–33 % while the bands agree within 5 %. It is not the
alignment (the rigid part of the changes is 1 %), nor the solver (samples from the flat mattress and
carried on agree to 1e-10), nor a few wrinkled vertices (the worst 10 % hold a quarter to a third of
it): it is the genuine second-order response, a mean (13–19 % of the change) and zero-mean scatter.
Scatter uncorrelated with A δl* adds only its square to the variance, so a 25 % error moves a band
by 3 %.

Cost: the equilibria stop at :data:`VALIDATION_TOL` (1e-3: Newton's last step from there moves the
face by less than 1e-5 of its change, measured on the saddle at 20 mm); each takes 7–20 Newton
iterations on its mesh, where one inflation does most of its iterations on the coarse meshes of its
continuation. So the samples run on the mesh twice as coarse as the check's
(:func:`validation_resolution`), about a tenth of the cost, about a median run of their own there
at the same lengths with its own Jacobian: the nonlinearity they measure is the mattress's, and on
vault1 and the saddle (8 pairs, seeds 1–3) the shift from 40 mm samples moves P(RMS <= T) of the
20 mm model as the 20 mm samples' shift does, within 0.005. With 32 pairs at the saddle's
Monte-Carlo median RMS, the 40 mm shift's projection on e₀ is 12–15 % short of the 20 mm one's, which
lowers P by 0.02–0.03 there (docs/decisions.md, Check). A Monte-Carlo from the flat mattress (``--samples K``) may also sample other
arrangements of the wrinkles, which no model about the median sees. SI units (m).
"""

from __future__ import annotations

import time
from dataclasses import dataclass, replace

import numpy as np

from airmat.check.face_linearization import Linearization, align_faces
from airmat.check.length_covariance import LengthCovariance
from airmat.check.pair_statistics import antithetic, pair_statistics, rms_shift_se, spread_scale, variance_ratio
from airmat.check.monte_carlo import draw
from airmat.errors import AirmatError
from airmat.forked import ForkedMap
from airmat.inflation.cholesky import ShiftedCholesky
from airmat.inflation.model import with_strings
from airmat.inflation.solver import NewtonSystem, solve

__all__ = ["Validation", "sample_validation", "start_validation", "finish_validation", "PendingValidation",
           "antithetic", "pair_statistics", "variance_ratio", "spread_scale", "rms_shift_se", "validation_resolution",
           "VALIDATION_SAMPLES", "VALIDATION_COARSEST", "RELIABLE_ERROR", "RELIABLE_P", "VALIDATION_TOL"]

#: full samples (antithetic pairs) that give the mean shift and check the model, by default: 8 pairs, so
#: that P(RMS <= T)'s standard error is judged with 7 degrees of freedom (its bound 1.8 times the estimate)
VALIDATION_SAMPLES = 16

#: the samples run on the mesh twice as coarse as the check's when that is at most this (m) and leaves
#: every string 4 edges (:func:`validation_resolution`)
VALIDATION_COARSEST = 0.04

#: relative error of the predicted spread above which the result is unreliable (module docstring)
RELIABLE_ERROR = 0.15

#: standard error of P(RMS <= T) above which the result is unreliable (module docstring)
RELIABLE_P = 0.05

#: relative force residual of the validation's equilibria (:func:`airmat.inflation.solver.solve`): Newton's
#: last step from 1e-3 moves the named face by less than 1e-5 of its change (module docstring)
VALIDATION_TOL = 1e-3


@dataclass(frozen=True)
class Validation:
    """Full samples in antithetic pairs against the model for their own length changes.

    Attributes
    ----------
    samples : int
        Full samples (2 per pair: δl and −δl).
    seed : int
    relative_error : float
        ‖actual − A δl‖ / ‖actual‖ of the deviation changes over every sample and vertex, the
        first-order prediction's error sample by sample (reported, not the verdict: the mean shift
        and zero-mean scatter make it up, which move the distribution far less; module docstring).
    spread_error : float
        sqrt(Σ ‖d_s − m̂‖² / Σ ‖A δl_s‖²) − 1: the relative error of the predicted spread about the mean,
        what the bands scale with (nan without converged pairs).
    shift : ndarray of shape (N, 3)
        m̂: the mean change of the samples, the model's second-order mean shift (m).
    rms_shift_se : float
        Standard error of the shift's effect on the RMS, from the scatter between the pairs (m; nan
        with fewer than 2 pairs).
    rms_actual, rms_linear : ndarray of shape (samples,)
        Each converged sample's RMS deviation, inflated and by the model e₀ + m̂ + A δl (m).
    converged : ndarray of shape (samples,) of bool
    p_within_se : float or None
        Standard error of P(RMS <= T) from ``rms_shift_se`` (the model's RMS density at T times it);
        None without T.
    threshold : float
        :data:`RELIABLE_ERROR`, the bound of ``|spread_error|``.
    p_threshold : float
        :data:`RELIABLE_P`, the bound of ``p_within_se``.
    seconds : float
        Wall time of the inflations (the coarse median's included).
    resolution : float
        Mesh edge of the samples (m; nan when not known).
    variance_ratio : float
        R̂: the samples' variance about their mean over the linear model's for the same δl
        (:func:`variance_ratio`; nan without 2 converged pairs).
    variance_ratio_se : float
        Its standard error from the scatter between the pairs (nan with fewer than 2 pairs).
    spread_scale : float
        s: the factor the model's change A δl is scaled by, sqrt of R̂ shrunk toward 1 by its standard
        error (:func:`spread_scale`); 1: not corrected.
    """

    samples: int
    seed: int
    relative_error: float
    spread_error: float
    shift: np.ndarray
    rms_shift_se: float
    rms_actual: np.ndarray
    rms_linear: np.ndarray
    converged: np.ndarray
    p_within_se: float | None = None
    threshold: float = RELIABLE_ERROR
    p_threshold: float = RELIABLE_P
    seconds: float = 0.0
    resolution: float = float("nan")
    variance_ratio: float = float("nan")
    variance_ratio_se: float = float("nan")
    spread_scale: float = 1.0

    @property
    def reliable(self) -> bool:
        """Every sample converged, the spread within the threshold and P(RMS <= T) known within ``p_threshold``."""
        p_ok = self.p_within_se is None or bool(self.p_within_bound <= self.p_threshold)
        return bool(self.samples > 0 and self.converged.all() and abs(self.spread_error) <= self.threshold and p_ok)

    @property
    def p_within_bound(self) -> float:
        """Upper 95 % confidence bound of ``p_within_se`` (nan without T or with fewer than 2 pairs).

        The standard error comes from the scatter of p pairs, p − 1 degrees of freedom: its bound is
        ``p_within_se · sqrt((p − 1) / χ²₀.₀₅(p − 1))``, 15.9 times the estimate with 2 pairs, 2.9 with 4,
        so that a lucky small scatter of few pairs does not vouch for P.
        """
        from scipy.special import gammaincinv

        dof = self.samples // 2 - 1
        if self.p_within_se is None or dof < 1 or not np.isfinite(self.p_within_se):
            return float("nan")
        return float(self.p_within_se * np.sqrt(dof / (2.0 * gammaincinv(0.5 * dof, 0.05))))   # χ² quantile

    @property
    def why(self) -> str:
        """What makes it unreliable ("" when reliable)."""
        if not self.converged.all():
            return f"{int((~self.converged).sum())} of {self.samples} full samples did not converge"
        if not abs(self.spread_error) <= self.threshold:
            return (f"the spread of {self.samples} full samples is {100 * self.spread_error:+.0f} % off the linear "
                    f"prediction (more than {100 * self.threshold:.0f} %)")
        if self.p_within_se is not None and not self.p_within_bound <= self.p_threshold:
            return (f"the nonlinear mean shift leaves P(RMS <= T) uncertain: its standard error is "
                    f"{self.p_within_se:.2f}, up to {self.p_within_bound:.2f} at 95 % confidence from "
                    f"{self.samples // 2} pairs of full samples (more than {self.p_threshold:.2f})")
        return ""


def _carry_on(lin: Linearization, x0: np.ndarray, mesh, strings, delta: np.ndarray, params,
              workers: int = 1) -> ForkedMap:
    """Equilibria at l* ± δ_j from the median ``x0`` (Newton, no ramp), started on up to ``workers`` forked
    processes (:class:`airmat.forked.ForkedMap`); its results: (positions (n, 3), converged) per sample, in
    the order +δ_1, −δ_1, +δ_2, ...

    The mesh's model, sparse pattern and symbolic factorization are shared; each run starts from its
    linear prediction x₀ ± J δ (from x₀ when that start stretches an edge past the solver's sanity
    bound) with the Newton system's shift, its floor and scale reset, so that a sample depends on its
    own δ only (the same bits in any process, in any order), and stops at :data:`VALIDATION_TOL`.
    """
    n = len(x0)
    system = NewtonSystem(groups=lin.assembler.free // 3)
    hint = system.hint_rel
    kw = dict(fixed_dofs=lin.fixed, tol=VALIDATION_TOL, max_iter=200, max_move=0.5 * float(np.mean(mesh.spacing)),
              assembler=lin.assembler, linear_system=system, desc="tolerance check", warn=False)

    def equilibrium(task):
        j, sign = task
        d = sign * delta[j]
        model = with_strings(lin.model, mesh, replace(strings, rest=strings.rest + d), params)
        step = (lin.dx @ d).reshape(n, 3)
        for start in (x0 + step, x0):      # a prediction that tears an edge (a wrinkle's rotation): from x₀
            system.hint_rel, system.mu_min, system.scale = hint, None, None
            try:
                r = solve(model, start, **kw)
            except AirmatError:
                continue
            return r.xyz, bool(r.converged)
        return np.full_like(x0, np.nan), False

    if len(delta):          # the ordering and symbolic analysis once, before any fork
        system.chol = ShiftedCholesky(lin.assembler.pattern(), system.groups)
    return ForkedMap(equilibrium, [(j, sign) for j in range(len(delta)) for sign in (1.0, -1.0)], workers)


def validation_resolution(design, resolution: float) -> float:
    """The mesh of the validation's samples (m): twice ``resolution`` when that is at most
    :data:`VALIDATION_COARSEST` and resolves every string, else ``resolution``.

    The samples measure how far the response to the string lengths is from linear, and its mean
    shift; both are the mattress's, not the mesh's. Side by side with samples on the check's own
    20 mm mesh (vault1 and the saddle, 8 pairs, seeds 1–3) the shift moves P(RMS <= T) by the same
    amount within 0.005, at a fifth to a tenth of the time (docs/decisions.md, Check).
    """
    from airmat.check.inflation_check import design_strings
    from airmat.inflation.strings import check_resolution

    coarse = 2.0 * float(resolution)
    if coarse > VALIDATION_COARSEST + 1e-12:
        return float(resolution)
    try:
        check_resolution(design_strings(design), coarse)
    except AirmatError:
        return float(resolution)
    return coarse


@dataclass
class PendingValidation:
    """Full samples started by :func:`start_validation` (on forked processes, or to run at
    :func:`finish_validation`), with what their statistics need."""

    design: object
    check_run: object
    lin: Linearization
    delta: np.ndarray
    seed: int
    runs: ForkedMap
    started: float


def start_validation(design, check_run, strings, lin: Linearization, n: int, seed: int, cov: LengthCovariance,
                     params, workers: int = 1) -> PendingValidation:
    """Draw the ``n`` full samples' length changes (antithetic pairs) and start their equilibria, carried on
    from ``check_run``'s median one, on up to ``workers`` forked processes (:class:`airmat.forked.ForkedMap`;
    1, or where the platform cannot fork: at :func:`finish_validation`, here). The samples are the same bits
    either way."""
    lengths, med = check_run.lengths, check_run.runs["median"]
    pairs = n // 2
    dr = draw(design, pairs, seed, lengths=lengths)
    t = cov.cut_tolerance
    rng = np.random.default_rng([seed, 1])
    cut = (rng.uniform(-t, t, dr.length.shape) if cov.cut_distribution == "uniform"
           else rng.normal(0.0, t, dr.length.shape)) if t > 0 else 0.0
    delta = lengths.to_simulated(np.maximum(dr.length + cut, 0.0)) - strings.rest          # (p, k)
    started = time.perf_counter()
    runs = _carry_on(lin, med.inflation.xyz, med.inflation.mesh, strings, delta, params, workers)
    return PendingValidation(design=design, check_run=check_run, lin=lin, delta=delta, seed=int(seed), runs=runs,
                             started=started)


def sample_validation(design, check_run, strings, lin: Linearization, n: int, seed: int, cov: LengthCovariance,
                      params, variance: float, base: np.ndarray | None = None,
                      spread_correction: bool = True, workers: int = 1) -> Validation:
    """``n`` full samples in antithetic pairs, carried on from ``check_run``'s median equilibrium, against
    the model ``lin`` of that run (``variance``: the model's total, Σ_v tr(A_v Σ A_vᵀ), m²), on up to
    ``workers`` forked processes: :func:`start_validation` then :func:`finish_validation`.

    ``base`` (N, 3): the deviation e₀ the RMS statistics add the changes to (m); default that run's
    own (another mesh's, when the samples run on a coarser one). ``spread_correction``: the model's
    change scaled by :func:`spread_scale` of the samples' variance ratio (False: not scaled, 1)."""
    pending = start_validation(design, check_run, strings, lin, n, seed, cov, params, workers)
    return finish_validation(pending, variance, base, spread_correction)


def finish_validation(pending: PendingValidation, variance: float, base: np.ndarray | None = None,
                      spread_correction: bool = True) -> Validation:
    """The statistics of :func:`start_validation`'s samples (waits for them); the arguments as
    :func:`sample_validation`'s. ``seconds``: from their start to their statistics."""
    design, check_run, lin, delta, seed = pending.design, pending.check_run, pending.lin, pending.delta, pending.seed
    med, pairs = check_run.runs["median"], len(delta)
    done = pending.runs.results()
    x = np.array([xyz for xyz, _ in done]).reshape(2 * pairs, *med.inflation.xyz.shape)
    converged = np.array([ok for _, ok in done], bool)
    approx = design.approx
    faces = (lin.operator @ x.transpose(1, 0, 2).reshape(x.shape[1], -1)).reshape(-1, len(x), 3).transpose(1, 0, 2)
    seconds = time.perf_counter() - pending.started
    e0 = med.deviation.aligned - approx.xyz if base is None else np.asarray(base, float)
    both = converged.reshape(-1, 2).all(axis=1).repeat(2)
    actual = align_faces(faces[both], approx.xyz) - med.deviation.aligned
    predicted = np.einsum("nck,sk->snc", lin.face, antithetic(delta)[both])
    if len(actual) == 0:
        nan = float("nan")
        return Validation(samples=2 * pairs, seed=int(seed), relative_error=nan, spread_error=nan,
                          shift=np.zeros_like(e0), rms_shift_se=nan, rms_actual=np.zeros(0), rms_linear=np.zeros(0),
                          converged=converged, seconds=seconds, resolution=float(check_run.resolution))
    shift, spread_err, per_pair = pair_statistics(actual, predicted)
    ratio, ratios, ratio_se = variance_ratio(actual, predicted)
    scale = spread_scale(ratio, ratio_se) if spread_correction else 1.0
    norm = float(np.linalg.norm(actual))
    err = float(np.linalg.norm(actual - predicted)) / norm if norm > 0 else float("nan")
    v = variance / len(e0)

    def rms(e):
        return np.sqrt(np.mean(np.sum((e0 + e) ** 2, axis=2), axis=1))
    return Validation(samples=2 * pairs, seed=int(seed), relative_error=err, spread_error=spread_err, shift=shift,
                      rms_shift_se=rms_shift_se(e0, per_pair, v, ratios if spread_correction else None),
                      rms_actual=rms(actual), rms_linear=rms(shift + scale * predicted), converged=converged,
                      seconds=seconds, resolution=float(check_run.resolution), variance_ratio=ratio,
                      variance_ratio_se=ratio_se, spread_scale=scale)
