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

The mean shift. The Gaussian is centred on the median run's face e₀, but a nonlinear response
moves the mean: E[e] = e₀ + m with m = ½ tr(Σ ∂²e/∂l*²) + O(Σ²). The bands hardly notice (m is a
few millimetres against bands of tens), the RMS does: RMS² = ⟨|e₀ + δe|²⟩ over the vertices holds
2⟨e₀·m⟩, first order in m and scaled by e₀, while the RMS spread comes from 2⟨e₀·A δl*⟩ alone. Where
e₀ dominates and the change is nearly orthogonal to it (the saddle at 20 mm: e₀ 21 mm RMS, changes
11 mm, RMS spread 2.9 mm) the second-order shift moves the RMS median by a sizeable part of its spread
(2⟨e₀·m⟩ = −28 mm², −0.6 mm of the first-order model's +0.9 mm offset from 64 full samples at the
same lengths; the rest is a 9 % smaller variance, a third-order effect). The second derivative at the
median does not give m: a central difference of the forces along the Jacobian's directions gives a
step-dependent 13–18 mm RMS against the samples' 2 mm (the wrinkles' and the tension-only strings'
energy is far from quadratic over one standard deviation). So m is sampled, without bias:

Validation and mean shift: ``validate`` full samples in antithetic pairs, δl*_j and −δl*_j
(:func:`airmat.check.monte_carlo.draw` plus the cut error; the Gaussian model is symmetric), each the
equilibrium carried on from the median run's (Newton from the linear prediction, the mesh's model
and symbolic factorization shared). The response splits into its odd part (A δl* plus third order)
and its even part; within a pair the odd part cancels, so m̂, the mean change of the samples, is an
unbiased estimate of m whose error is the even part's scatter alone. The model draws
e = e₀ + m̂ + A δl*. Its checks:

- ``spread_error`` = sqrt(Σ_s ‖δe_s − m̂‖² / Σ_s ‖A δl*_s‖²) − 1, the relative error of the spread
  about the mean that the bands scale with. Paired on the same δl*, its sampling error is small
  (0.025 with 2 pairs on the saddle). Above :data:`RELIABLE_ERROR` (15 %, the accuracy the bands
  claim against a Monte-Carlo) the result says unreliable: a string that goes slack in half the
  samples, a wrinkle that snaps, halve or double the spread.
- with T, ``p_within_se``: the model's RMS density at T times the standard error of the shift's
  effect on the RMS, from the scatter between the pairs. Above :data:`RELIABLE_P` (0.05) the result
  says unreliable: the sampled shift leaves P(RMS <= T) open. That standard error is judged by its
  upper 95 % confidence bound (:attr:`Validation.p_within_bound`): with p pairs the scatter has p − 1
  degrees of freedom, and with the default 2 pairs the bound is 15.9 times the estimate, so P is
  vouched for only where the shift barely moves the RMS; ``validate=8`` (4 pairs) brings the factor
  to 2.9. On the saddle at 20 mm the estimate from 2 pairs reads 0.04 while P over 8 validation seeds
  scatters by 0.11.
- any sample that does not converge.

The per-sample relative error ‖δe − A δl*‖ / ‖δe‖ is reported but is not the verdict: on 64 full
samples of vault1 and the saddle it is 26–33 % while the bands agree within 5 %. It is not the
alignment (the rigid part of the changes is 1 %), nor the solver (samples from the flat mattress and
carried on agree to 1e-10), nor a few wrinkled vertices (the worst 10 % hold a quarter to a third of
it): it is the genuine second-order response, a mean (13–19 % of the change) and zero-mean scatter.
Scatter uncorrelated with A δl* adds only its square to the variance, so a 25 % error moves a band
by 3 %.

