"""Bayesian posterior of Equation 3's slip Delta and thickness d from measured curvatures.

Each specimen i (string length ``l_i`` between ends a geodesic distance
``L_i`` apart) was scanned and fitted to a cylinder of curvature ``kappa_i``
with standard error ``s_i``. The model is

    kappa_i = | kappa1(l_i, L_i; Delta, d) + e_i |,   e_i ~ Normal(0, s_i**2 + sigma**2),

where ``sigma`` (1/m) is the specimen-to-specimen scatter the fit errors do
not explain (string tension, pressure, how the specimen was tied). The
absolute value is there because a cylinder fit returns ``kappa >= 0``: the
likelihood is a folded normal, which only matters for flat specimens
(``l >= L - 2 Delta``, model ``kappa1 = 0``), whose small positive fitted
curvatures then carry the right weight. Flat specimens bound Delta from
below: a smaller Delta, ``Delta < (L - l) / 2``, would bend them.

Priors (independent; the log-probability is ``-inf`` outside the bounds and
the model is not evaluated there):

- ``Delta ~ Uniform(0, 0.2 * min(L))``: the slip of each string end is
  non-negative and well below the string spacing (paper: 18 mm at L = 300 mm);
- ``d ~ Uniform(5 mm, 500 mm)``: any plausible drop-stitch thickness
  (paper: 70 mm);
- ``sigma ~ HalfCauchy(scale 1 1/m)`` truncated to ``[0, 20 1/m]``: weakly
  informative, most mass below a few 1/m (the curvatures of interest are
  0-15 1/m).

The posterior is sampled with emcee's ensemble sampler (differential-evolution
move), vectorized (one Equation 3 call evaluates a batch of walkers x all
specimens), started in a Gaussian ball around the least-squares optimum and
run in chunks until the chain is at least ``tau_multiple`` (50) integrated
autocorrelation times long or ``max_steps`` is reached.
"""

from __future__ import annotations

import logging
from dataclasses import dataclass, field

import numpy as np

from airmat.errors import InputError
from airmat.progress import progress
from airmat.calib.likelihood import (DEFAULT_PRIORS, PARAM_NAMES, Priors, SpecimenData,
                              log_probability, specimen_data)
from airmat.calib.model import kappa1

__all__ = ["Priors", "DEFAULT_PRIORS", "SpecimenData", "Posterior", "ParamSummary",
           "PARAM_NAMES", "specimen_data", "log_probability", "least_squares_start",
           "check_sampler_options", "sample_posterior"]

log = logging.getLogger(__name__)


@dataclass(frozen=True)
class ParamSummary:
    """Posterior median and central 95% interval of one parameter (SI units)."""

    median: float
    lo95: float
    hi95: float

    @classmethod
    def of(cls, x: np.ndarray) -> "ParamSummary":
        lo, med, hi = np.percentile(x, [2.5, 50.0, 97.5])
        return cls(median=float(med), lo95=float(lo), hi95=float(hi))


@dataclass(frozen=True)
class Posterior:
    """Result of :func:`sample_posterior`.

    Attributes
    ----------
    samples : ndarray of shape (n, 3)
        Flat posterior draws ``(Delta [m], d [m], sigma [1/m])`` after burn-in and thinning.
    log_prob : ndarray of shape (n,)
        Log posterior of each draw.
    delta, d, sigma : ParamSummary
        Median and 95% interval (m, m, 1/m).
    start : ndarray of shape (3,)
        Least-squares optimum the walkers started around.
    tau : ndarray of shape (3,)
        Integrated autocorrelation time (steps) of each coordinate the walkers
        move in: Delta, d and log sigma.
    acceptance_fraction : float
        Mean acceptance fraction of the walkers.
    n_steps, n_walkers, burn, thin : int
        Chain length (steps), ensemble size, discarded steps, thinning.
    converged : bool
        Whether ``n_steps >= tau_multiple * max(tau)``.
    n_iter : int
        Same as ``n_steps``.
    residual : float
        ``tau_multiple * max(tau) / n_steps``: <= 1 when converged.
    message : str
        What happened, in words.
    priors : Priors
        The priors used.
    """

    samples: np.ndarray
    log_prob: np.ndarray
    delta: ParamSummary
    d: ParamSummary
    sigma: ParamSummary
    start: np.ndarray
    tau: np.ndarray
    acceptance_fraction: float
    n_steps: int
    n_walkers: int
    burn: int
    thin: int
    converged: bool
    n_iter: int
    residual: float
    message: str
    priors: Priors = field(default=DEFAULT_PRIORS)


