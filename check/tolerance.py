"""Tolerance to first order: the inflated shape's distribution from one Jacobian and the length covariance.

``airmat check --samples K`` inflates K sampled string-length vectors. To first
order the whole distribution is a matrix product away. At the median equilibrium
a change δl* of the simulated rest lengths moves the deviation vector of Ŝ's vertex v,
e_v = aligned − Ŝ, to e_v + A_v δl*, A of shape (N, 3, k): the adjoint Jacobian of the aligned
named face, rigid motions removed (:mod:`airmat.check.face_linearization`).

With Σ the covariance of δl* (:mod:`airmat.check.length_covariance`: posterior of
(Δ, d) through Equation 3, scatter σ, cut and tie), the Gaussian model
e ~ N(e₀ + m̂, A Σ Aᵀ) (m̂ the mean shift, below) gives, cheaply:

- per vertex, the standard deviation of the change along Ŝ's normal and the half-widths
  of its central 50 % and 95 % intervals (0.674 and 1.960 standard deviations);
- by sampling the model (:data:`MODEL_DRAWS` draws, seeded): per-vertex 50 % / 95 %
  quantiles of the distance |e_v| (what the Monte-Carlo's ``per_vertex_q`` is), the
  distribution of the RMS and P(RMS <= T);
- each string's share of the total variance Σ_v tr(A_v Σ A_vᵀ): the Euler allocation
  ``(Aᵀ A Σ)_ii``, which sums to the total (a string's share can be negative when it is
  anti-correlated with the others in the posterior).

The Gaussian is centred on e₀ + m̂, m̂ the nonlinear mean shift that full samples in antithetic pairs
give, its change A δl* scaled by s, the square root of those samples' variance about their mean over
the model's for the same δl* (shrunk toward 1 by its standard error), and checked against them
(:mod:`airmat.check.tolerance_validation`): e ~ N(e₀ + m̂, s² A Σ Aᵀ). SI units (m).
"""

from __future__ import annotations

import logging
import time
from dataclasses import dataclass, replace

import numpy as np

from airmat.check.face_linearization import linearize
from airmat.check.length_covariance import LengthCovariance, length_covariance
from airmat.check.tolerance_validation import (VALIDATION_SAMPLES, Validation, finish_validation,
                                               sample_validation, start_validation, validation_resolution)
from airmat.errors import InputError
from airmat.inflation.model import Parameters
from airmat.summary import Summarized, mm

__all__ = ["LinearTolerance", "tolerance", "applies", "summary_line", "density_at", "MODEL_DRAWS"]

log = logging.getLogger(__name__)

#: draws of the linear Gaussian model for the quantiles and the RMS (the 95 % quantile's relative
#: sampling error is then about 2 %: sqrt(0.95 · 0.05 / 2000) / (2 φ(1.96) · 1.96))
MODEL_DRAWS = 2000

#: central 50 % and 95 % intervals of a normal distribution: half-widths in standard deviations
Z_BANDS = (0.6744897501960817, 1.959963984540054)

#: strings listed as mattering most
TOP_STRINGS = 10