Cost: the equilibria stop at :data:`VALIDATION_TOL` (1e-3: Newton's last step from there moves the
face by less than 1e-5 of its change, measured on the saddle at 20 mm); each takes 7–20 fine-mesh
Newton iterations, where one inflation does most of its iterations on the coarse meshes of its
continuation. A Monte-Carlo from the flat mattress (``--samples K``) may also sample other
arrangements of the wrinkles, which no model about the median sees. SI units (m).
"""

from __future__ import annotations

import logging
import time
from dataclasses import dataclass, replace

import numpy as np

from airmat.check.adjoint import equilibrium_jacobian, factor_equilibrium, rest_derivative
from airmat.check.length_covariance import LengthCovariance, length_covariance
from airmat.check.monte_carlo import draw
from airmat.check.refine_objective import face_operator
from airmat.errors import AirmatError, InputError
from airmat.inflation.assembly import build_assembler
from airmat.inflation.energy import block_pattern
from airmat.inflation.model import Parameters, build_model, with_strings
from airmat.inflation.solver import NewtonSystem, rigid_pins, solve
from airmat.summary import Summarized, mm

__all__ = ["LinearTolerance", "Validation", "Linearization", "tolerance", "applies", "summary_line", "linearize",
           "face_jacobian", "remove_rigid", "align_faces", "antithetic", "pair_statistics", "rms_shift_se",
           "density_at",
           "VALIDATION_SAMPLES", "RELIABLE_ERROR", "RELIABLE_P", "MODEL_DRAWS"]

log = logging.getLogger(__name__)

#: full samples (antithetic pairs) that give the mean shift and check the model, by default
VALIDATION_SAMPLES = 4
#: relative error of the predicted spread above which the result is unreliable (module docstring)
RELIABLE_ERROR = 0.15
#: standard error of P(RMS <= T) above which the result is unreliable (module docstring)
RELIABLE_P = 0.05
#: relative force residual of the validation's equilibria (:func:`airmat.inflation.solver.solve`): Newton's
#: last step from 1e-3 moves the named face by less than 1e-5 of its change (module docstring)
VALIDATION_TOL = 1e-3
#: draws of the linear Gaussian model for the quantiles and the RMS (the 95 % quantile's relative
#: sampling error is then about 2 %: sqrt(0.95 · 0.05 / 2000) / (2 φ(1.96) · 1.96))
MODEL_DRAWS = 2000
#: central 50 % and 95 % intervals of a normal distribution: half-widths in standard deviations
Z_BANDS = (0.6744897501960817, 1.959963984540054)
#: strings listed as mattering most
TOP_STRINGS = 10


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
        Wall time of the inflations.
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
        from scipy.stats import chi2

        dof = self.samples // 2 - 1
        if self.p_within_se is None or dof < 1 or not np.isfinite(self.p_within_se):
            return float("nan")
        return float(self.p_within_se * np.sqrt(dof / chi2.ppf(0.05, dof)))

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
            rows.append(("validation", f"spread {100 * self.validation.spread_error:+.0f} % on "
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
            if v is None:
                return "no spread of the string lengths"
            p = "" if v.p_within_se is None else f", P(RMS <= T) within +-{v.p_within_se:.2f}"
            return (f"the linear spread is within {100 * abs(v.spread_error):.0f} % of {v.samples} full samples "
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
                        "median run's face plus the mean shift of the validation's antithetic pairs of full samples "
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
            "spread_error": None if not np.isfinite(v.spread_error) else round(v.spread_error, 4),
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


@dataclass(frozen=True)
class Linearization:
    """The median equilibrium's model, factored once: what the Jacobian and the validation solves share.

    Attributes
    ----------
    model : airmat.inflation.energy.Model
        U_B with the strings at their median rest lengths.
    assembler : airmat.inflation.assembly.Assembler
        The sparse pattern with the solver's pinned DOFs removed.
    fixed : ndarray of shape (6,)
        The pinned flat DOF indices (:func:`airmat.inflation.solver.rigid_pins`).
    dx : ndarray of shape (3 n, k)
        dx/dl* of every DOF (m/m).
    face : ndarray of shape (N, 3, k)
        A, the aligned named face's change per rest length, rigid motions removed (m/m).
    operator : scipy.sparse.csr_matrix of shape (N, n)
        The named face at Ŝ's points from the vertex positions (:func:`face_operator`).
    """

    model: object
    assembler: object
    fixed: np.ndarray
    dx: np.ndarray
    face: np.ndarray
    operator: object


def linearize(design, run, strings, surface: str, params: Parameters = Parameters()) -> Linearization:
    """The adjoint linearization of the named face at the median run (see :class:`Linearization`).

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
    Linearization
    """
    inf = run.inflation
    mesh, x = inf.mesh, inf.xyz
    model = build_model(mesh, strings, params)
    fixed = rigid_pins(mesh.uv, mesh.top)
    asm = build_assembler(block_pattern(model), model.n_vertices, fixed)
    factor = factor_equilibrium(model, x, asm)
    dx = equilibrium_jacobian(factor, rest_derivative(model.springs[-1], x, mesh.thickness))   # (3n, k)
    k = len(strings.rest)
    p = face_operator(mesh, design.approx.uv, surface)
    face = (p @ dx.reshape(len(x), 3 * k)).reshape(-1, 3, k)
    face = np.einsum("ij,njk->nik", run.deviation.rotation, face)
    return Linearization(model, asm, fixed, dx, remove_rigid(run.deviation.aligned, face), p)


def face_jacobian(design, run, strings, surface: str, params: Parameters = Parameters()) -> np.ndarray:
    """A: the aligned named face's change per simulated rest length, rigid motions removed (Ŝ's frame),
    shape (N, 3, k) at Ŝ's N vertices (m/m): the ``face`` of :func:`linearize` (same parameters)."""
    return linearize(design, run, strings, surface, params).face


