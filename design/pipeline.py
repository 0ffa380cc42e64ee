"""The whole designer in one call: target S -> Ŝ -> field on Ω -> stripes -> string lengths.

:func:`design` chains the surface side (airmat.design.surface: U_A relaxation to
Ŝ, principal curvature, constructibility, transfer to Ω) and the pattern
side (airmat.design.stripes, airmat.design.string_lengths), timing each stage, and returns
a :class:`DesignResult` that the check takes as it is
(:func:`airmat.check.inflation_check.check`). Its files are written and read back
by :mod:`airmat.design.design_io`. SI units (m, 1/m).
"""

from __future__ import annotations

import dataclasses
import inspect
import logging
import time
from dataclasses import dataclass, field

import numpy as np

from airmat.errors import InputError
from airmat.units import M_TO_MM
from airmat.calib.model import kappa_max
from airmat.design.calibration_source import CalibrationSource, default_calibration, from_calibration
from airmat.design.coverage import pattern_coverage
from airmat.design.field import MattressField
from airmat.design.fold_route import FOLD_SIGMA_BAND, FoldRoute, fold_route, folds_likely, needs_folds, start_trials
from airmat.design.pattern import Pattern
from airmat.design.string_lengths import string_pattern
from airmat.design.stripes import StripeParams, Stripes, check_stripe_params, trace_stripes
from airmat.design.tie_grid import snap_dashes
from airmat.design.surface import ApproxSurface, approximate_surface, mattress_field
from airmat.summary import Summarized

__all__ = ["DesignParams", "DesignResult", "design"]

log = logging.getLogger(__name__)


def _mm(x) -> float:
    return round(float(x) * M_TO_MM, 3)


