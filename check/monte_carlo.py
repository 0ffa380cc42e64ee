"""Tolerance as a distribution: the string lengths of K Monte-Carlo samples and what the runs say.

A built mattress differs from the design because its strings do not bend it
exactly as Equation 3's median says: the calibration's (Δ, d) are uncertain
(the posterior), and each real string bends a little differently from the curve,
independently of its neighbours (the scatter σ of the calibration, 1/m).
:func:`draw` samples that, per sample s and string i:

1. (Δ_s, d_s, σ_s): one posterior sample of the design's calibration (drawn
   with replacement, seeded); σ_s = 0 when the calibration has no σ samples
   (the paper's default: ``sigma_source`` says so).
2. κ_s,i = κ₁(l_i; Δ_s, d_s) + σ_s z_s,i, z ~ N(0, 1) independent per string:
   the curvature the string produces, tied at its median length l_i (its
   dash's span L_i), clipped to [0, κ_max] of the design's median (Δ, d).
3. The length that produces κ_s,i under the design's median (Δ̄, d̄), as a
   change from the median: l_s,i = l_i + l(κ_s,i; Δ̄, d̄) − l(κ₁(l_i; Δ̄, d̄); Δ̄, d̄)
   (Equation 3 inverted; written as a change, a sample equal to the median is
   the median length exactly).
4. Its simulated rest length through the one real-to-simulated map,
   :func:`airmat.check.length_map.length_map` ``(calibration).to_simulated``.

:func:`summarize` turns the K runs' deviations into the statistics of
``inflate.json``'s ``monte_carlo`` block. SI units.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from airmat.check.string_world import world_strings
from airmat.summary import Summarized, mm

__all__ = ["MonteCarloDraws", "MonteCarloResult", "draw", "summarize", "quantile_se"]

#: how many sensitive strings the result lists
TOP_STRINGS = 10


@dataclass(frozen=True)
class MonteCarloDraws:
    """K samples of the strings' lengths.

    Attributes
    ----------
    seed : int
    delta, d, sigma : ndarray of shape (K,)
        The posterior sample of each Monte-Carlo sample (m, m, 1/m).
    kappa : ndarray of shape (K, k)
        Curvature each string produces in each sample (1/m, unsigned).
    kappa_median : ndarray of shape (k,)
        κ₁ of each string at its median length and the design's median (Δ, d) (1/m).
    length : ndarray of shape (K, k)
        Real string length that produces ``kappa`` under the design's median (Δ, d) (m).
    rest : ndarray of shape (K, k)
        Simulated rest length l* of ``length`` (m).
    sigma_source : str
        ``"posterior"`` or ``"none (sigma = 0: the calibration measured no scatter)"``.
    """

    seed: int
    delta: np.ndarray
    d: np.ndarray
    sigma: np.ndarray
    kappa: np.ndarray
    kappa_median: np.ndarray
    length: np.ndarray
    rest: np.ndarray
    sigma_source: str

    @property
    def n(self) -> int:
        """Number of samples K."""
        return int(self.delta.shape[0])


def draw(design, n: int, seed: int = 0, *, lengths=None) -> MonteCarloDraws:
    """K = ``n`` samples of every string's length (see the module's chain).

    Parameters
    ----------
    design : airmat.design.pipeline.DesignResult
    n : int
        Samples, >= 1.
    seed : int
        Seed of the posterior draws and of the scatter.

    Returns
    -------
    MonteCarloDraws
    """
    cal = design.calibration
    rng = np.random.default_rng(seed)
    pick = rng.integers(0, cal.n_samples, size=n)
    has_sigma = cal.sigma is not None
    delta, d = cal.delta[pick], cal.d[pick]
    sigma = np.asarray(cal.sigma, float)[pick] if has_sigma else np.zeros(n)
    z = rng.standard_normal((n, len(design.pattern.strings)))
    w = world_strings(design, delta, d, kappa_offset=sigma[:, None] * z, lengths=lengths)
    source = "posterior" if has_sigma else "none (sigma = 0: the calibration measured no scatter)"
    return MonteCarloDraws(seed=int(seed), delta=delta, d=d, sigma=sigma, kappa=w.kappa, kappa_median=w.kappa_median,
                           length=w.length, rest=w.rest, sigma_source=source)


def quantile_se(x, q: float, *, n_boot: int = 1000, seed: int = 0) -> float:
    """Bootstrap standard error of the ``q``-quantile (0..1) of the samples ``x`` (seeded).

    Examples
    --------
    >>> quantile_se(np.ones(8), 0.5)
    0.0
    """
    x = np.asarray(x, float)
    idx = np.random.default_rng(seed).integers(0, x.size, size=(n_boot, x.size))
    boot = np.quantile(x[idx], q, axis=1)
    return 0.0 if np.ptp(boot) == 0 else float(np.std(boot, ddof=1))   # exact 0 without spread


@dataclass(frozen=True, repr=False)
class MonteCarloResult(Summarized):
    """The K runs' deviations and their statistics.

    Attributes
    ----------
    draws : MonteCarloDraws
    rms : ndarray of shape (K,)
        RMS deviation of each run from Ŝ on the check's named face (m).
    per_vertex_q : ndarray of shape (2, n)
        50 % and 95 % quantiles over the runs of each Ŝ vertex's deviation (m).
    converged : ndarray of shape (K,) of bool
    tolerance : float or None
        The T of P(RMS <= T) (m).
    seconds : float
        Wall-clock seconds of the K runs, summed over the runs.
    """

    draws: MonteCarloDraws
    rms: np.ndarray
    per_vertex_q: np.ndarray
    converged: np.ndarray
    tolerance: float | None = None
    seconds: float = 0.0


    def _summary(self):
        q = np.percentile(self.rms, [50.0, 95.0])
        return "MonteCarloResult", [("samples", self.rms.shape[0]), ("RMS median", mm(q[0])), ("RMS 95 %", mm(q[1])),
                                    ("converged", f"{int(np.sum(self.converged))}/{self.converged.size}")]

    def stats(self) -> dict:
        """Median and 95th percentile of the RMS with bootstrap standard errors, P(RMS <= T) (m)."""
        r = self.rms
        out = {"rms_median": float(np.median(r)), "rms_median_se": quantile_se(r, 0.5, seed=self.draws.seed),
               "rms_p95": float(np.quantile(r, 0.95)), "rms_p95_se": quantile_se(r, 0.95, seed=self.draws.seed)}
        if self.tolerance is not None:
            p = float(np.mean(r <= self.tolerance))
            out["p_within"] = p
            out["p_within_se"] = float(np.sqrt(p * (1.0 - p) / r.size))
        return out

    def sensitive(self, top: int = TOP_STRINGS) -> tuple:
        """The strings whose curvature scatter moves the shape most: (indices, correlations).

        Pearson correlation over the samples between a string's curvature change
        κ_s,i − κ̄_i and the run's RMS deviation, ranked by its magnitude. The
        scatter σ z_s,i is independent across strings, so a string's correlation
        measures its own effect on the shape; the (Δ, d) part is shared by all
        strings and shifts every correlation alike. Needs K >= 3 (else empty), and is
        noisy for small K (its standard error is about 1/√K).
        """
        dk = self.draws.kappa - self.draws.kappa_median[None, :]
        if self.rms.size < 3 or dk.shape[1] == 0 or np.ptp(self.rms) == 0:
            return np.zeros(0, int), np.zeros(0)
        a = dk - dk.mean(axis=0)
        b = self.rms - self.rms.mean()
        den = np.sqrt((a ** 2).sum(axis=0) * (b ** 2).sum())
        corr = np.divide(a.T @ b, den, out=np.zeros(dk.shape[1]), where=den > 0)
        order = np.argsort(-np.abs(corr), kind="stable")[:top]
        return order, corr[order]


def summarize(draws: MonteCarloDraws, deviations, *, tolerance: float | None = None,
              converged=None, seconds: float = 0.0) -> MonteCarloResult:
    """The Monte-Carlo result of K runs' deviations from Ŝ.

    Parameters
    ----------
    draws : MonteCarloDraws
    deviations : sequence of airmat.check.compare.Deviation
        One per sample, on the check's named face.
    tolerance : float, optional
        T (m) of P(RMS <= T).
    converged : sequence of bool, optional
    seconds : float
        Wall-clock seconds of the runs, summed.

    Returns
    -------
    MonteCarloResult
    """
    rms = np.array([dv.rms for dv in deviations], float)
    per = np.stack([dv.per_vertex for dv in deviations])
    q = np.quantile(per, [0.5, 0.95], axis=0)
    conv = np.ones(rms.size, bool) if converged is None else np.asarray(converged, bool)
    return MonteCarloResult(draws=draws, rms=rms, per_vertex_q=q, converged=conv, tolerance=tolerance,
                            seconds=float(seconds))