@dataclass(frozen=True, repr=False)
class LinearTolerance(Summarized):
    """The linearized tolerance of a design (see the module docstring); SI units.

    Attributes
    ----------
    surface : str
        The named face the deviations are measured on.
    covariance : LengthCovariance
        Of the simulated rest lengths (m²).
    jacobian : ndarray of shape (N, 3, k)
        A: the aligned named face's change per rest length, rigid motions removed (m/m).
    base : ndarray of shape (N, 3)
        e₀: the median run's aligned face minus Ŝ (m).
    normal : ndarray of shape (N, 3)
        Ŝ's unit vertex normals.
    normal_sd : ndarray of shape (N,)
        Standard deviation of each vertex's change along the normal, s times the first order's (m).
    per_vertex_q : ndarray of shape (2, N)
        50 % and 95 % quantiles of the distance |e_v| under the model (m), as ``MonteCarloResult.per_vertex_q``.
    rms : ndarray of shape (MODEL_DRAWS,)
        RMS deviation of each draw of the model (m).
    share : ndarray of shape (k,)
        Each string's share of the total variance (sums to 1; 0 without variance).
    ids : tuple of str
        The strings' ids.
    tolerance : float or None
        T (m) of P(RMS <= T).
    validation : Validation or None
        None: not validated (``validate=0``, or no spread to validate); its ``spread_scale`` is s, the
        factor of the model's change A δl*.
    seconds : float
        Wall time of the Jacobian and the model (the median run and the validation excluded).
    seed : int
    """

    surface: str
    covariance: LengthCovariance
    jacobian: np.ndarray
    base: np.ndarray
    normal: np.ndarray
    normal_sd: np.ndarray
    per_vertex_q: np.ndarray
    rms: np.ndarray
    share: np.ndarray
    ids: tuple
    tolerance: float | None = None
    validation: Validation | None = None
    seconds: float = 0.0
    seed: int = 0

    def _summary(self):
        band = self.band_normal[1]
        rows = [("face", self.surface), ("95 % band along the normal", f"median {mm(float(np.median(band)))}, "
                                                                      f"max {mm(float(band.max()))}"),
                ("RMS median", mm(float(np.median(self.rms)))), ("RMS 95 %", mm(float(np.quantile(self.rms, 0.95))))]
        if self.validation is not None:
            rows.append(("validation", f"spread {100 * self.validation.spread_error:+.0f} % on "
                                       f"{self.validation.samples} samples, scaled by "
                                       f"{self.validation.spread_scale:.3f}"))
        return "LinearTolerance", rows + [("reliable", self.reliable)]

    @property
    def band_normal(self) -> np.ndarray:
        """Half-widths of the central 50 % and 95 % intervals along the normal, shape (2, N) (m)."""
        return np.outer(Z_BANDS, self.normal_sd)

    @property
    def reliable(self) -> bool | None:
        """The validation's verdict; None when not validated (True without spread: nothing moves)."""
        if not np.any(self.covariance.total):
            return True
        return None if self.validation is None else self.validation.reliable

    @property
    def message(self) -> str:
        """One line on the verdict."""
        v = self.validation
        if self.reliable is None:
            return "not validated against full samples"
        if self.reliable:
            if v is None:
                return "no spread of the string lengths"
            p = "" if v.p_within_se is None else f", P(RMS <= T) within +-{v.p_within_se:.2f}"
            on = f" on the {v.resolution * 1e3:.0f} mm mesh" if np.isfinite(v.resolution) else ""
            return (f"the linear spread is within {100 * abs(v.spread_error):.1f} % of {v.samples} full samples{on} "
                    f"(antithetic pairs, which give the mean shift){p}")
        return f"UNRELIABLE: {v.why}; use --samples K (a Monte-Carlo of full inflations)"

    def stats(self) -> dict:
        """RMS median and 95th percentile, P(RMS <= T) when T is set (m), as ``MonteCarloResult.stats``."""
        out = {"rms_median": float(np.median(self.rms)), "rms_p95": float(np.quantile(self.rms, 0.95))}
        if self.tolerance is not None:
            out["p_within"] = float(np.mean(self.rms <= self.tolerance))
        return out

    def sensitive(self, top: int = TOP_STRINGS) -> tuple:
        """The strings that matter most: (indices, variance shares), largest |share| first."""
        order = np.argsort(-np.abs(self.share), kind="stable")[:top]
        return order, self.share[order]

    def block(self) -> dict:
        """The ``tolerance`` block of inflate.json (mm)."""
        def spread(x):
            return {"median": round(float(np.median(x)) * 1e3, 3), "max": round(float(np.max(x)) * 1e3, 3)}
        st, v, cov = self.stats(), self.validation, self.covariance
        idx, share = self.sensitive()
        out = {"method": "linear", "surface": self.surface, "reliable": self.reliable, "message": self.message,
               "model": "first order about the mean: the adjoint Jacobian of the aligned face at the median run "
                        "(rigid motions removed) times the covariance of the simulated string lengths (posterior of "
                        "(delta, d) through Equation 3, scatter sigma, cut and tie), sampled as a Gaussian about the "
                        "median run's face plus the mean shift of the validation's antithetic pairs of full samples, "
                        "its spread scaled to theirs (validation.spread_scale) (airmat.check.tolerance)",
               "sigma_source": cov.sigma_source, "cut_tolerance_mm": round(cov.cut_tolerance * 1e3, 3),
               "cut_distribution": cov.cut_distribution, "length_sd_mm": spread(cov.sd),
               "band_normal_mm": {"p50": spread(self.band_normal[0]), "p95": spread(self.band_normal[1])},
               "distance_q95_mm": spread(self.per_vertex_q[1]),
               "rms_mm": {"median": round(st["rms_median"] * 1e3, 3), "p95": round(st["rms_p95"] * 1e3, 3)},
               "draws": int(self.rms.size), "seed": self.seed,
               "sensitive_strings": [{"id": self.ids[i], "variance_share": round(float(f), 4)}
                                     for i, f in zip(idx, share)]}
        if self.tolerance is not None:
            out["tolerance_mm"] = round(self.tolerance * 1e3, 3)
            out["p_rms_within_tolerance"] = round(st["p_within"], 4)
        out["validation"] = None if v is None else {
            "samples": v.samples, "seed": v.seed, "converged": int(np.count_nonzero(v.converged)),
            "resolution_mm": round(v.resolution * 1e3, 3) if np.isfinite(v.resolution) else None,
            "relative_error": None if not np.isfinite(v.relative_error) else round(v.relative_error, 4),
            "spread_error": None if not np.isfinite(v.spread_error) else round(v.spread_error, 4),
            "variance_ratio": None if not np.isfinite(v.variance_ratio) else round(v.variance_ratio, 4),
            "variance_ratio_se": None if not np.isfinite(v.variance_ratio_se) else round(v.variance_ratio_se, 4),
            "spread_scale": round(v.spread_scale, 4),
            "threshold": v.threshold, "p_threshold": v.p_threshold,
            "mean_shift_mm": {"rms": round(float(np.sqrt(np.mean(np.sum(v.shift ** 2, axis=1)))) * 1e3, 3),
                              "max": round(float(np.max(np.linalg.norm(v.shift, axis=1))) * 1e3, 3)},
            "rms_shift_se_mm": None if not np.isfinite(v.rms_shift_se) else round(v.rms_shift_se * 1e3, 3),
            "p_rms_within_tolerance_se": None if v.p_within_se is None or not np.isfinite(v.p_within_se)
            else round(v.p_within_se, 4),
            "p_rms_within_tolerance_se_bound": None if not np.isfinite(v.p_within_bound)
            else round(v.p_within_bound, 4),
            "rms_mm": {"inflated": [round(float(r) * 1e3, 3) for r in v.rms_actual],
                       "linear": [round(float(r) * 1e3, 3) for r in v.rms_linear]}}
        return out