def align_faces(faces: np.ndarray, target: np.ndarray) -> np.ndarray:
    """Each face rigidly aligned onto the target (Kabsch, as :func:`airmat.check.compare.deviation`).

    Parameters
    ----------
    faces : ndarray of shape (S, N, 3)
        Points corresponding to the target's (m).
    target : ndarray of shape (N, 3)
        (m).

    Returns
    -------
    ndarray of shape (S, N, 3)
        R_s (face_s − its centroid) + the target's centroid, R_s the proper rotation of least squares.

    Examples
    --------
    >>> t = np.random.default_rng(1).normal(size=(6, 3))
    >>> c, s = np.cos(0.3), np.sin(0.3)
    >>> moved = t @ np.array([[c, -s, 0], [s, c, 0], [0, 0, 1]]).T + 2.0
    >>> bool(np.allclose(align_faces(moved[None], t)[0], t))
    True
    """
    f = np.asarray(faces, float)
    t = np.asarray(target, float)
    fc, tc = f - f.mean(axis=1, keepdims=True), t - t.mean(axis=0)
    u, _, vt = np.linalg.svd(np.einsum("snc,nd->scd", fc, tc))            # H = U S Vᵀ, R = V D Uᵀ
    sign = np.ones((len(f), 3))
    sign[:, 2] = np.sign(np.linalg.det(u) * np.linalg.det(vt))
    rot = np.einsum("sji,sj,skj->sik", vt, sign, u)
    return np.einsum("sik,snk->sni", rot, fc) + t.mean(axis=0)


def antithetic(delta: np.ndarray) -> np.ndarray:
    """Each change followed by its negative: rows δ₁, −δ₁, δ₂, −δ₂, ...

    Parameters
    ----------
    delta : ndarray of shape (p, k)

    Returns
    -------
    ndarray of shape (2 p, k)

    Examples
    --------
    >>> antithetic(np.array([[1.0, 2.0]])).tolist()
    [[1.0, 2.0], [-1.0, -2.0]]
    """
    d = np.asarray(delta, float)
    return np.stack([d, -d], axis=1).reshape(-1, d.shape[1])


def pair_statistics(changes: np.ndarray, predicted: np.ndarray) -> tuple:
    """The antithetic pairs' mean shift and the relative error of the predicted spread.

    Parameters
    ----------
    changes : ndarray of shape (2 p, N, 3)
        d_s = e(δ_s) − e₀ of full samples at δ₁, −δ₁, δ₂, −δ₂, ... (m).
    predicted : ndarray of shape (2 p, N, 3)
        A δ_s (m).

    Returns
    -------
    shift : ndarray of shape (N, 3)
        m̂ = the mean of d_s: the odd part of the response cancels in each pair, so m̂ is the
        mean of the even parts q_j = (d(δ_j) + d(−δ_j)) / 2 (m).
    spread_error : float
        sqrt(Σ_s ‖d_s − m̂‖² / Σ_s ‖A δ_s‖²) − 1: how far the spread about the mean is off the
        linear prediction's, relatively (nan without spread).
    pairs_shift : ndarray of shape (p, N, 3)
        q_j − e₀'s change, each pair's own estimate of the shift (m).

    Examples
    --------
    >>> p = np.array([[[1.0, 0, 0]], [[-1.0, 0, 0]]])
    >>> shift, err, _ = pair_statistics(p + [0, 0, 0.5], p)     # linear plus a constant: exact spread
    >>> shift.tolist(), err
    ([[0.0, 0.0, 0.5]], 0.0)
    """
    d = np.asarray(changes, float)
    pairs = d.reshape(-1, 2, *d.shape[1:]).mean(axis=1)
    shift = pairs.mean(axis=0)
    den = float(np.sum(np.asarray(predicted, float) ** 2))
    err = float(np.sqrt(np.sum((d - shift) ** 2) / den) - 1.0) if den > 0 else float("nan")
    return shift, err, pairs


