"""Tolerance to first order: the inflated shape's distribution from one Jacobian and the length covariance.

``airmat check --samples K`` inflates K sampled string-length vectors. To first
order the whole distribution is a matrix product away. At the median equilibrium
the adjoint gives ``dx/dl* = -H⁻¹ ∂g/∂l*`` (:mod:`airmat.check.adjoint`: one
factorization of the Hessian, one back-substitution per string); the named face at
Ŝ's points is ``P x`` (:func:`airmat.check.refine_objective.face_operator`), turned into
Ŝ's frame by the median run's alignment. The check aligns every run to Ŝ again
(Kabsch), so a change of the face counts only up to a rigid motion: each column
of the Jacobian loses its least-squares infinitesimal rigid motion at the aligned
points (the linearized Kabsch; the term of the median's own residual is dropped,
second order in the deviation over the size of Ŝ). So a change δl* of the
simulated rest lengths moves the deviation vector of Ŝ's vertex v, e_v = aligned − Ŝ,
to e_v + A_v δl*, with A of shape (N, 3, k).

With Σ the covariance of δl* (:mod:`airmat.check.length_covariance`: posterior of
(Δ, d) through Equation 3, scatter σ, cut and tie), the linear Gaussian model
e ~ N(e₀, A Σ Aᵀ) gives, cheaply:

- per vertex, the standard deviation of the change along Ŝ's normal and the half-widths
  of its central 50 % and 95 % intervals (0.674 and 1.960 standard deviations);
- by sampling the model (:data:`MODEL_DRAWS` draws, seeded): per-vertex 50 % / 95 %
  quantiles of the distance |e_v| (what the Monte-Carlo's ``per_vertex_q`` is), the
  distribution of the RMS and P(RMS <= T);
- each string's share of the total variance Σ_v tr(A_v Σ A_vᵀ): the Euler allocation
  ``(Aᵀ A Σ)_ii``, which sums to the total (a string's share can be negative when it is
  anti-correlated with the others in the posterior).

Validity is checked, not assumed: ``validate`` full nonlinear samples
(:func:`airmat.check.monte_carlo.draw` plus the cut error) are compared with the prediction
A δl* for their own δl*. Each is the equilibrium carried on from the median run's to its own
lengths (:func:`airmat.inflation.simulate.inflate_from`: Newton, no ramp), the branch the
linear model describes, at a fraction of an inflation each. A Monte-Carlo from the flat
mattress (``--samples K``) also samples other arrangements of the wrinkles, which no
first-order model sees. The relative
error is ‖(e_s − e₀) − A δl*_s‖ / ‖e_s − e₀‖ over every sample and vertex. Above
:data:`RELIABLE_ERROR` (25 %) the result says unreliable and recommends ``--samples K``:
a 25 % error of the spread is the sampling error of a 95 % quantile from about 16 full
samples (its relative standard error √(p(1−p)/K) / (f(q) q) is 0.24 at K = 16 for a
Gaussian deviation), so the linear answer is kept only where it is at least as good as
a short Monte-Carlo. SI units (m).
"""

from __future__ import annotations

import logging
import time
from dataclasses import dataclass, replace

import numpy as np

from airmat.check.adjoint import equilibrium_jacobian, factor_equilibrium, rest_derivative
from airmat.check.compare import deviation
from airmat.check.length_covariance import LengthCovariance, length_covariance
from airmat.check.monte_carlo import draw
from airmat.check.refine_objective import face_operator
from airmat.errors import InputError
from airmat.inflation.assembly import build_assembler
from airmat.inflation.energy import block_pattern
from airmat.inflation.model import Parameters, build_model
from airmat.inflation.solver import rigid_pins
from airmat.summary import Summarized, mm

__all__ = ["LinearTolerance", "Validation", "tolerance", "applies", "summary_line", "face_jacobian", "remove_rigid",
           "VALIDATION_SAMPLES",
           "RELIABLE_ERROR", "MODEL_DRAWS"]