def summary_line(block: dict) -> str:
    """The check's summary line of a ``tolerance`` block (:meth:`LinearTolerance.block`)."""
    b, r = block["band_normal_mm"]["p95"], block["rms_mm"]
    line = (f"  tolerance (linear): 95 % band along the normal median {b['median']:.1f} mm, max {b['max']:.1f} mm; "
            f"RMS median {r['median']:.1f} mm, 95th percentile {r['p95']:.1f} mm")
    if "tolerance_mm" in block:
        line += f", P(RMS <= {block['tolerance_mm']:g} mm) = {block['p_rms_within_tolerance']:.2f}"
    return line + f"\n    {block['message']}"


def applies(design, cut_tolerance: float = 0.0) -> str | None:
    """Why a design has no linear tolerance (no strings, or no spread of their lengths), or None when it has one.

    Examples
    --------
    >>> from types import SimpleNamespace
    >>> applies(SimpleNamespace(pattern=SimpleNamespace(strings=())))
    'the design has no strings'
    """
    if len(design.pattern.strings) == 0:
        return "the design has no strings"
    cal = design.calibration
    if cal.n_samples < 2 and cal.sigma is None and not cut_tolerance > 0:
        return ("the design's calibration is one point (no posterior samples, no scatter) and no cut tolerance "
                "is given: the string lengths have no spread")
    return None


