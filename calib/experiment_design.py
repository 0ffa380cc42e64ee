"""Which specimens to build and scan next: Bayesian experimental design on the calibration posterior.

A new specimen at string-length ratio ``x = l / L`` would be measured as
``y = |kappa1(x L, L; Delta, d) + e|``, ``e ~ Normal(0, s**2 + sigma**2)``
(the likelihood of :mod:`airmat.calib.likelihood`, with ``s`` the cylinder
fit's standard error and ``sigma`` the specimen scatter of each posterior
draw). Its value is judged before it is built (preposterior analysis): one
posterior draw plays the truth, a measurement is simulated from it, the
other draws are reweighted by that measurement's likelihood (importance
sampling, the drawn truth left out so that it does not vouch for itself),
and the target quantity of the reweighted posterior is averaged over many
such simulations. Two targets:

- ``"area"``: the 95 % credible area of (Delta, d), ``pi chi2_2(0.95) sqrt(det C)``
  with ``C`` the 2 x 2 posterior covariance (m**2; the ellipse of a normal posterior);
- ``"band"``: a design's strings' 95 % length band, ``2 x 1.96`` posterior
  standard deviations of each string's length through Equation 3 at its
  curvature and span, averaged over the strings (m).

Everything is vectorized over (simulations, candidates, draws): one Equation 3
call for all draws x candidates, one likelihood array per greedy step. The N
specimens are chosen greedily: step k scores every candidate jointly with the
k - 1 already chosen (the same simulated truths and noise, so the earlier
specimens' simulated measurements carry over), and the candidate with the
smallest expected target is taken; a ratio may be chosen again (several
scans there). The same simulations score N evenly spaced ratios, the plan's
baseline. SI units: metres, 1/m.
"""

from __future__ import annotations

import logging
from dataclasses import dataclass

import numpy as np

from airmat.errors import InputError
from airmat.summary import Summarized
from airmat.calib.model import kappa1, kappa_max, string_length
from airmat.calib.likelihood import folded_normal_logpdf

__all__ = ["TARGETS", "DEFAULT_L_OVER_L", "SpecimenPlan", "credible_area", "design_strings", "string_lengths",
           "plan_specimens", "plan"]

log = logging.getLogger(__name__)

#: what the plan shrinks: the (Delta, d) credible area or a design's string-length band
TARGETS = ("area", "band")
#: candidate string-length ratios l/L: a specimen at each, from strongly bent to flat
DEFAULT_L_OVER_L = tuple(np.round(np.arange(0.30, 0.9501, 0.025), 3).tolist())
#: chi-square quantile with 2 degrees of freedom at 95 %: the 95 % ellipse of a 2-D normal
_CHI2_2_95 = -2.0 * np.log(0.05)
#: half-width of a normal 95 % interval in standard deviations
_Z95 = 1.959963984540054
#: below this mean effective sample size the reweighted posteriors are coarse (logged)
_MIN_ESS = 30.0
#: numbers per (simulations, candidates, draws) block: a few such arrays stay within tens of MB
_BLOCK = 1 << 20


@dataclass(frozen=True, repr=False)
class SpecimenPlan(Summarized):
    """Result of :func:`plan_specimens`.

    Attributes
    ----------
    l_over_L : ndarray of shape (N,)
        The proposed string-length ratios, in the order chosen.
    predicted : ndarray of shape (N + 1,)
        Expected target now (entry 0) and after the first 1 ... N proposed specimens
        (m**2 for ``"area"``, m for ``"band"``).
    even_l_over_L : ndarray of shape (N,)
        N evenly spaced ratios over the candidates' range (the baseline).
    even : ndarray of shape (N + 1,)
        Expected target with k evenly spaced ratios (``linspace(lo, hi, k)``; k = 1:
        the middle), k = 0 ... N.
    candidates : ndarray of shape (C,)
        The ratios scored.
    scores : ndarray of shape (N, C)
        Expected target after adding each candidate at each greedy step.
    ess : ndarray of shape (N,)
        Mean effective sample size of the reweighted draws after each step.
    target : str
        ``"area"`` or ``"band"``.
    L : float
        String-end distance of the new specimens (m).
    kappa_se : float
        Standard error of a new specimen's fitted curvature (1/m).
    sigma : float
        Posterior median of the specimen scatter (1/m).
    n_draws, n_sims, seed : int
        Posterior draws reweighted, simulated measurements per candidate, seed.
    """

    l_over_L: np.ndarray
    predicted: np.ndarray
    even_l_over_L: np.ndarray
    even: np.ndarray
    candidates: np.ndarray
    scores: np.ndarray
    ess: np.ndarray
    target: str
    L: float
    kappa_se: float
    sigma: float
    n_draws: int
    n_sims: int
    seed: int

    @property
    def counts(self) -> dict:
        """Scans per distinct proposed ratio, ``{l/L: n}``, in the order first chosen."""
        out: dict = {}
        for x in self.l_over_L:
            out[float(x)] = out.get(float(x), 0) + 1
        return out

    def _summary(self):
        scale, unit = (1e6, "mm²") if self.target == "area" else (1e3, "mm")
        plan = ", ".join(f"{x:g}" + (f" ×{n}" if n > 1 else "") for x, n in self.counts.items())
        return "SpecimenPlan", [("l/L", plan), (self.target, f"{self.predicted[0] * scale:.3g} → "
                                                f"{self.predicted[-1] * scale:.3g} {unit}"),
                                ("evenly spaced", f"{self.even[-1] * scale:.3g} {unit}")]