log = logging.getLogger(__name__)

#: full samples that check the linear prediction by default
VALIDATION_SAMPLES = 8
#: relative error of the linear prediction above which the result is unreliable (module docstring)
RELIABLE_ERROR = 0.25
#: draws of the linear Gaussian model for the quantiles and the RMS (the 95 % quantile's relative
#: sampling error is then about 2 %: sqrt(0.95 · 0.05 / 2000) / (2 φ(1.96) · 1.96))
MODEL_DRAWS = 2000
#: central 50 % and 95 % intervals of a normal distribution: half-widths in standard deviations
Z_BANDS = (0.6744897501960817, 1.959963984540054)
#: strings listed as mattering most
TOP_STRINGS = 10


@dataclass(frozen=True)
class Validation:
    """Full samples against the linear prediction for their own length changes.

    Attributes
    ----------
    samples : int
    seed : int
    relative_error : float
        ‖actual − predicted‖ / ‖actual‖ of the deviation changes over every sample and vertex
        (nan without samples or without any change).
    rms_actual, rms_linear : ndarray of shape (samples,)
        Each sample's RMS deviation, inflated and predicted (m).
    converged : ndarray of shape (samples,) of bool
    threshold : float
        :data:`RELIABLE_ERROR`.
    seconds : float
        Wall time of the inflations.
    """

    samples: int
    seed: int
    relative_error: float
    rms_actual: np.ndarray
    rms_linear: np.ndarray
    converged: np.ndarray
    threshold: float = RELIABLE_ERROR
    seconds: float = 0.0

    @property
    def reliable(self) -> bool:
        """Every sample converged and the relative error is at most the threshold."""
        return bool(self.samples > 0 and self.converged.all() and self.relative_error <= self.threshold)


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
        Standard deviation of each vertex's change along the normal (m).
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
        None: not validated (``validate=0``, or no spread to validate).
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
            rows.append(("validation", f"{100 * self.validation.relative_error:.0f} % error on "
                                       f"{self.validation.samples} samples"))
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
            return ("no spread of the string lengths" if v is None else
                    f"the linear prediction is within {100 * v.relative_error:.0f} % of {v.samples} full samples")
        why = (f"{int((~v.converged).sum())} of {v.samples} full samples did not converge"
               if not v.converged.all() else
               f"the linear prediction is {100 * v.relative_error:.0f} % off {v.samples} full samples "
               f"(more than {100 * v.threshold:.0f} %)")
        return f"UNRELIABLE: {why}; use --samples K (a Monte-Carlo of full inflations)"

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
               "model": "first order: the adjoint Jacobian of the aligned face at the median run (rigid motions "
                        "removed) times the covariance of the simulated string lengths (posterior of (delta, d) "
                        "through Equation 3, scatter sigma, cut and tie), sampled as a Gaussian "
                        "(airmat.check.tolerance)",
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
            "relative_error": None if not np.isfinite(v.relative_error) else round(v.relative_error, 4),
            "threshold": v.threshold,
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


def remove_rigid(points: np.ndarray, columns: np.ndarray) -> np.ndarray:
    """Each column's displacement field less its least-squares infinitesimal rigid motion.

    Parameters
    ----------
    points : ndarray of shape (N, 3)
        Where the displacements sit (m).
    columns : ndarray of shape (N, 3, k)
        Displacement fields (any unit).

    Returns
    -------
    ndarray of shape (N, 3, k)
        Orthogonal to every translation and rotation about the points' centroid.

    Examples
    --------
    >>> p = np.random.default_rng(0).normal(size=(10, 3))
    >>> spin = np.cross([0.0, 0.0, 1.0], p - p.mean(axis=0)) + [1.0, 2.0, 3.0]
    >>> bool(np.allclose(remove_rigid(p, spin[:, :, None]), 0))
    True
    """
    p = np.asarray(points, float) - np.mean(points, axis=0)
    n = len(p)
    basis = np.zeros((n, 3, 6))
    basis[:, :, :3] = np.eye(3)
    for c in range(3):
        basis[:, :, 3 + c] = np.cross(np.eye(3)[c], p)
    g = basis.reshape(3 * n, 6)
    a = np.asarray(columns, float).reshape(3 * n, -1)
    coef, *_ = np.linalg.lstsq(g, a, rcond=None)
    return (a - g @ coef).reshape(columns.shape)


