"""The Laplace (Gaussian) posterior of (Δ, d) and the strings' errors e, with the face linear in the rest lengths.

At one inflation (a linearisation point), the scan reduced to normal displacements y at the covered
vertices (:mod:`airmat.asbuilt.scan_data`) is modelled as

    y ≈ A_n δ'(rest(θ, e) − rest_j) + G r + ε,

A_n the face Jacobian on the vertex normals, δ' the change of the rest lengths the face feels
(tension-only strings: :func:`slack_reach`, :class:`LinearFace`), rest(θ, e) the exact chain
(:mod:`airmat.asbuilt.chain_slopes`), G r a rigid motion with a flat prior (:func:`rigid_columns`) and
ε ~ N(0, τ² + the points' own scatter). The prior: Student-t on (Δ, d) (:data:`PRIOR_DOF`, scale the
calibration's covariance), Gaussian on e. :func:`map_estimate` finds the MAP by an inner Gauss–Newton
over the exact chain, τ² re-estimated on the way, then moves θ to the mode of its Laplace marginal
(:func:`marginal_mode`). :func:`known_face_update` is the same posterior with every rest length observed
(no inflation): the limit a converged update reaches.

SI units (m, 1/m) throughout.
"""

from __future__ import annotations

import logging
from dataclasses import dataclass

import numpy as np
from scipy.linalg import block_diag

from airmat.asbuilt.chain_slopes import CLIPPED_SLOPE, error_slope, length_prior, world_slopes
from airmat.asbuilt.scan_data import scan_data
from airmat.check.string_world import world_strings
from airmat.design.curvature import vertex_normals
from airmat.errors import InputError
from airmat.inflation.energy import spring_profile

__all__ = ["LinearFace", "linear_face", "slack_reach", "rigid_columns", "solve_gaussian", "map_estimate",
           "map_objective", "marginal_mode", "half_logdet_errors", "prior_term", "prior_weight", "theta_r2",
           "known_face_update", "PRIOR_DOF", "TAU_FLOOR", "NOISE_ROUNDS", "INNER_ITER", "INNER_TOL"]

log = logging.getLogger(__name__)

#: fixed-point rounds of the model-error variance τ² per inner step
NOISE_ROUNDS = 3


#: inner Gauss–Newton steps over the exact chain at most, and their tolerance (posterior sd)
INNER_ITER = 30


INNER_TOL = 1e-3


#: degrees of freedom of the Student-t prior on (Δ, d) (scale: the calibration's covariance). The cylinders'
#: calibration need not hold for the built mattress (another batch, pressure, temperature): where the scan
#: contradicts it, a Gaussian prior would still pull the estimate by its full weight (in the demo's world,
#: 15 calibration sd away along Δ and d's correlation, 3.6 posterior sd off with the face known), a t
#: prior gives way (its weight falls as 1 / r²); where they agree it acts as the calibration
#: (weight (ν + 2) / ν at its mean)
PRIOR_DOF = 4.0


#: the model error's standard deviation is at least this (m): a micrometre, far below any scan's noise
TAU_FLOOR = 1e-6


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


def rigid_columns(xyz: np.ndarray, normal: np.ndarray) -> np.ndarray:
    """(N, 6): the normal component of the three translations and the three rotations about the centroid."""
    p = xyz - xyz.mean(axis=0)
    rot = np.cross(p[:, None, :], np.eye(3)[None, :, :])       # (N, 3 axes, 3): -(axis x p) ... sign is free
    return np.column_stack([normal, np.einsum("nac,nc->na", rot, normal)])


def solve_gaussian(y, var_scan, tau2, jac, rigid, prior_prec, prior_rhs):
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
class LinearFace:
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


def linear_face(point, faces, points) -> tuple:
    """The scan reduced at the prediction and the face's normal Jacobian there: (ScanData, LinearFace).

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
    return data, LinearFace(y=data.observed[c], var_scan=data.point_sd ** 2 / data.weight[c], a_n=a_n,
                         rigid=rigid_columns(point.deviation.aligned, normal)[c], rest=point.rest,
                         reach=point.reach, give=point.give)


def theta_r2(x, prior_mean, prior_prec) -> float:
    """r²: (Δ, d)'s squared Mahalanobis distance from the calibration's mean under its precision."""
    d = x[:2] - prior_mean[:2]
    return float(d @ prior_prec[:2, :2] @ d)


def prior_weight(x, prior_mean, prior_prec) -> float:
    """w = (ν + 2) / (ν + r²): the Student-t prior's weight on (Δ, d)'s Gaussian precision at x (IRLS),
    ν = :data:`PRIOR_DOF`."""
    return (PRIOR_DOF + 2.0) / (PRIOR_DOF + theta_r2(x, prior_mean, prior_prec))


def prior_term(x, prior_mean, prior_prec) -> float:
    """The prior's negative log density (up to a constant): Student-t on (Δ, d), Gaussian on the errors."""
    e = x[2:] - prior_mean[2:]
    return (0.5 * (PRIOR_DOF + 2.0) * np.log1p(theta_r2(x, prior_mean, prior_prec) / PRIOR_DOF)
            + 0.5 * float(e @ prior_prec[2:, 2:] @ e))