def credible_area(delta_d, weights=None) -> np.ndarray:
    """95 % credible area (m**2) of (Delta, d) from draws, as the normal ellipse ``pi chi2 sqrt(det C)``.

    Parameters
    ----------
    delta_d : ndarray of shape (n, 2)
        Draws of (Delta, d) (m).
    weights : ndarray of shape (..., n), optional
        Non-negative weights of the draws (normalized here); default equal.

    Returns
    -------
    ndarray of shape (...)
        The area (m**2) for every row of weights; a scalar array without weights.

    Examples
    --------
    >>> rng = np.random.default_rng(0)
    >>> x = rng.normal(size=(200_000, 2)) * [0.001, 0.002]      # sd 1 mm and 2 mm
    >>> round(float(credible_area(x)) / (np.pi * 5.991 * 2e-6), 2)
    1.0
    """
    x = np.asarray(delta_d, float)
    if x.ndim != 2 or x.shape[1] != 2:
        raise InputError(f"delta_d must have shape (n, 2), got {x.shape}")
    x = x - x.mean(axis=0)     # centred: the covariance of nearly equal draws keeps its digits
    w = np.full(x.shape[0], 1.0 / x.shape[0]) if weights is None else np.asarray(weights, float)
    w = w / w.sum(axis=-1, keepdims=True)
    m = w @ x                                                    # (..., 2)
    c = np.einsum("...n,ni,nj->...ij", w, x, x) - m[..., :, None] * m[..., None, :]
    det = np.maximum(c[..., 0, 0] * c[..., 1, 1] - c[..., 0, 1] ** 2, 0.0)
    return np.pi * _CHI2_2_95 * np.sqrt(det)


def string_lengths(kappa_abs, span, delta, d) -> np.ndarray:
    """Each string's length (m) under each posterior draw; a draw that cannot reach |κ| gives l = 0.

    Parameters
    ----------
    kappa_abs, span : ndarray of shape (J,)
        |κ| (1/m) and Equation 3's span L (m) of each string.
    delta, d : ndarray of shape (n,)
        Posterior draws (m).

    Returns
    -------
    ndarray of shape (n, J)
    """
    k, L = np.asarray(kappa_abs, float)[None, :], np.asarray(span, float)[None, :]
    delta, d = np.asarray(delta, float)[:, None], np.asarray(d, float)[:, None]
    kmax = kappa_max(L, delta, d)
    return np.where(k > kmax, 0.0, string_length(np.minimum(k, kmax), L, delta, d))


def design_strings(design):
    """|κ| (1/m) and span (m) of a design's strings: arrays of shape (J,).

    Takes an :class:`airmat.design.pipeline.DesignResult` (or anything whose
    ``pattern.strings`` have ``kappa`` and ``eq3_span``).
    """
    strings = getattr(getattr(design, "pattern", None), "strings", None)
    if not strings:
        raise InputError("the design has no strings: nothing to plan for (use the credible area instead)")
    return (np.array([abs(float(s.kappa)) for s in strings]), np.array([float(s.eq3_span) for s in strings]))


def _weights(logw):
    """Normalized weights and their effective sample size along the last axis."""
    w = np.exp(logw - logw.max(axis=-1, keepdims=True))
    w /= w.sum(axis=-1, keepdims=True)
    return w, 1.0 / np.sum(w * w, axis=-1)