def face_jacobian(design, run, strings, surface: str, params: Parameters = Parameters()) -> np.ndarray:
    """A: the aligned named face's change per simulated rest length, rigid motions removed (Ŝ's frame).

    Parameters
    ----------
    design : airmat.design.pipeline.DesignResult
    run : airmat.check.inflation_check.CheckRun
        The median run: its equilibrium and its alignment to Ŝ.
    strings : airmat.inflation.strings.StringSet
        The strings it was inflated with (rest lengths l*, m).
    surface : str
        The named face.
    params : Parameters

    Returns
    -------
    ndarray of shape (N, 3, k)
        At Ŝ's N vertices (m/m).
    """
    inf = run.inflation
    mesh, x = inf.mesh, inf.xyz
    model = build_model(mesh, strings, params)
    asm = build_assembler(block_pattern(model), model.n_vertices, rigid_pins(mesh.uv, mesh.top))
    factor = factor_equilibrium(model, x, asm)
    dx = equilibrium_jacobian(factor, rest_derivative(model.springs[-1], x, mesh.thickness))   # (3n, k)
    k = len(strings.rest)
    p = face_operator(mesh, design.approx.uv, surface)
    face = (p @ dx.reshape(len(x), 3 * k)).reshape(-1, 3, k)
    face = np.einsum("ij,njk->nik", run.deviation.rotation, face)
    return remove_rigid(run.deviation.aligned, face)


def _model_draws(base, a, cov, n: int, seed: int, chunk: int = 500) -> tuple:
    """Sample e = e₀ + A δl, δl ~ N(0, cov): (per-vertex 50/95 % quantiles of |e| (2, N), RMS per draw (n,))."""
    lam, vec = np.linalg.eigh(cov)
    root = vec * np.sqrt(np.maximum(lam, 0.0))
    z = np.random.default_rng(seed).standard_normal((n, cov.shape[0]))
    flat, e0 = a.reshape(-1, cov.shape[0]), base.reshape(-1)
    dist = np.empty((n, base.shape[0]))
    for s in range(0, n, chunk):
        e = e0 + (z[s:s + chunk] @ root.T) @ flat.T                        # (chunk, 3N)
        dist[s:s + chunk] = np.linalg.norm(e.reshape(len(e), -1, 3), axis=2)
    return np.quantile(dist, [0.5, 0.95], axis=0), np.sqrt(np.mean(dist ** 2, axis=1))


def _validate(design, check_run, strings, a, n: int, seed: int, cov: LengthCovariance, params, workers,
              scheduler) -> Validation:
    """``n`` full samples, carried on from the median equilibrium, against the prediction A δl* for their δl*."""
    from airmat.inflation.simulate import inflate_many

    lengths, med = check_run.lengths, check_run.runs["median"]
    dr = draw(design, n, seed, lengths=lengths)
    t = cov.cut_tolerance
    rng = np.random.default_rng([seed, 1])
    cut = (rng.uniform(-t, t, dr.length.shape) if cov.cut_distribution == "uniform"
           else rng.normal(0.0, t, dr.length.shape)) if t > 0 else 0.0
    rest = lengths.to_simulated(np.maximum(dr.length + cut, 0.0))
    started = time.perf_counter()
    runs = inflate_many(med.inflation.mesh, [replace(strings, rest=r) for r in rest], params=params,
                        workers=workers, scheduler=scheduler, start=med.inflation, desc="tolerance check")
    seconds = time.perf_counter() - started
    approx = design.approx
    actual = np.stack([deviation(r, approx.xyz, approx.uv, check_run.surface).aligned for r in runs])
    actual -= med.deviation.aligned
    predicted = np.einsum("nck,sk->snc", a, rest - strings.rest)
    norm = float(np.linalg.norm(actual))
    err = float(np.linalg.norm(actual - predicted)) / norm if norm > 0 else float("nan")
    e0 = med.deviation.aligned - approx.xyz

    def rms(e):
        return np.sqrt(np.mean(np.sum((e0 + e) ** 2, axis=2), axis=1))
    return Validation(samples=int(n), seed=int(seed), relative_error=err, rms_actual=rms(actual),
                      rms_linear=rms(predicted), converged=np.array([r.converged for r in runs], bool),
                      seconds=seconds)