def map_objective(lin: LinearFace, x, prior_mean, prior_prec, tau2) -> float:
    """The MAP objective at the linearisation's own point x (k + 2,): half the weighted squared misfit of the
    scan from that inflation after the best rigid motion, plus the prior's negative log density (:func:`prior_term`)."""
    root = 1.0 / np.sqrt(tau2 + lin.var_scan)
    g, y = lin.rigid * root[:, None], lin.y * root
    r = y - g @ np.linalg.lstsq(g, y, rcond=None)[0]
    return 0.5 * float(r @ r) + prior_term(x, prior_mean, prior_prec)


def map_estimate(design, lin: LinearFace, x0, prior_mean, prior_prec, tau2, k):
    """The MAP of (θ, e) under the face linear in the rest lengths and the exact chain rest(θ, e).

    Inner Gauss–Newton: the chain (:func:`~airmat.check.string_world.world_strings`, Equation 3) is cheap and evaluated exactly,
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
        weighted[:2, :2] *= prior_weight(x, prior_mean, prior_prec)
        for _ in range(NOISE_ROUNDS):
            dx, cov, resid, dof = solve_gaussian(y, lin.var_scan, tau2, jac, lin.rigid, weighted,
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
    return marginal_mode(design, lin, x, joint, tau2, prior_prec[2:, 2:]), joint, resid, tau2, inner


def half_logdet_errors(design, lin: LinearFace, theta, error, tau2, prior_prec_e, frozen, d_e_frozen) -> float:
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


def marginal_mode(design, lin: LinearFace, x, joint, tau2, prior_prec_e) -> np.ndarray:
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
        up, down = (half_logdet_errors(design, lin, x[:2] + sg * h, x[2:] + sg * (slope @ h), tau2, prior_prec_e,
                                        frozen, d_e_hat) for sg in (1.0, -1.0))
        grad[j] = (up - down) / (2 * h[j])
    step = -c_tt @ grad
    return np.concatenate([x[:2] + step, x[2:] + slope @ step])


def known_face_update(design, rest, *, cut_tolerance: float = 0.003, cut_distribution: str = "uniform",
                      rest_sd: float = 1e-6) -> tuple:
    """The update's posterior of (Δ, d, e) when the face, hence every string's rest length, is known exactly.

    The limit :func:`~airmat.asbuilt.update.update` reaches on a scan without noise of a face the model makes exactly: the same
    prior and chain (:func:`~airmat.check.string_world.world_strings`), each rest length observed with standard deviation ``rest_sd``
    (a slack string's rest length does not depend on its error and tells nothing). No inflation: the
    statistics of the update alone, cheap enough to measure the intervals' coverage over many cut-error
    draws (``bench/bench_correct.py``).

    Parameters
    ----------
    design : airmat.design.pipeline.DesignResult
    rest : ndarray of shape (k,)
        The simulated rest lengths of the world (m).
    cut_tolerance, cut_distribution
        The prior of e, as :func:`~airmat.asbuilt.update.update`'s.
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
    mean0, cov0, s = length_prior(design, cut_tolerance, cut_distribution)
    prior_prec = block_diag(np.linalg.inv(cov0), np.diag(1.0 / s ** 2))
    cal = design.calibration
    x0 = np.concatenate([[cal.delta_median, float(np.median(cal.d))], np.zeros(k)])
    rest0 = world_strings(design, x0[0], x0[1], cut_error=x0[2:]).rest
    lin = LinearFace(y=rest - rest0, var_scan=np.full(k, rest_sd ** 2), a_n=np.eye(k), rigid=np.zeros((k, 0)),
                  rest=rest0)
    x, cov, _, _, _ = map_estimate(design, lin, x0, np.concatenate([mean0, np.zeros(k)]), prior_prec, rest_sd ** 2, k)
    return x, cov