@dataclass(frozen=True)
class DesignParams:
    """Every knob of the designer (SI: m, 1/m).

    Attributes
    ----------
    L : float or None
        Geodesic spacing of string ends; None: the calibration's L (paper: 0.30 m).
    mu1 : float or None
        Dash period along a line (m), paper §3.3.1; None: L, dashes end to end.
    mu2 : float
        Spacing of neighbouring lines (m), paper §3.3.1.

    The defaults (μ₁ = L, μ₂ = 50 mm) come from a measured table of pattern
    density against deviation (``docs/benchmarks.md``, ``bench/bench_density.py``): the paper's
    sparser μ₁ = 400, μ₂ = 100 mm left bands of the mattress unstrung and landed
    2.1-2.9 % of the diagonal from Ŝ, the denser pattern 0.8-1.4 % on the
    constructible presets but the saddle.
    margin : float
        Dashes stay this far inside the mattress edge (m).
    step : float or None
        Line integration step (m); default min(μ₂ / 10, 10 mm).
    spacing : float
        Mesh spacing of Ω for the relaxation (m).
    k_a1, k_a2, k_a3 : float or None
        U_A weights (edge lengths, closest point, smoothing); None: the defaults of
        :func:`airmat.design.surface.approximate_surface`.
    kappa_min : float
        |κ| (1/m) below which a family needs no string.
    weight_min : float
        Direction weight below which lines stop (umbilics).
    n_kappa_points : int
        Field samples per dash for its representative κ (paper: N).
    tie_grid : float
        Pitch of the grid mesh on the mattress's faces (m, paper §2.1: 0.02): each
        dash's ends are snapped to its nodes and L recomputed per dash
        (:mod:`airmat.design.tie_grid`); 0 leaves the ends free.
    face_metric : bool
        Ŝ in the metric of the face it stands for (:mod:`airmat.design.face_metric`): on a
        design with curvature of both signs the named face carries the minority
        family's strings and shortens along them; one-signed designs are unchanged.
        False: Ω's metric everywhere (the paper's A1).
    free_face_span : bool
        Evaluate Equation 3 at each string's free-face span on Ŝ (:mod:`airmat.design.free_face`:
        shorter where Ŝ compresses the face opposite the string). False: at the dash's
        span on Ω (the paper).
    end_dashes : bool
        Cut a shorter dash (at least ``L_end_min``) from each line end's leftover inside the margin, its own
        arc length its L in Equation 3 (:class:`airmat.design.stripes.StripeParams`); False: the paper's
        whole dashes only, the leftovers stay unstrung edge bands.
    L_end_min : float or None
        Shortest end dash (m); None: L / 2.
    folds : bool
        When Ŝ contracts edges below its σ band, search stiffer U_A edge lengths for a Ŝ that gathers the
        excess into drape-like folds (:mod:`airmat.design.fold_route`, the paper's §4 dome).
        False: keep the plain Ŝ and its verdict.
    """

    L: float | None = None
    mu1: float | None = None
    mu2: float = 0.05
    margin: float = 0.03
    step: float | None = None
    spacing: float = 0.02
    k_a1: float | None = None
    k_a2: float | None = None
    k_a3: float | None = None
    kappa_min: float = 0.25
    weight_min: float = 0.0
    n_kappa_points: int = 10
    tie_grid: float = 0.02
    face_metric: bool = True
    free_face_span: bool = True
    folds: bool = True
    end_dashes: bool = False
    L_end_min: float | None = None

    def weights(self) -> dict:
        """The U_A weights in use: given ones, else the surface side's defaults."""
        defaults = inspect.signature(approximate_surface).parameters
        return {k: float(getattr(self, k) if getattr(self, k) is not None else defaults[k].default)
                for k in ("k_a1", "k_a2", "k_a3")}

    def stripe_params(self, L: float) -> StripeParams:
        """The stripe tracer's parameters, with L resolved."""
        return StripeParams(L=L, mu1=L if self.mu1 is None else self.mu1, mu2=self.mu2, margin=self.margin, step=self.step,
                            kappa_min=self.kappa_min, weight_min=self.weight_min, end_dashes=self.end_dashes,
                            L_end_min=self.L_end_min)

    def file_dict(self, L: float) -> dict:
        """The parameters as written to design.json (mm, 1/m)."""
        sp, mm = self.stripe_params(L), _mm
        return {"L_mm": mm(L), "mu1_mm": mm(sp.mu1), "mu2_mm": mm(self.mu2), "margin_mm": mm(self.margin),
                "step_mm": mm(sp.step_used), "spacing_mm": mm(self.spacing), **self.weights(),
                "kappa_min_per_m": self.kappa_min,
                "weight_min": self.weight_min, "n_kappa_points": int(self.n_kappa_points),
                "tie_grid_mm": mm(self.tie_grid), "face_metric": bool(self.face_metric),
                "free_face_span": bool(self.free_face_span), "folds": bool(self.folds),
                **({"end_dashes": True, "L_end_min_mm": mm(sp.L_end_min_used)} if self.end_dashes else {})}


@dataclass(frozen=True, repr=False)
class DesignResult(Summarized):
    """Everything a design produced (SI units), from :func:`design` or read back from its folder.

    Attributes
    ----------
    name : str
        The target's name.
    approx : airmat.design.surface.ApproxSurface
        Ŝ with its Ω coordinates and constructibility report (and, in memory, the
        relaxation result and the curvature).
    pattern : airmat.design.pattern.Pattern
        The strings with lengths and tolerances.
    calibration : CalibrationSource
        The posterior samples the lengths were computed from.
    params : DesignParams
        With ``L`` resolved.
    seed : int
    mfield : airmat.design.field.MattressField or None
        The principal-curvature field on Ω (None when read from files).
    stripes : airmat.design.stripes.Stripes or None
        Lines and dashes of both families (None when read from files).
    source : str or None
        The folder the design was written to or read from, if any.
    timings : dict
        Seconds per stage (the surface side's stages, ``transfer``, ``stripes``, ``lengths``).
    refine : dict or None
        The ``refine`` block of design.json (mm) when the lengths were refined through the
        inflation (:func:`check.refine.refine`), else None.
    open_loop : tuple of airmat.design.pattern.TensionString or None
        A refined design's strings before any refinement, at their open-loop lengths, the
        dropped ones included: its inflations start from these strings' equilibrium and carry it
        on to the refined lengths (:func:`airmat.check.inflation_check.check`). None when not refined.
    fold_route : airmat.design.fold_route.FoldRoute or None
        What the fold route tried and chose, when the plain Ŝ contracted edges below its σ band; else None.
    """

    name: str
    approx: ApproxSurface = field(repr=False)
    pattern: Pattern
    calibration: CalibrationSource = field(repr=False)
    params: DesignParams
    seed: int
    mfield: MattressField | None = field(default=None, repr=False)
    stripes: Stripes | None = field(default=None, repr=False)
    source: str | None = None
    timings: dict = field(default_factory=dict, compare=False)
    refine: dict | None = None
    open_loop: tuple | None = field(default=None, repr=False)
    fold_route: FoldRoute | None = field(default=None, repr=False)

    def _summary(self):
        rep = self.approx.report
        rows = [("target", self.name), ("strings", len(self.pattern.strings)),
                ("constructible", "unknown" if rep is None else rep.constructible),
                ("calibration", "uncalibrated" if self.calibration.uncalibrated else self.calibration.label)]
        if self.refine:
            rows.append(("refined", "yes"))
        return "DesignResult", rows

    @property
    def mattress(self):
        """The mattress (airmat.design.mattress.Mattress)."""
        return self.approx.mattress