def rms_shift_se(base: np.ndarray, pairs: np.ndarray, spread: float) -> float:
    """Standard error of the mean shift's effect on the RMS, from the scatter of the pairs' own estimates.

    Pair j alone moves the RMS of a draw of typical spread by
    Δ_j = sqrt(⟨|e₀ + q_j|²⟩ + v) − sqrt(⟨|e₀|²⟩ + v), v the mean squared change of the model;
    the standard error of their mean is sd(Δ_j) / sqrt(p).

    Parameters
    ----------
    base : ndarray of shape (N, 3)
        e₀ (m).
    pairs : ndarray of shape (p, N, 3)
        Each pair's shift estimate (:func:`pair_statistics`) (m).
    spread : float
        v = tr(A Σ Aᵀ) / N (m²).

    Returns
    -------
    float
        (m); nan with fewer than 2 pairs.

    Examples
    --------
    >>> e0 = np.zeros((4, 3))
    >>> round(rms_shift_se(e0, np.stack([e0 + [0, 0, 1.0], e0 + [0, 0, 3.0]]), 0.0), 6)
    1.0
    """
    if len(pairs) < 2:
        return float("nan")
    e0 = np.asarray(base, float)
    moved = np.sqrt(np.mean(np.sum((e0 + pairs) ** 2, axis=2), axis=1) + spread)
    at = np.sqrt(np.mean(np.sum(e0 ** 2, axis=1)) + spread)
    return float(np.std(moved - at, ddof=1) / np.sqrt(len(pairs)))


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
    flat, e0 = a.reshape(-1, cov.shape[0]), base.reshape(-1)
    dist = np.empty((n, base.shape[0]))
    for s in range(0, n, chunk):
        e = e0 + (z[s:s + chunk] @ root.T) @ flat.T                        # (chunk, 3N)
        dist[s:s + chunk] = np.linalg.norm(e.reshape(len(e), -1, 3), axis=2)
    return np.quantile(dist, [0.5, 0.95], axis=0), np.sqrt(np.mean(dist ** 2, axis=1))