def tolerance(design, *, run=None, resolution: float = 0.020, params: Parameters = Parameters(),
              surface: str = "auto", calibrated_map: bool = False, lengths=None, cut_tolerance: float = 0.0,
              cut_distribution: str = "uniform", tolerance: float | None = None,
              validate: int = VALIDATION_SAMPLES, seed: int = 0, draws: int = MODEL_DRAWS, workers: int = 1,
              scheduler: str | None = None, known=None) -> LinearTolerance:
    """The tolerance of a design as a distribution, to first order (see the module docstring).

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
        Full samples that check the prediction (0: none; the result is then not validated).
    seed : int
        Seed of the model's draws and of the validation samples.
    draws : int
        Draws of the linear Gaussian model.

    Returns
    -------
    LinearTolerance

    Raises
    ------
    airmat.errors.InputError
        A design without strings, a negative ``validate`` or fewer than 2 ``draws``.
    """
    from airmat.check.inflation_check import check, design_strings

    if len(design.pattern.strings) == 0:
        raise InputError("the design has no strings: no string-length tolerance to propagate")
    if validate < 0 or draws < 2:
        raise InputError(f"tolerance: validate must be >= 0 and draws >= 2, got {validate} and {draws}")
    if run is None:
        run = check(design, resolution=resolution, params=params, envelope=False, surface=surface,
                    calibrated_map=calibrated_map, lengths=lengths, workers=workers, scheduler=scheduler, known=known)
    started = time.perf_counter()
    strings = design_strings(design, "median", lengths=run.lengths)
    cov = length_covariance(design, lengths=run.lengths, cut_tolerance=cut_tolerance,
                            cut_distribution=cut_distribution)
    med = run.runs["median"]
    a = face_jacobian(design, med, strings, run.surface, params)
    base = med.deviation.aligned - design.approx.xyz
    from airmat.design.curvature import vertex_normals

    normal = vertex_normals(design.approx.xyz, design.approx.faces)
    total = cov.total
    b = np.einsum("nc,nck->nk", normal, a)
    normal_sd = np.sqrt(np.maximum(np.einsum("nk,kl,nl->n", b, total, b), 0.0))
    q, rms = _model_draws(base, a, total, int(draws), seed)
    flat = a.reshape(-1, a.shape[2])
    contrib = np.einsum("ri,ri->i", flat, flat @ total)
    share = contrib / contrib.sum() if contrib.sum() > 0 else np.zeros_like(contrib)
    seconds = time.perf_counter() - started
    spread = bool(np.any(total))
    val = (_validate(design, run, strings, a, int(validate), seed, cov, params, workers, scheduler)
           if validate and spread else None)
    result = LinearTolerance(surface=run.surface, covariance=cov, jacobian=a, base=base, normal=normal,
                             normal_sd=normal_sd, per_vertex_q=q, rms=rms, share=share, ids=tuple(strings.ids),
                             tolerance=tolerance, validation=val, seconds=seconds, seed=int(seed))
    log.info("linear tolerance in %.2f s: 95 %% band along the normal median %.2f mm; %s", seconds,
             1e3 * float(np.median(result.band_normal[1])), result.message)
    return result