def least_squares_start(data: SpecimenData, bounds: np.ndarray):
    """Weighted least-squares optimum of (Delta, d), a scatter estimate and a covariance.

    Returns
    -------
    x0 : ndarray of shape (3,)
        ``(Delta [m], d [m], sigma [1/m])`` strictly inside ``bounds``.
    cov : ndarray of shape (3, 3)
        Gaussian approximation of the posterior covariance around ``x0``.
    """
    from scipy.optimize import least_squares

    lo, hi = bounds[:2, 0], bounds[:2, 1]
    span = hi - lo
    sigma = 0.0
    x = lo + np.array([0.3, 0.2]) * span  # Delta ~ 0.06 L, d ~ 0.1 m: mid-range guesses
    for _ in range(2):  # fit with the scatter, re-estimate the scatter, refit
        w = 1.0 / np.sqrt(data.kappa_se ** 2 + sigma ** 2)

        def resid(p, w=w):
            return (kappa1(data.l, data.L, p[0], p[1]) - data.kappa) * w

        res = least_squares(resid, x, bounds=(lo, hi), x_scale=span * 0.1)
        x = res.x
        r = kappa1(data.l, data.L, x[0], x[1]) - data.kappa
        dof = max(data.kappa.size - 2, 1)
        sigma = float(np.sqrt(max(np.sum(r ** 2) / dof - np.mean(data.kappa_se ** 2), 0.0)))
    sigma = min(max(sigma, 0.1 * float(np.median(data.kappa_se))), 0.5 * bounds[2, 1])
    jac = res.jac
    try:
        cov2 = np.linalg.inv(jac.T @ jac)
    except np.linalg.LinAlgError:
        cov2 = np.diag((span * 1e-2) ** 2)
    cov = np.zeros((3, 3))
    cov[:2, :2] = cov2
    cov[2, 2] = (0.3 * sigma) ** 2 if sigma > 0 else 1e-4
    x0 = np.clip(np.array([x[0], x[1], sigma]), bounds[:, 0] + 1e-6 * np.ptp(bounds, axis=1),
                 bounds[:, 1] - 1e-6 * np.ptp(bounds, axis=1))
    return x0, cov


def _initial_ball(x0, cov, bounds, n_walkers, rng, logp) -> np.ndarray:
    """n_walkers distinct starting points near x0 with finite log-probability."""
    width = np.ptp(bounds, axis=1)
    std = np.sqrt(np.clip(np.diag(cov), (1e-4 * width) ** 2, (0.05 * width) ** 2))
    corr = cov / np.sqrt(np.outer(np.diag(cov), np.diag(cov)) + 1e-300)
    corr = np.where(np.isfinite(corr), corr, 0.0)
    np.fill_diagonal(corr, 1.0)
    cov = 0.25 * corr * np.outer(std, std)  # half the posterior width: a ball inside the bulk
    for _ in range(20):
        cand = rng.multivariate_normal(x0, cov, size=4 * n_walkers, check_valid="ignore")
        ok = np.isfinite(logp(cand))
        if ok.sum() >= n_walkers:
            return cand[ok][:n_walkers]
        cov = cov * 0.1
    raise InputError("could not place the walkers inside the prior bounds around the "
                     f"least-squares start {x0.tolist()}", start=x0)


def _summarize(tau, n_steps, tau_multiple):
    tau_max = float(np.max(tau))
    residual = tau_multiple * tau_max / n_steps
    return tau_max, residual, residual <= 1.0


def check_sampler_options(n_walkers: int, max_steps: int) -> None:
    """Raise InputError for an ensemble smaller than 6 walkers or a step cap below 1."""
    if n_walkers < 2 * len(PARAM_NAMES):
        raise InputError(f"--walkers {n_walkers}: need at least {2 * len(PARAM_NAMES)} "
                         f"(twice the number of parameters)", n_walkers=n_walkers)
    if max_steps < 1:
        raise InputError(f"--max-steps {max_steps}: need at least 1", max_steps=max_steps)