def density_at(x: np.ndarray, t: float) -> float:
    """Density of the samples ``x`` at ``t``: a Gaussian kernel of Silverman's bandwidth (1/unit of x).

    Examples
    --------
    >>> x = np.random.default_rng(0).standard_normal(20000)
    >>> abs(density_at(x, 0.0) - 0.399) < 0.02       # φ(0), within the kernel's smoothing and the sampling
    True
    """
    x = np.asarray(x, float)
    sd = float(np.std(x, ddof=1))
    if not sd > 0:
        return float("inf") if np.any(x == t) else 0.0
    h = 1.06 * sd * x.size ** -0.2
    return float(np.mean(np.exp(-0.5 * ((t - x) / h) ** 2)) / (h * np.sqrt(2 * np.pi)))


def _model_draws(base, a, cov, n: int, seed: int, chunk: int = 500) -> tuple:
    """Sample e = e₀ + A δl, δl ~ N(0, cov): (per-vertex 50/95 % quantiles of |e| (2, N), RMS per draw (n,))."""
    lam, vec = np.linalg.eigh(cov)
    root = vec * np.sqrt(np.maximum(lam, 0.0))
    z = np.random.default_rng(seed).standard_normal((n, cov.shape[0]))
    m = base.shape[0]
    comp = np.ascontiguousarray(a.transpose(1, 0, 2)).reshape(-1, cov.shape[0])     # (3N, k): x rows, y rows, z rows
    e0 = np.ascontiguousarray(base.T).reshape(-1)
    dist = np.empty((n, m))
    for s in range(0, n, chunk):
        e = (e0 + (z[s:s + chunk] @ root.T) @ comp.T).reshape(-1, 3, m)     # each component contiguous
        dist[s:s + chunk] = np.sqrt(e[:, 0] ** 2 + e[:, 1] ** 2 + e[:, 2] ** 2)
    return np.quantile(dist, [0.5, 0.95], axis=0), np.sqrt(np.mean(dist ** 2, axis=1))


def _start_coarse(design, run, strings, n: int, seed: int, cov, params, *, workers: int, scheduler,
                  forks: int):
    """The validation's samples on the mesh of :func:`validation_resolution` when it is coarser than
    ``run``'s: there a median run at the same lengths and its own Jacobian and variance, then the samples
    started on up to ``forks`` forked processes. Returns (pending samples, their model's variance (m²),
    setup seconds), or None when the samples run on ``run``'s own mesh."""
    from airmat.check.inflation_check import check

    res = validation_resolution(design, run.resolution)
    if abs(res - run.resolution) < 1e-12:
        return None
    started = time.perf_counter()
    known = _level_run(design, run, strings, res, params)
    without_s = replace(design, approx=replace(design.approx, target=None))     # no distance to S needed here
    coarse = check(without_s, resolution=res, params=params, envelope=False, surface=run.surface,
                   lengths=run.lengths, workers=workers, scheduler=scheduler, known=known)
    clin = linearize(design, coarse.runs["median"], strings, run.surface, params)
    flat = clin.face.reshape(-1, clin.face.shape[2])
    cvar = float(np.einsum("ri,ri->", flat, flat @ cov.total))
    pending = start_validation(design, coarse, strings, clin, n, seed, cov, params, forks)
    setup = time.perf_counter() - started
    log.debug("validation on the %.0f mm mesh: its median run and Jacobian %.2f s, %d samples on %d forked "
              "processes", res * 1e3, setup, n, pending.runs.forked)
    return pending, cvar, setup