def _carry_on(lin: Linearization, x0: np.ndarray, mesh, strings, delta: np.ndarray, params) -> tuple:
    """Equilibria at l* ± δ_j from the median ``x0`` (Newton, no ramp): positions (2 p, n, 3), converged (2 p,).

    The mesh's model, sparse pattern and symbolic factorization are shared; each run starts from its
    linear prediction x₀ ± J δ (from x₀ when that start stretches an edge past the solver's sanity
    bound) with the Newton shift's hint reset, and stops at :data:`VALIDATION_TOL`.
    """
    n = len(x0)
    system = NewtonSystem(groups=lin.assembler.free // 3)
    hint = system.hint_rel
    kw = dict(fixed_dofs=lin.fixed, tol=VALIDATION_TOL, max_iter=200, max_move=0.5 * float(np.mean(mesh.spacing)),
              assembler=lin.assembler, linear_system=system, desc="tolerance check", warn=False)

    def equilibrium(rest, step):
        model = with_strings(lin.model, mesh, replace(strings, rest=rest), params)
        for start in (x0 + step, x0):      # a prediction that tears an edge (a wrinkle's rotation): from x₀
            system.hint_rel = hint
            try:
                r = solve(model, start, **kw)
            except AirmatError:
                continue
            return r.xyz, bool(r.converged)
        return np.full_like(x0, np.nan), False

    out, ok = np.empty((2 * len(delta), n, 3)), np.zeros(2 * len(delta), bool)
    for j, d in enumerate(delta):
        step = (lin.dx @ d).reshape(n, 3)
        out[2 * j], ok[2 * j] = equilibrium(strings.rest + d, step)
        out[2 * j + 1], ok[2 * j + 1] = equilibrium(strings.rest - d, -step)
    return out, ok


def _validate(design, check_run, strings, lin: Linearization, n: int, seed: int, cov: LengthCovariance,
              params, variance: float) -> Validation:
    """``n`` full samples in antithetic pairs, carried on from the median equilibrium, against the model
    (``variance``: the model's total, Σ_v tr(A_v Σ A_vᵀ), m²)."""
    lengths, med = check_run.lengths, check_run.runs["median"]
    pairs = n // 2
    dr = draw(design, pairs, seed, lengths=lengths)
    t = cov.cut_tolerance
    rng = np.random.default_rng([seed, 1])
    cut = (rng.uniform(-t, t, dr.length.shape) if cov.cut_distribution == "uniform"
           else rng.normal(0.0, t, dr.length.shape)) if t > 0 else 0.0
    delta = lengths.to_simulated(np.maximum(dr.length + cut, 0.0)) - strings.rest          # (p, k)
    started = time.perf_counter()
    x, converged = _carry_on(lin, med.inflation.xyz, med.inflation.mesh, strings, delta, params)
    approx = design.approx
    faces = (lin.operator @ x.transpose(1, 0, 2).reshape(x.shape[1], -1)).reshape(-1, len(x), 3).transpose(1, 0, 2)
    seconds = time.perf_counter() - started
    e0 = med.deviation.aligned - approx.xyz
    both = converged.reshape(-1, 2).all(axis=1).repeat(2)
    actual = align_faces(faces[both], approx.xyz) - med.deviation.aligned
    predicted = np.einsum("nck,sk->snc", lin.face, antithetic(delta)[both])
    if len(actual) == 0:
        nan = float("nan")
        return Validation(samples=2 * pairs, seed=int(seed), relative_error=nan, spread_error=nan,
                          shift=np.zeros_like(e0), rms_shift_se=nan, rms_actual=np.zeros(0), rms_linear=np.zeros(0),
                          converged=converged, seconds=seconds)
    shift, spread_err, per_pair = pair_statistics(actual, predicted)
    norm = float(np.linalg.norm(actual))
    err = float(np.linalg.norm(actual - predicted)) / norm if norm > 0 else float("nan")
    v = variance / len(e0)

    def rms(e):
        return np.sqrt(np.mean(np.sum((e0 + e) ** 2, axis=2), axis=1))
    return Validation(samples=2 * pairs, seed=int(seed), relative_error=err, spread_error=spread_err, shift=shift,
                      rms_shift_se=rms_shift_se(e0, per_pair, v), rms_actual=rms(actual),
                      rms_linear=rms(shift + predicted), converged=converged, seconds=seconds)


def tolerance(design, *, run=None, resolution: float = 0.020, params: Parameters = Parameters(),
              surface: str = "auto", calibrated_map: bool = False, lengths=None, cut_tolerance: float = 0.0,
              cut_distribution: str = "uniform", tolerance: float | None = None,
              validate: int = VALIDATION_SAMPLES, seed: int = 0, draws: int = MODEL_DRAWS, workers: int = 1,
              scheduler: str | None = None, known=None) -> LinearTolerance:
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
        pairs, solved in this process whatever ``workers``); 0: none, the result is then the
        first-order model about e₀, not validated.
    seed : int
        Seed of the model's draws and of the validation samples.
    draws : int
        Draws of the Gaussian model.

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
    med = run.runs["median"]
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
    seconds = time.perf_counter() - started
    spread = bool(np.any(total))
    val = (_validate(design, run, strings, lin, int(validate), seed, cov, params, float(contrib.sum()))
           if validate and spread else None)
    started = time.perf_counter()
    shift = val.shift if val is not None else np.zeros_like(base)
    q, rms = _model_draws(base + shift, a, total, int(draws), seed)
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