def sample_posterior(data: SpecimenData, *, priors: Priors = DEFAULT_PRIORS, n_walkers: int = 32,
                     max_steps: int = 4000, chunk: int = 100, tau_multiple: float = 50.0,
                     seed=0) -> Posterior:
    """Sample the posterior of (Delta, d, sigma) with emcee.

    Parameters
    ----------
    data : SpecimenData
        Measured curvatures (1/m) and string geometry (m) of S >= 3 specimens
        (:func:`specimen_data`).
    priors : Priors
        Prior bounds (see the module docstring).
    n_walkers : int
        Ensemble size, >= 6 (twice the number of parameters).
    max_steps : int
        Cap on the chain length (steps per walker).
    chunk : int
        Steps between convergence checks.
    tau_multiple : float
        Required chain length in integrated autocorrelation times.
    seed : int or numpy.random.Generator
        Seeds the initial ball and emcee's internal generator; the same seed
        gives identical samples.

    Notes
    -----
    emcee's differential-evolution move (``DEMove``) mixes about twice as fast
    as the default stretch move here (integrated autocorrelation times of
    11-16 steps against 30-35 on 12 specimens, sampling log sigma), so about
    600-900 steps of 32 walkers reach 50 tau. Each step evaluates Equation 3 twice (once per half
    ensemble) on a (16, S) batch; ``airmat.calib.model.kappa1`` costs 0.25-0.5 ms per (16, 12) call
    (``bench/bench_calibration.py``), so the model takes under a second of the run (the whole
    MCMC of 32 walkers x 700 steps: 1.2 s on the 2-core reference machine).

    Returns
    -------
    Posterior
        Samples with burn-in (``ceil(3 tau_max)`` steps) discarded and thinned by
        ``max(1, floor(tau_min / 2))``; ``converged`` False (and a warning
        logged) when ``max_steps`` ran out first.
    """
    import emcee

    from airmat.interrupt import deferred_interrupt

    check_sampler_options(n_walkers, max_steps)
    rng = np.random.default_rng(seed)
    bounds = priors.bounds(float(np.min(data.L)))
    args = (data, bounds, priors.sigma_scale)
    x0, cov = least_squares_start(data, bounds)
    p0 = _initial_ball(x0, cov, bounds, n_walkers, rng,
                       lambda t: np.where(t[:, 2] > 0, log_probability(t, *args), -np.inf))
    p0[:, 2] = np.log(p0[:, 2])  # the walkers move in (Delta, d, log sigma)
    state = emcee.State(p0, random_state=np.random.RandomState(rng.integers(2**32)).get_state())
    sampler = emcee.EnsembleSampler(n_walkers, len(PARAM_NAMES), _log_prob_log_sigma, args=args,
                                    vectorize=True, moves=emcee.moves.DEMove())
    tau = np.full(len(PARAM_NAMES), np.inf)
    # Ctrl-C waits for the end of a chunk: inside emcee it would print its likelihood wrapper's traceback
    with progress(total=max_steps, desc="sampling", unit="step") as bar, deferred_interrupt() as pending:
        while sampler.iteration < max_steps:
            n = min(chunk, max_steps - sampler.iteration)
            state = sampler.run_mcmc(state, n, progress=False)
            pending.check()
            bar.update(n)
            tau = sampler.get_autocorr_time(tol=0)
            tau_max, residual, done = _summarize(tau, sampler.iteration, tau_multiple)
            bar.set_postfix_str(f"tau {tau_max:.0f}, need {tau_multiple * tau_max:.0f} steps")
            if done:
                break
    return _result(sampler, tau, x0, priors, tau_multiple)


def _log_prob_log_sigma(u, data, bounds, sigma_scale):
    """:func:`log_probability` in the sampler's coordinates (Delta, d, log sigma), with the Jacobian.

    A scale parameter mixes better in log space (sigma's autocorrelation time
    drops by about a fifth), and sigma > 0 holds by construction.
    """
    theta = np.array(u, dtype=float)
    theta[:, 2] = np.exp(theta[:, 2])
    return log_probability(theta, data, bounds, sigma_scale) + u[:, 2]


def _result(sampler, tau, x0, priors, tau_multiple) -> Posterior:
    n_steps = sampler.iteration
    tau_max, residual, converged = _summarize(tau, n_steps, tau_multiple)
    burn = min(int(np.ceil(3 * tau_max)), n_steps // 2)
    thin = max(1, int(np.min(tau) // 2))
    samples = sampler.get_chain(discard=burn, thin=thin, flat=True).copy()
    logp = sampler.get_log_prob(discard=burn, thin=thin, flat=True) - samples[:, 2]  # no Jacobian
    samples[:, 2] = np.exp(samples[:, 2])
    acc = float(np.mean(sampler.acceptance_fraction))
    if converged:
        message = (f"converged: {n_steps} steps = {n_steps / tau_max:.0f} autocorrelation times "
                   f"(tau {np.round(tau, 1).tolist()})")
    else:
        message = (f"NOT converged: {n_steps} steps are only {n_steps / tau_max:.0f} autocorrelation "
                   f"times (tau {np.round(tau, 1).tolist()}), {tau_multiple:.0f} needed: raise "
                   f"--max-steps to at least {int(np.ceil(tau_multiple * tau_max))}")
        log.warning("MCMC %s; the intervals are unreliable", message)
    return Posterior(samples=samples, log_prob=logp,
                     delta=ParamSummary.of(samples[:, 0]), d=ParamSummary.of(samples[:, 1]),
                     sigma=ParamSummary.of(samples[:, 2]), start=x0, tau=np.asarray(tau, float),
                     acceptance_fraction=acc, n_steps=n_steps, n_walkers=sampler.nwalkers,
                     burn=burn, thin=thin, converged=converged, n_iter=n_steps,
                     residual=residual, message=message, priors=priors)