def _target_fn(target, delta_d, lengths):
    if target == "area":
        return lambda w: credible_area(delta_d, w)
    centred = lengths - lengths.mean(axis=0)

    def band(w):   # mean over strings of the 95 % width, 2 z sqrt(Var l)
        m1, m2 = w @ centred, w @ (centred * centred)
        return (2.0 * _Z95 * np.sqrt(np.maximum(m2 - m1 * m1, 0.0))).mean(axis=-1)

    return band


def _check(samples, L, n_add, candidates, kappa_se, target, strings):
    samples = np.asarray(samples, float)
    if samples.ndim != 2 or samples.shape[1] != 3 or samples.shape[0] < 10:
        raise InputError(f"samples must have shape (n >= 10, 3) (Delta, d, sigma), got {samples.shape}")
    if not np.all(np.isfinite(samples[:, :2])):
        raise InputError("the posterior samples of Delta and d must be finite")
    if not np.all(np.isfinite(samples[:, 2]) & (samples[:, 2] >= 0)):
        raise InputError("the calibration has no samples of the specimen scatter sigma (1/m): "
                         "a new specimen's measurement noise is unknown")
    if not (np.isfinite(L) and L > 0):
        raise InputError(f"L must be a length > 0 m, got {L!r}")
    if int(n_add) != n_add or n_add < 1:
        raise InputError(f"the number of specimens to add must be an integer >= 1, got {n_add!r}")
    c = np.asarray(candidates, float)
    if c.ndim != 1 or c.size < 2 or not np.all((c > 0) & (c <= 1)):
        raise InputError(f"candidate ratios l/L must be at least 2 values in (0, 1], got {c.tolist()}")
    if not (np.isfinite(kappa_se) and kappa_se >= 0):
        raise InputError(f"kappa_se must be >= 0 1/m, got {kappa_se!r}")
    if target not in TARGETS:
        raise InputError(f"target must be one of {TARGETS}, got {target!r}")
    if target == "band" and strings is None:
        raise InputError("target 'band' needs the design's strings")
    return samples, np.unique(c)


def plan_specimens(samples, *, L: float, n_add: int = 4, candidates=DEFAULT_L_OVER_L, kappa_se: float = 0.0,
                   target: str = "area", strings=None, n_draws: int = 2000, n_sims: int = 64,
                   seed=0) -> SpecimenPlan:
    """Greedy Bayesian experimental design: the next ``n_add`` specimens' ratios l/L.

    Parameters
    ----------
    samples : ndarray of shape (n, 3)
        Posterior draws (Delta [m], d [m], sigma [1/m]), e.g. ``Calibration.posterior.samples``.
    L : float
        String-end distance of the new specimens (m).
    n_add : int
        Specimens to propose (>= 1).
    candidates : array_like of shape (C,)
        Ratios l/L in (0, 1] to choose from (default 0.30, 0.325, ..., 0.95).
    kappa_se : float
        Standard error of a new specimen's fitted curvature (1/m), added to the scatter sigma.
    target : {"area", "band"}
        Shrink the (Delta, d) credible area or the design strings' length band.
    strings : (ndarray of shape (J,), ndarray of shape (J,)), optional
        |κ| (1/m) and span (m) of the design's strings (:func:`design_strings`); needed for ``"band"``.
    n_draws : int
        Posterior draws reweighted (a random subset when there are more).
    n_sims : int
        Simulated measurements per candidate and step.
    seed : int or numpy.random.Generator
        The same seed gives the same plan.

    Returns
    -------
    SpecimenPlan
    """
    samples, cand = _check(samples, L, n_add, candidates, kappa_se, target, strings)
    rng = np.random.default_rng(seed)
    if samples.shape[0] > n_draws:
        samples = samples[np.sort(rng.choice(samples.shape[0], size=int(n_draws), replace=False))]
    n = samples.shape[0]
    delta, d, sigma = samples.T
    lengths = string_lengths(*strings, delta, d) if target == "band" else None
    score = _target_fn(target, samples[:, :2], lengths)
    var = kappa_se ** 2 + sigma ** 2                                  # (n,)
    truth = rng.integers(n, size=int(n_sims))                         # the draw playing the truth, per simulation
    z = rng.standard_normal((int(n_add), int(n_sims)))               # the k-th new specimen's noise
    self_out = np.zeros((int(n_sims), n))
    self_out[np.arange(int(n_sims)), truth] = -np.inf                 # leave the truth out of its own posterior

    def loglik(mu, k):
        """Log-likelihood (S, ..., n) of the k-th new specimen's simulated measurement; mu of shape (n, ...)."""
        noise = (z[k] * np.sqrt(var[truth])).reshape((-1,) + (1,) * (mu.ndim - 1))
        y = np.abs(mu[truth] + noise)                                 # (S, ...): measured under the drawn truth
        return folded_normal_logpdf(y[..., None], mu.T[None], var)

    mu = kappa1(cand[None, :] * L, L, delta[:, None], d[:, None])     # (n, C): Equation 3 once
    acc = self_out.copy()
    chosen, predicted, ess, scores = [], [float(score(np.full(n, 1.0 / n)))], [], []
    for k in range(int(n_add)):
        s, e = np.empty(cand.size), np.empty((int(n_sims), cand.size))
        for j in _chunks(cand.size, int(n_sims) * n):                 # (S, c, n) blocks of at most _BLOCK
            w, e[:, j] = _weights(acc[:, None, :] + loglik(mu[:, j], k))
            s[j] = score(w).mean(axis=0)
        best = int(np.argmin(s))
        chosen.append(cand[best])
        predicted.append(float(s[best]))
        ess.append(float(e[:, best].mean()))
        scores.append(s)
        acc = acc + loglik(mu[:, best], k)
    even_x, even = _evenly_spaced(cand, int(n_add), L, delta, d, loglik, self_out, score)
    if min(ess) < _MIN_ESS:
        log.warning("the reweighted posteriors rest on %.0f effective draws: the predictions are coarse "
                    "(raise n_draws)", min(ess))
    return SpecimenPlan(l_over_L=np.array(chosen), predicted=np.array(predicted), even_l_over_L=even_x,
                        even=np.array([predicted[0], *even]), candidates=cand, scores=np.array(scores),
                        ess=np.array(ess), target=target, L=float(L), kappa_se=float(kappa_se),
                        sigma=float(np.median(sigma)), n_draws=n, n_sims=int(n_sims),
                        seed=int(seed) if isinstance(seed, (int, np.integer)) else 0)