def _level_run(design, run, strings, res: float, params):
    """The run a check on the mesh of edge ``res`` (m) would inflate first, from ``run``'s own continuation: the
    solution its inflation from the flat mattress (the median run's, or a refined design's open loop) holds on
    that mesh, carried on to the check's tolerance; None when it holds none there or does not converge.

    The continuation solves that mesh to a looser tolerance on the path a check there takes (the same coarser
    meshes, ramp and start), so the carried-on solution is that check's run to its tolerance, in a few Newton
    iterations instead of a new inflation."""
    from airmat.check.inflation_check import KnownRun, open_loop_strings
    from airmat.inflation.mesh import build_mattress_mesh
    from airmat.inflation.simulate import INFLATE_TOL, inflate_from

    refined = run.open_loop is not None
    source = run.open_loop if refined else run.runs["median"].inflation
    which = open_loop_strings(design, lengths=run.lengths) if refined else strings
    m = design.mattress
    target = build_mattress_mesh(m.width, m.height, m.thickness, resolution=res)
    for mesh, x in source.levels:
        if mesh.n_vertices == target.n_vertices and np.array_equal(mesh.spacing, target.spacing):
            level = replace(source, mesh=mesh, xyz=x, levels=())
            inf = inflate_from(level, which if len(which) else None, params=params, tol=INFLATE_TOL)
            return KnownRun(which, inf, params, INFLATE_TOL) if inf.converged else None
    return None


def _fork_workers(workers: int) -> int:
    """Forked processes for the validation's samples: ``workers``, at most the cores this process may use
    (not the idle ones: right after a closest-point query open3d's threads still count as running)."""
    from airmat.cores import usable_cores

    return max(1, min(int(workers), usable_cores()))