#: relative difference of the design's L from the calibration's beyond which the lengths are extrapolated
L_TOLERANCE = 0.10


def _span_notes(L: float, calibration) -> tuple:
    """A note (and a warning) when the design's L is not the one Equation 3 was calibrated at."""
    if abs(L / calibration.L - 1.0) <= L_TOLERANCE:
        return ()
    note = (f"L = {L * 1e3:.0f} mm differs from the calibration's L = {calibration.L * 1e3:.0f} mm: Equation 3 "
            f"was calibrated at {calibration.L * 1e3:.0f} mm, so these lengths are extrapolated (the simulated "
            f"specimen at L = 150 mm bends up to 25 % less than Equation 3 predicts: `airmat validate --L-mm 150`); "
            f"calibrate with specimens at {L * 1e3:.0f} mm to rely on them")
    log.warning(note)
    return (note,)


def design(target, mattress, *, calibration=None,
           params: DesignParams = DesignParams(), seed: int = 0, progress: bool = True,
           workers: int = 1) -> DesignResult:
    """Design the string pattern that bends ``mattress`` into an approximation of ``target``.

    Parameters
    ----------
    target : airmat.design.target.Target or mesh
        The guide surface S (m); any object with ``vertices``, ``faces`` and ``name``
        is taken as a Target (:meth:`airmat.design.target.Target.from_mesh`).
    mattress : airmat.design.mattress.Mattress
        W, H, thickness (m).
    calibration : CalibrationSource or airmat.calib.calibrate.Calibration, optional
        Posterior of Equation 3's Δ and d (a Calibration, as :func:`airmat.calibrate` or
        :func:`airmat.read_calibration` give it, is taken through
        :func:`~airmat.design.calibration_source.from_calibration`); default the paper's
        values, labelled uncalibrated (d = the mattress thickness).
    params : DesignParams
    seed : int
        Seed of every random step (the default calibration's samples).
    progress : bool
        Progress bar on the relaxation when on a terminal.
    workers : int
        Relaxations of the fold route at a time (:func:`airmat.design.fold_route.fold_route`: forked
        processes on Linux; the same Ŝ as one at a time). Where the target holds more Gaussian curvature
        than a disc reaches within the fold band (:func:`~airmat.design.fold_route.folds_likely`), the
        route's first ``workers`` relaxations start beside the plain one.

    Returns
    -------
    DesignResult

    Raises
    ------
    airmat.errors.InputError
        Impossible parameters (checked before any work), a target that does not fit the mattress.
    airmat.errors.ConvergenceError
        When the relaxation diverges.
    """
    if calibration is None:
        calibration = default_calibration(seed=seed, d=mattress.thickness)
    elif not isinstance(calibration, CalibrationSource):
        calibration = from_calibration(calibration)
    L = float(calibration.L if params.L is None else params.L)
    params = dataclasses.replace(params, L=L, mu1=L if params.mu1 is None else params.mu1)
    sp = params.stripe_params(L)
    check_stripe_params(sp, mattress.width, mattress.height)
    if not (params.tie_grid >= 0 and np.isfinite(params.tie_grid)):
        raise InputError(f"the tie grid pitch must be >= 0 mm (0: free ends), got {params.tie_grid * M_TO_MM!r}")
    reach = float(np.median(kappa_max(L, calibration.delta, calibration.d)))
    weights = params.weights()

    def relax(k_a1: float, folds: bool = False) -> ApproxSurface:
        # a folded Ŝ is judged by the fold band (the paper's built dome), the plain one by the default band
        band = {"sigma_band": FOLD_SIGMA_BAND} if folds else {}
        return approximate_surface(target, mattress, spacing=params.spacing, **{**weights, "k_a1": k_a1},
                                   kappa_max=reach, progress=progress, face_metric=params.face_metric,
                                   kappa_min=params.kappa_min, string_margin=params.margin, folds=folds, **band)

    def relax_folded(k_a1: float) -> ApproxSurface:
        return relax(k_a1, folds=True)

    # a target with more Gaussian curvature than a disc reaches within the fold band: the fold route's first
    # relaxations start beside the plain one (given up if the plain Ŝ needs no folds; the same Ŝ either way)
    early = (start_trials(relax_folded, k_a1=weights["k_a1"], workers=workers)
             if params.folds and workers > 1 and folds_likely(target) else None)
    try:
        approx = relax(weights["k_a1"])
    except BaseException:
        if early is not None:
            early.cancel()
        raise
    timings = dict(approx.timings)
    route = None
    if params.folds and needs_folds(approx.report):
        t = time.perf_counter()
        approx, route = fold_route(approx, relax_folded, k_a1=weights["k_a1"], workers=workers, started=early)
        timings["fold_route"] = time.perf_counter() - t
    elif early is not None:
        early.cancel()
    t = time.perf_counter()
    mfield = mattress_field(approx)
    timings["transfer"] = time.perf_counter() - t
    t = time.perf_counter()
    stripes = trace_stripes(mfield, sp)
    timings["stripes"] = time.perf_counter() - t
    t = time.perf_counter()
    dashes, snap = snap_dashes(stripes.dashes, grid=params.tie_grid, width=mattress.width, height=mattress.height)
    if sp.end_dashes:       # an end dash whose ends the grid put closer than the minimum (a line curving on Ω): none
        end = {d.id for d in stripes.dashes if d.length < L * (1.0 - 1e-6)}
        keep = np.array([d.id not in end or d.chord >= sp.L_end_min_used for d in dashes], bool)
        if not keep.all():
            log.info(f"{int((~keep).sum())} end dashes with ends closer than {sp.L_end_min_used * 1e3:.0f} mm once "
                     f"tied to the grid: left out")
            dashes = tuple(d for d, k in zip(dashes, keep) if k)
            snap = dataclasses.replace(snap, end_shift=snap.end_shift[keep], length_change=snap.length_change[keep])
    pattern = string_pattern(mfield, dashes, calibration, L=L, n_points=params.n_kappa_points,
                             approx=approx if params.free_face_span else None,
                             kappa_min=params.kappa_min, notes=stripes.notes, tie_grid=snap)
    cover = pattern_coverage(mfield, pattern.strings, dashes, approx.uv, width=mattress.width,
                             height=mattress.height, kappa_min=params.kappa_min, L=L, mu2=sp.mu2, margin=sp.margin,
                             end_dashes=sp.end_dashes)
    for note in cover.notes():
        log.info(note)
    pattern = dataclasses.replace(pattern, notes=pattern.notes + cover.notes() + _span_notes(L, calibration),
                                  coverage=cover.summary_mm())
    timings["lengths"] = time.perf_counter() - t
    return DesignResult(name=target.name, approx=approx, pattern=pattern, calibration=calibration, params=params,
                        seed=int(seed), mfield=mfield, stripes=stripes, timings=timings, fold_route=route)