def _chunks(n_cand: int, per_candidate: int):
    """Slices of the candidates whose (simulations, candidates, draws) arrays hold at most _BLOCK numbers."""
    step = max(1, _BLOCK // per_candidate)
    return [slice(i, min(i + step, n_cand)) for i in range(0, n_cand, step)]


def _even(cand, k: int) -> np.ndarray:
    """k evenly spaced ratios over the candidates' range; one: the middle."""
    return np.linspace(cand[0], cand[-1], k) if k > 1 else np.array([0.5 * (cand[0] + cand[-1])])


def _evenly_spaced(cand, n_add, L, delta, d, loglik, self_out, score):
    """Expected target with k = 1 ... n_add evenly spaced ratios, the same simulations as the plan."""
    out = []
    for k in range(1, n_add + 1):
        mu = kappa1(_even(cand, k)[None, :] * L, L, delta[:, None], d[:, None])   # (n, k)
        acc = self_out + sum(loglik(mu[:, i], i) for i in range(k))
        out.append(float(score(_weights(acc)[0]).mean()))
    return _even(cand, n_add), out


def plan(calibration, *, design=None, n_add: int = 4, candidates=DEFAULT_L_OVER_L, kappa_se: float | None = None,
         n_draws: int = 2000, n_sims: int = 64, seed=0) -> SpecimenPlan:
    """Which specimens to build and scan next to shrink a calibration's uncertainty the most.

    Parameters
    ----------
    calibration : airmat.calib.calibrate.Calibration
        From :func:`airmat.calib.calibrate.calibrate` or :func:`airmat.calib.calibration_io.read_calibration`.
    design : airmat.design.pipeline.DesignResult, optional
        Shrink this design's 95 % string-length band; default: the (Delta, d) credible area.
    n_add : int
        Specimens to propose.
    candidates : array_like of shape (C,)
        Ratios l/L in (0, 1] to choose from.
    kappa_se : float, optional
        Standard error of a new specimen's curvature (1/m); default: the median of the
        calibration's specimens (0 when it lists none).
    n_draws, n_sims, seed
        As in :func:`plan_specimens`.

    Returns
    -------
    SpecimenPlan
        The new specimens share the calibration's L (``calibration.curve.L``).
    """
    if kappa_se is None:
        se = [s.kappa_se for s in calibration.specimens]
        kappa_se = float(np.median(se)) if se else 0.0
    strings = design_strings(design) if design is not None else None
    return plan_specimens(calibration.posterior.samples, L=float(calibration.curve.L), n_add=n_add,
                          candidates=candidates, kappa_se=kappa_se, target="area" if design is None else "band",
                          strings=strings, n_draws=n_draws, n_sims=n_sims, seed=seed)