def tolerance(design, *, run=None, resolution: float = 0.020, params: Parameters = Parameters(),
              surface: str = "auto", calibrated_map: bool = False, lengths=None, cut_tolerance: float = 0.0,
              cut_distribution: str = "uniform", tolerance: float | None = None,
              validate: int = VALIDATION_SAMPLES, seed: int = 0, draws: int = MODEL_DRAWS, workers: int = 1,
              scheduler: str | None = None, known=None, spread_correction: bool = True) -> LinearTolerance:
    """The tolerance of a design as a distribution, to first order with its mean shift (see the module docstring).

    Parameters
    ----------
    design : airmat.design.pipeline.DesignResult
    run : airmat.check.inflation_check.DesignCheck, optional
        A check of ``design`` whose median run, face, length map and start are used; default: a
        check made here (median run only) with ``resolution``, ``params``, ``surface``,
        ``calibrated_map``, ``lengths``, ``workers``, ``scheduler`` and ``known``.
    cut_tolerance : float
        t (m) of the cut-and-tie error of every string (:mod:`airmat.check.length_covariance`).
    cut_distribution : {"uniform", "normal"}
        Uniform on ±t, or normal with standard deviation t.
    tolerance : float, optional
        T (m) of P(RMS <= T).
    validate : int
        Full samples that check the prediction and give its mean shift, an even number (antithetic
        pairs, on the mesh of :func:`~airmat.check.tolerance_validation.validation_resolution`: twice
        ``run``'s resolution where that resolves the strings, up to 40 mm); 0: none, the result is then
        the first-order model about e₀, not validated. With ``workers`` > 1 they run on as many forked
        processes, at most the usable cores (:class:`airmat.forked.ForkedMap`, Linux; the same results), beside
        the model's own Jacobian; else in this process.
    seed : int
        Seed of the model's draws and of the validation samples.
    draws : int
        Draws of the Gaussian model.
    spread_correction : bool
        Scale the model's change A δl* by the validation's
        :func:`~airmat.check.pair_statistics.spread_scale` (the full samples' spread about their mean
        against the model's, shrunk toward 1 by its standard error); False: the first-order spread.

    Returns
    -------
    LinearTolerance

    Raises
    ------
    airmat.errors.InputError
        A design without strings, a negative or odd ``validate`` or fewer than 2 ``draws``.
    """
    from airmat.check.inflation_check import check, design_strings

    if len(design.pattern.strings) == 0:
        raise InputError("the design has no strings: no string-length tolerance to propagate")
    if validate < 0 or validate % 2 or draws < 2:
        raise InputError(f"tolerance: validate must be an even number >= 0 (antithetic pairs) and draws >= 2, "
                         f"got {validate} and {draws}")
    if run is None:
        run = check(design, resolution=resolution, params=params, envelope=False, surface=surface,
                    calibrated_map=calibrated_map, lengths=lengths, workers=workers, scheduler=scheduler, known=known)
    started = time.perf_counter()
    strings = design_strings(design, "median", lengths=run.lengths)
    cov = length_covariance(design, lengths=run.lengths, cut_tolerance=cut_tolerance,
                            cut_distribution=cut_distribution)
    prepared = time.perf_counter() - started
    med = run.runs["median"]
    validating = bool(validate) and bool(np.any(cov.total))       # no spread: nothing to validate
    forks = _fork_workers(workers) if validating else 1
    coarse = (_start_coarse(design, run, strings, int(validate), seed, cov, params, workers=workers,
                            scheduler=scheduler, forks=forks) if validating else None)
    started = time.perf_counter()       # the model's own time (its validation's samples may run beside it)
    lin = linearize(design, med, strings, run.surface, params)
    a = lin.face
    base = med.deviation.aligned - design.approx.xyz
    from airmat.design.curvature import vertex_normals

    normal = vertex_normals(design.approx.xyz, design.approx.faces)
    total = cov.total
    b = np.einsum("nc,nck->nk", normal, a)
    normal_sd = np.sqrt(np.maximum(np.einsum("nk,kl,nl->n", b, total, b), 0.0))
    flat = a.reshape(-1, a.shape[2])
    contrib = np.einsum("ri,ri->i", flat, flat @ total)
    share = contrib / contrib.sum() if contrib.sum() > 0 else np.zeros_like(contrib)
    seconds = prepared + time.perf_counter() - started
    val = None
    if validating:
        if coarse is not None:          # its samples ran beside the model above
            pending, cvar, setup = coarse
            val = finish_validation(pending, cvar, base=base, spread_correction=spread_correction)
            val = replace(val, seconds=val.seconds + setup)
        else:
            val = sample_validation(design, run, strings, lin, int(validate), seed, cov, params, float(contrib.sum()),
                                    spread_correction=spread_correction, workers=forks)
    started = time.perf_counter()
    shift = val.shift if val is not None else np.zeros_like(base)
    scale = val.spread_scale if val is not None else 1.0
    normal_sd = scale * normal_sd
    q, rms = _model_draws(base + shift, a, scale ** 2 * total, int(draws), seed)
    if val is not None and tolerance is not None:
        val = replace(val, p_within_se=density_at(rms, tolerance) * val.rms_shift_se)
    seconds += time.perf_counter() - started
    result = LinearTolerance(surface=run.surface, covariance=cov, jacobian=a, base=base, normal=normal,
                             normal_sd=normal_sd, per_vertex_q=q, rms=rms, share=share, ids=tuple(strings.ids),
                             tolerance=tolerance, validation=val, seconds=seconds, seed=int(seed))
    log.info("linear tolerance in %.2f s (validation %.2f s): 95 %% band along the normal median %.2f mm; %s",
             seconds, 0.0 if val is None else val.seconds, 1e3 * float(np.median(result.band_normal[1])),
             result.message)
    return result
