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
  linearised tension vanishes (:func:`slack_reach`), so its term is A_n,i min(δl*_i, u_i). A string the
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
of θ's Laplace marginal (:func:`_marginal_mode`: the joint MAP's θ, one of k + 2 parameters of which
k are the strings' errors, is biased by the chain's curvature in e) and the errors' conditional mean there.

SI units (m, 1/m) throughout.
"""

from __future__ import annotations

import logging
import time
from dataclasses import dataclass, replace

import numpy as np
from scipy.linalg import block_diag

from airmat.asbuilt.scan_data import MAX_POINTS, ScanData, scan_data, scan_subset
from airmat.check.compare import deviation
from airmat.check.string_world import world_strings
from airmat.check.face_linearization import linearize
from airmat.design.curvature import vertex_normals
from airmat.errors import InputError
from airmat.inflation.energy import spring_profile
from airmat.inflation.model import Parameters
from airmat.progress import residual_progress
from airmat.summary import Summarized, mm

__all__ = ["Prediction", "Update", "update", "known_face_update", "world_slopes",
           "error_slope", "slack_reach",
           "MAX_RELINEARISATIONS", "FLAG_SE"]

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
#: fixed-point rounds of the model-error variance τ² per inner step
NOISE_ROUNDS = 3
#: inner Gauss–Newton steps over the exact chain at most, and their tolerance (posterior sd)
INNER_ITER = 30
INNER_TOL = 1e-3
#: a point from which no step of a quarter posterior sd lowers the objective is a converged update when the scan's
#: misfit from its prediction is at most this many times the scan's own scatter at the vertices (RMS over them):
#: on vault1 at 40 mm, 85 % of the face scanned, 2.9 times where pose and world were found (0.38 against 0.13 mm),
#: 14 times where registration and update stopped together 6 mm off in Δ (2.61 against 0.18 mm)
STATIONARY_FIT = 10.0
#: degrees of freedom of the Student-t prior on (Δ, d) (scale: the calibration's covariance). The cylinders'
#: calibration need not hold for the built mattress (another batch, pressure, temperature): where the scan
#: contradicts it, a Gaussian prior would still pull the estimate by its full weight (in the demo's world,
#: 15 calibration sd away along Δ and d's correlation, 3.6 posterior sd off with the face known), a t
#: prior gives way (its weight falls as 1 / r²); where they agree it acts as the calibration
#: (weight (ν + 2) / ν at its mean)
PRIOR_DOF = 4.0
#: the model error's standard deviation is at least this (m): a micrometre, far below any scan's noise
TAU_FLOOR = 1e-6
#: ∂rest/∂e below this: the string is clipped by Equation 3 (slack, or at its largest curvature)
CLIPPED_SLOPE = 1e-6


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
        The strings' tensions to first order (:func:`slack_reach`) (m, m/m). None: every string
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


def world_slopes(design, theta, error, *, strings=None) -> tuple:
    """∂rest/∂(Δ, d) (k, 2), ∂rest_i/∂e_i (k,) and ∂rest_i/∂z_i (k,) at one world (central differences).

    Parameters
    ----------
    design : airmat.design.pipeline.DesignResult
    theta : ndarray of shape (2,)
        (Δ, d) (m).
    error : ndarray of shape (k,)
        Effective length errors (m).
    strings : sequence of TensionString, optional
        Default the design's.

    Returns
    -------
    tuple of ndarray
        Unitless (m/m) for Δ, d and e; m per 1/m for the curvature offset z.
    """
    theta, error = np.asarray(theta, float), np.asarray(error, float)
    h = 1e-5 * max(float(np.max(np.abs(theta))), 1e-3)
    hk = 1e-3
    # the eight worlds of the central differences in one batched chain: Δ ± h, d ± h, e ± h, z ± hk
    delta = theta[0] + h * np.array([1.0, -1.0, 0, 0, 0, 0, 0, 0])
    d = theta[1] + h * np.array([0, 0, 1.0, -1.0, 0, 0, 0, 0])
    e = error[None, :] + h * np.array([0, 0, 0, 0, 1.0, -1.0, 0, 0])[:, None]
    z = hk * np.array([0, 0, 0, 0, 0, 0, 1.0, -1.0])[:, None]
    r = world_strings(design, delta, d, cut_error=e, kappa_offset=z, strings=strings).rest
    r_theta = np.column_stack([(r[0] - r[1]) / (2 * h), (r[2] - r[3]) / (2 * h)])
    return r_theta, (r[4] - r[5]) / (2 * h), (r[6] - r[7]) / (2 * hk)


def error_slope(design, theta, error, *, strings=None) -> np.ndarray:
    """∂rest_i/∂e_i (k,) at one world: :func:`world_slopes`'s second part alone (two worlds of the chain).

    Parameters are those of :func:`world_slopes`.
    """
    theta, error = np.asarray(theta, float), np.asarray(error, float)
    h = 1e-5 * max(float(np.max(np.abs(theta))), 1e-3)
    r = world_strings(design, np.full(2, theta[0]), np.full(2, theta[1]),
                      cut_error=error[None, :] + h * np.array([1.0, -1.0])[:, None], strings=strings).rest
    return (r[0] - r[1]) / (2 * h)


def _prior(design, cut_tolerance: float, cut_distribution: str):
    """(θ mean (2,), θ covariance (2, 2), s (k,)) of the prior (m, m², m)."""
    cal = design.calibration
    if cal.n_samples < 2:
        raise InputError("the design's calibration has fewer than 2 posterior samples: no prior covariance of "
                         "(delta, d) to update", n_samples=cal.n_samples)
    mean = np.array([np.mean(cal.delta), np.mean(cal.d)])
    cov = np.atleast_2d(np.cov(np.column_stack([cal.delta, cal.d]), rowvar=False))
    k = len(design.pattern.strings)
    median = np.array([cal.delta_median, float(np.median(cal.d))])
    _, d_e, d_z = world_slopes(design, median, np.zeros(k))
    var = np.full(k, cut_tolerance ** 2 / 3.0 if cut_distribution == "uniform" else cut_tolerance ** 2)
    if cal.sigma is not None:
        ratio = np.divide(d_z, d_e, out=np.zeros(k), where=np.abs(d_e) > 1e-9)
        var = var + ratio ** 2 * float(np.mean(np.asarray(cal.sigma, float) ** 2))
    return mean, cov, np.sqrt(var)


def slack_reach(linearization, x: np.ndarray) -> tuple:
    """How the strings' tensions vanish under changes of the rest lengths, to first order (m, m/m).

    A string is tension-only (:func:`airmat.inflation.energy.spring_profile`). Its force f_i, of slope
    f_i' in its stretch, vanishes where the stretch has fallen by r_i = f_i / f_i'; a change δ of the
    rest lengths changes the stretch by ((C − I) δ)_i, C_ij = ∂(end distance of i)/∂l*_j the face's
    give at the equilibrium (the adjoint's columns). So string i is slack once
    r_i + ((C − I) δ)_i <= 0, and it then no longer moves the face, however long.

    Parameters
    ----------
    linearization : airmat.check.face_linearization.Linearization
        At the equilibrium ``x``; its last spring group is the external strings.
    x : ndarray of shape (n, 3)
        The equilibrium's vertex positions (m).

    Returns
    -------
    reach : ndarray of shape (k,)
        r_i >= 0 (m); 0 for a string slack at ``x``.
    give : ndarray of shape (k, k)
        C (m/m).
    """
    s = linearization.model.springs[-1]
    r = np.einsum("sk,skc->sc", s.coef, x[s.idx])
    length = np.linalg.norm(r, axis=1)
    rhat = r / np.maximum(length, 1e-300)[:, None]
    _, f, df = spring_profile(length - s.rest, s.smooth, s.compression)
    k = len(length)
    dx = linearization.dx.reshape(len(x), 3, k)
    give = np.einsum("sc,sj,sjcq->sq", rhat, s.coef, dx[s.idx])
    return np.where((f > 0) & (df > 0), f / np.maximum(df, 1e-300), 0.0), give


def _rigid_columns(xyz: np.ndarray, normal: np.ndarray) -> np.ndarray:
    """(N, 6): the normal component of the three translations and the three rotations about the centroid."""
    p = xyz - xyz.mean(axis=0)
    rot = np.cross(p[:, None, :], np.eye(3)[None, :, :])       # (N, 3 axes, 3): -(axis x p) ... sign is free
    return np.column_stack([normal, np.einsum("nac,nc->na", rot, normal)])


def _solve(y, var_scan, tau2, jac, rigid, prior_prec, prior_rhs):
    """The MAP step of the Gaussian model and its covariance (rigid part marginalized); with the residual."""
    w = 1.0 / (tau2 + var_scan)
    m = np.column_stack([jac, rigid])
    p = jac.shape[1]
    h = (m * w[:, None]).T @ m
    h[:p, :p] += prior_prec
    rhs = (m * w[:, None]).T @ y
    rhs[:p] += prior_rhs
    scale = np.sqrt(np.maximum(np.diag(h), 1e-300))          # equilibrate: metres of Δ against vertices
    cov = np.linalg.pinv(h / np.outer(scale, scale), hermitian=True) / np.outer(scale, scale)
    x = cov @ rhs
    resid = y - m @ x
    dof = len(y) - float(np.trace((m * w[:, None]).T @ m @ cov))
    return x, cov, resid, max(dof, 1.0)


@dataclass(frozen=True)
class _Linear:
    """The face linearised at one inflation: y ≈ A_n (rest − rest_j) + G r at the covered vertices."""

    y: np.ndarray
    var_scan: np.ndarray
    a_n: np.ndarray
    rigid: np.ndarray
    rest: np.ndarray
    reach: np.ndarray | None = None
    give: np.ndarray | None = None

    def effective(self, rest: np.ndarray) -> tuple:
        """The change of the rest lengths the face feels at ``rest``, and its derivative (m, m/m).

        δ = rest − rest_j. A string taut in the linear model (:func:`slack_reach`) acts with its
        own δ_i; a slack one with the change that leaves its tension at 0, the others' fixed:
        δ_i' = (r_i + Σ_{j≠i} C_ij δ_j) / (1 − C_ii), less than δ_i.

        Returns
        -------
        tuple
            δ' (k,) and ∂δ'/∂rest (k, k).
        """
        delta = rest - self.rest
        if self.reach is None:
            return delta, np.eye(len(delta))
        c = self.give
        own = np.maximum(1.0 - np.diag(c), 1e-6)
        off = c - np.diag(np.diag(c))
        zero = (self.reach + off @ delta) / own
        slack = zero < delta
        d = np.where(slack[:, None], off / own[:, None], np.eye(len(delta)))
        return np.where(slack, zero, delta), d


def _linearisation(point, faces, points) -> tuple:
    """The scan reduced at the prediction and the face's normal Jacobian there: (ScanData, _Linear).

    The scan is projected again at every prediction (2.9 s for a million points on vault1): moving the
    first reduction by the prediction's change along the normals instead leaves the points' slide
    along the face, which on vault1 (a 22 mm move) kept a 0.5 mm residual where projecting again
    leaves 0.05 mm.
    """
    data = scan_data(points, point.deviation.aligned, faces)
    if not data.covered.any():
        raise InputError("no scan point lies on the predicted face: is the scan registered in Ŝ's frame?")
    normal = vertex_normals(point.deviation.aligned, faces)
    c = data.covered
    a_n = np.einsum("nc,nck->nk", normal[c], point.jacobian[c])
    return data, _Linear(y=data.observed[c], var_scan=data.point_sd ** 2 / data.weight[c], a_n=a_n,
                         rigid=_rigid_columns(point.deviation.aligned, normal)[c], rest=point.rest,
                         reach=point.reach, give=point.give)


def _theta_r2(x, prior_mean, prior_prec) -> float:
    """r²: (Δ, d)'s squared Mahalanobis distance from the calibration's mean under its precision."""
    d = x[:2] - prior_mean[:2]
    return float(d @ prior_prec[:2, :2] @ d)


def _prior_weight(x, prior_mean, prior_prec) -> float:
    """w = (ν + 2) / (ν + r²): the Student-t prior's weight on (Δ, d)'s Gaussian precision at x (IRLS),
    ν = :data:`PRIOR_DOF`."""
    return (PRIOR_DOF + 2.0) / (PRIOR_DOF + _theta_r2(x, prior_mean, prior_prec))


def _prior_term(x, prior_mean, prior_prec) -> float:
    """The prior's negative log density (up to a constant): Student-t on (Δ, d), Gaussian on the errors."""
    e = x[2:] - prior_mean[2:]
    return (0.5 * (PRIOR_DOF + 2.0) * np.log1p(_theta_r2(x, prior_mean, prior_prec) / PRIOR_DOF)
            + 0.5 * float(e @ prior_prec[2:, 2:] @ e))


def _objective(lin: _Linear, x, prior_mean, prior_prec, tau2) -> float:
    """The MAP objective at the linearisation's own point x (k + 2,): half the weighted squared misfit of the
    scan from that inflation after the best rigid motion, plus the prior's negative log density (:func:`_prior_term`)."""
    root = 1.0 / np.sqrt(tau2 + lin.var_scan)
    g, y = lin.rigid * root[:, None], lin.y * root
    r = y - g @ np.linalg.lstsq(g, y, rcond=None)[0]
    return 0.5 * float(r @ r) + _prior_term(x, prior_mean, prior_prec)


def _map(design, lin: _Linear, x0, prior_mean, prior_prec, tau2, k):
    """The MAP of (θ, e) under the face linear in the rest lengths and the exact chain rest(θ, e).

    Inner Gauss–Newton: the chain (:func:`world_strings`, Equation 3) is cheap and evaluated exactly,
    only the face is linear; τ² is re-estimated from the residual on the way. Where strings sit at
    Equation 3's clip (slack onset, largest curvature) full steps can cycle across the kink until
    :data:`INNER_ITER`; damping them instead (halving a step that does not lower the objective) stops
    on the kink itself, where the Gauss–Newton covariance collapses (Δ's sd to 5 µm on some draws of
    the refined saddle, whose known-face coverage then falls from 95 % to 84 %), so they are not
    damped. Returns
    (x, covariance of x, residual, τ², inner iterations).
    """
    x = np.array(x0, float)
    for inner in range(1, INNER_ITER + 1):
        rest = world_strings(design, x[0], x[1], cut_error=x[2:]).rest
        r_theta, d_e, _ = world_slopes(design, x[:2], x[2:])
        delta, d_delta = lin.effective(rest)
        a = lin.a_n @ d_delta
        jac = np.column_stack([a @ r_theta, a * d_e[None, :]])
        y = lin.y - lin.a_n @ delta
        weighted = prior_prec.copy()
        weighted[:2, :2] *= _prior_weight(x, prior_mean, prior_prec)
        for _ in range(NOISE_ROUNDS):
            dx, cov, resid, dof = _solve(y, lin.var_scan, tau2, jac, lin.rigid, weighted,
                                         weighted @ (prior_mean - x))
            tau2 = max(float(np.sum(resid ** 2 - lin.var_scan)) / dof, TAU_FLOOR ** 2)
        x = x + dx[:k + 2]
        sd = np.sqrt(np.maximum(np.diag(cov[:k + 2, :k + 2]), 1e-300))
        if np.max(np.abs(dx[:k + 2]) / sd) < INNER_TOL:
            break
    else:
        log.warning("as-built update: the inner Gauss-Newton over Equation 3 stopped after %d steps, the last "
                    "%.3g posterior sd (tolerance %g)", INNER_ITER, float(np.max(np.abs(dx[:k + 2]) / sd)), INNER_TOL)
    joint = cov[:k + 2, :k + 2]
    return _marginal_mode(design, lin, x, joint, tau2, prior_prec[2:, 2:]), joint, resid, tau2, inner


def _half_logdet_errors(design, lin: _Linear, theta, error, tau2, prior_prec_e, frozen, d_e_frozen) -> float:
    """½ log det H_ee: the Gauss–Newton precision of the string errors e with θ held, the rigid motion
    marginalized, at (θ, e); the strings ``frozen`` (k,) keep their slopes ``d_e_frozen``."""
    d_e = np.where(frozen, d_e_frozen, error_slope(design, theta, error))
    _, d_delta = lin.effective(world_strings(design, theta[0], theta[1], cut_error=error).rest)
    w = 1.0 / (tau2 + lin.var_scan)
    m = (lin.a_n @ d_delta) * d_e[None, :]
    h = (m * w[:, None]).T @ m + prior_prec_e
    if lin.rigid.shape[1]:
        mg = (m * w[:, None]).T @ lin.rigid
        h -= mg @ np.linalg.solve((lin.rigid * w[:, None]).T @ lin.rigid, mg.T)
    return 0.5 * float(np.linalg.slogdet(h)[1])


def _marginal_mode(design, lin: _Linear, x, joint, tau2, prior_prec_e) -> np.ndarray:
    """From the joint MAP x (k + 2,) of (θ, e) to the mode of θ's marginal posterior: one Newton step.

    With one error per string, the joint MAP's θ is biased by the chain's curvature in e (the
    Neyman–Scott effect: maximising over k nuisance parameters instead of integrating them out). The
    Laplace marginal of θ is the joint's profile minus ½ log det H_ee(θ) (H_ee: the precision of e
    given θ, which depends on θ through ∂rest/∂e at ê(θ)); at the joint MAP the profile's gradient
    vanishes, so the marginal mode is one step θ ← θ − Σ_θθ ∇(½ log det H_ee) away, the errors moved
    with it by their conditional mean Σ_eθ Σ_θθ⁻¹ Δθ. ∇ is a central difference along ê(θ) (each
    evaluation a k × k determinant). A string within 3 prior sd of its error from Equation 3's clip
    (slack, or at the largest curvature: ∂rest/∂e drops to 0 there) keeps its slope: the Laplace
    approximation does not hold across that kink, and its jump would dominate the gradient. On vault2
    with ±3 mm cuts and the face known, the joint MAP misses a world at the prior's mean by 1.5
    posterior sd in Δ and in d, the marginal mode by under 0.1 sd (``tests/asbuilt/test_update.py``).
    """
    c_tt = joint[:2, :2]
    slope = joint[2:, :2] @ np.linalg.inv(c_tt)           # E[e | θ] per unit of θ
    reach = 3.0 / np.sqrt(np.diag(prior_prec_e))
    d_e_hat = error_slope(design, x[:2], x[2:])
    frozen = np.abs(d_e_hat) < CLIPPED_SLOPE
    for sign in (-1.0, 1.0):
        frozen |= np.abs(error_slope(design, x[:2], x[2:] + sign * reach)) < CLIPPED_SLOPE
    grad = np.zeros(2)
    for j in range(2):
        h = np.zeros(2)
        h[j] = 1e-3 * np.sqrt(c_tt[j, j])
        up, down = (_half_logdet_errors(design, lin, x[:2] + sg * h, x[2:] + sg * (slope @ h), tau2, prior_prec_e,
                                        frozen, d_e_hat) for sg in (1.0, -1.0))
        grad[j] = (up - down) / (2 * h[j])
    step = -c_tt @ grad
    return np.concatenate([x[:2] + step, x[2:] + slope @ step])


def known_face_update(design, rest, *, cut_tolerance: float = 0.003, cut_distribution: str = "uniform",
                      rest_sd: float = 1e-6) -> tuple:
    """The update's posterior of (Δ, d, e) when the face, hence every string's rest length, is known exactly.

    The limit :func:`update` reaches on a scan without noise of a face the model makes exactly: the same
    prior and chain (:func:`world_strings`), each rest length observed with standard deviation ``rest_sd``
    (a slack string's rest length does not depend on its error and tells nothing). No inflation: the
    statistics of the update alone, cheap enough to measure the intervals' coverage over many cut-error
    draws (``bench/bench_correct.py``).

    Parameters
    ----------
    design : airmat.design.pipeline.DesignResult
    rest : ndarray of shape (k,)
        The simulated rest lengths of the world (m).
    cut_tolerance, cut_distribution
        The prior of e, as :func:`update`'s.
    rest_sd : float
        Standard deviation of each observed rest length (m).

    Returns
    -------
    tuple of ndarray
        The MAP (k + 2,) of (Δ, d, e_1 .. e_k) (m) and its covariance (k + 2, k + 2) (m²).
    """
    k = len(design.pattern.strings)
    rest = np.asarray(rest, float)
    if rest.shape != (k,):
        raise InputError(f"rest lengths: expected shape ({k},), got {rest.shape}")
    mean0, cov0, s = _prior(design, cut_tolerance, cut_distribution)
    prior_prec = block_diag(np.linalg.inv(cov0), np.diag(1.0 / s ** 2))
    cal = design.calibration
    x0 = np.concatenate([[cal.delta_median, float(np.median(cal.d))], np.zeros(k)])
    rest0 = world_strings(design, x0[0], x0[1], cut_error=x0[2:]).rest
    lin = _Linear(y=rest - rest0, var_scan=np.full(k, rest_sd ** 2), a_n=np.eye(k), rigid=np.zeros((k, 0)),
                  rest=rest0)
    x, cov, _, _, _ = _map(design, lin, x0, np.concatenate([mean0, np.zeros(k)]), prior_prec, rest_sd ** 2, k)
    return x, cov


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
    """``point`` with its face Jacobian and its strings' slack reach (:func:`slack_reach`)."""
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
    mean0, cov0, s = _prior(design, cut_tolerance, cut_distribution)
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
        rms_before = float(np.sqrt(np.mean(_linearisation(first, faces, points)[1].y ** 2)))
        tau2 = max(start.noise_sd ** 2, TAU_FLOOR ** 2)
        point = start.prediction     # converged when the MAP at its linearisation point stays there
        x = np.concatenate([point.theta, point.error])
    names = ("delta", "d") + tuple(f"string {st.dash.id}" for st in design.pattern.strings)
    raised = False                 # the last step raised the objective and was not taken
    stationary = None              # (misfit, scatter) (m) where steps from the accepted point raise the
                                   # objective down to STEP_TOL
    best = None                    # the accepted linearisation: (its point's parameters, _Linear, ScanData, point)
    sd = None                      # the posterior sd of the last MAP (set with ``best``)
    with residual_progress(STEP_TOL, desc="as-built update (step in posterior sd)") as bar:
        for it in range(max_relinearisations + 1):
            data, lin = _linearisation(point, faces, points)
            at = np.concatenate([point.theta, point.error])
            if rms_before is None:
                rms_before = float(np.sqrt(np.mean(lin.y ** 2)))
                tau2 = rms_before ** 2
            elif best is not None and (_objective(lin, at, prior_mean, prior_prec, tau2)
                                       > _objective(best[1], best[0], prior_mean, prior_prec, tau2)):
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
            x, joint, resid, tau2, inner = _map(design, lin, x, prior_mean, prior_prec, tau2, k)
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
